//! `<HOME>` handed to the kernel in the tick the host link is lost (a case
//! the `kernel_ticks` fuzz target reaches): the run starts and fails in the
//! same tick, as a homing run interrupted by a lost link does: H3, the
//! run's joints unhomed, the arm stops and latches. The monitor checks every
//! tick; it must tell this stop from one entered from Operational, or it
//! would flag SR-19 for the unhomed joints.

mod common;

use common::{both, Rig, START};
use kernel::{Event, HomingStatus, Request, Scalar, State, StopCause};

both!(home_in_the_tick_the_link_is_lost_fails_the_run_and_latches);

fn home_in_the_tick_the_link_is_lost_fails_the_run_and_latches<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.run(3);
    r.tick(Some(Request::Home));
    r.run_until(60_000, |o| o.status.state != State::Homing).expect("homes");
    assert_eq!(r.k.state(), State::Operational);
    r.run(200);
    r.plant.link_lost = true;
    let out = r.tick(Some(Request::Home));
    assert!(out.events.iter().any(|e| matches!(e, Event::HomingStarted { .. })), "{:?}", out.events);
    assert!(out.events.iter().any(|e| *e == Event::SoftEstop { cause: StopCause::LinkLost }), "{:?}", out.events);
    assert_eq!(out.status.state, State::Stopping);
    assert_eq!(out.status.homing, HomingStatus::Failed);
    assert_ne!(out.status.homed, 0b11_1111, "the aborted run's joints are not homed");
    r.run_until(200, |o| o.status.state == State::SoftEstop).expect("latches");
}
