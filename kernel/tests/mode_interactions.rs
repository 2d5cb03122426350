//! Where modes meet: a link lost in every phase of a homing run, a switch
//! pressed while its joint waits or since power-on, a stream that stops at
//! speed, and a cause the kernel cannot see at rest. Each in both numeric
//! variants, every tick checked by the monitor (`common::Rig`).
//!
//! The rules (SAFETY.md SR-6, SR-10, SR-19, SR-29, SR-31): a joint's switch
//! is its homing input until the joint is homed, in every state; a homing
//! run ended by a lost link latches (SoftEstop, H3) and `<ENABLE>` then
//! `<HOME>` bring the arm back; at the command timeout the arm holds when
//! every set-point is at rest on its last target.

mod common;

use common::{both, Rig};
use kernel::config::AXES;
use kernel::homing::Phase;
use kernel::{Event, FaultReason, HomingStatus, Request, Scalar, State, StopCause};

/// J1 past its switch (J1 seeks negative, switch at -1.72 rad): the pose
/// a host meets after the arm was left there.
const J1_ON_SWITCH: [f64; AXES] = [-1.75, -0.5, 1.0, 0.0, 0.0, 0.0];
const DEFAULT_POSE: [f64; AXES] = [0.0, -0.5, 1.0, 0.0, 0.0, 0.0];

both!(
    link_lost_while_a_pressed_joint_waits_latches_and_recovers,
    link_lost_during_backoff_on_the_switch_latches_and_recovers,
    link_lost_late_in_a_seek_is_no_position_fault,
    link_lost_in_every_phase_of_j6_recovers,
    stream_stopped_at_speed_holds,
    stall_is_invisible_at_rest_and_faults_again,
);

/// Runs until `f` holds on the kernel, at most `max` ticks.
fn until<S: Scalar>(r: &mut Rig<S>, max: u32, mut f: impl FnMut(&Rig<S>) -> bool) -> bool {
    for _ in 0..max {
        if f(r) {
            return true;
        }
        r.tick(None);
    }
    f(r)
}

fn faults<S: Scalar>(r: &Rig<S>) -> Vec<FaultReason> {
    r.events
        .iter()
        .filter_map(|e| match e {
            Event::Fault(f) => Some(*f),
            _ => None,
        })
        .collect()
}

/// The link is lost now: the run fails (H3), the ramp ends latched with
/// no fault; with the link back, `<ENABLE>` leads to Unhomed and `<HOME>`
/// homes every joint.
fn lose_link_then_recover<S: Scalar>(r: &mut Rig<S>, what: &str) {
    r.plant.link_lost = true;
    let out = r.tick(None);
    assert!(
        out.events.iter().any(|e| *e == Event::SoftEstop { cause: StopCause::LinkLost }),
        "{what}: no link-loss stop: {:?}",
        out.events
    );
    assert_eq!(out.status.homing, HomingStatus::Failed, "{what}: H3");
    // The ramp of a homing run does not follow set-points (the joints are
    // not homed): every set-point is held at rest where the run left it,
    // so advancing or not advancing them in this ramp is the same.
    assert!(r.k.setpoints_at_rest(), "{what}: a set-point moves in the homing run's ramp");
    assert!(
        until(r, 400, |r| {
            assert!(r.k.setpoints_at_rest(), "{what}: a set-point moves in the homing run's ramp");
            r.k.state() != State::Stopping
        }),
        "{what}: the ramp ends"
    );
    r.run(500);
    assert_eq!(faults(r), vec![], "{what}: a lost link in homing faults nothing");
    assert_eq!(r.k.state(), State::SoftEstop, "{what}: latched");
    r.plant.link_lost = false;
    let out = r.enable();
    assert!(
        out.events.iter().any(|e| *e == Event::Enabled(State::Unhomed)),
        "{what}: <ENABLE> refused: {:?}",
        out.events
    );
    r.tick(Some(Request::Home));
    assert!(until(r, 60_000, |r| r.k.state() != State::Homing), "{what}: homing ends");
    assert_eq!(r.k.state(), State::Operational, "{what}: homed again; events {:?}", r.events);
    assert_eq!(faults(r), vec![], "{what}");
}

fn link_lost_while_a_pressed_joint_waits_latches_and_recovers<S: Scalar>() {
    let mut r = Rig::<S>::new(J1_ON_SWITCH);
    r.run(3);
    assert_ne!(r.plant.switches() & 1, 0, "J1 starts on its switch");
    r.tick(Some(Request::Home));
    assert!(until(&mut r, 10_000, |r| r.k.homing_phases()[5] == Phase::FastSeek), "J6 seeks");
    r.run(300);
    assert_eq!(r.k.homing_phases()[0], Phase::Waiting);
    lose_link_then_recover(&mut r, "J1 waiting on its switch");
}

fn link_lost_during_backoff_on_the_switch_latches_and_recovers<S: Scalar>() {
    let mut r = Rig::<S>::new(DEFAULT_POSE);
    r.run(3);
    r.tick(Some(Request::Home));
    assert!(until(&mut r, 10_000, |r| r.k.homing_phases()[5] == Phase::BackOff), "J6 backs off");
    r.tick(None);
    assert_ne!(r.plant.switches() & 0b10_0000, 0, "J6 still on its switch");
    lose_link_then_recover(&mut r, "J6 backing off its switch");
}

fn link_lost_late_in_a_seek_is_no_position_fault<S: Scalar>() {
    // J6's pre-homing estimate passes its joint limit plus the margin
    // before it meets its switch (it started 0.4 rad past its true zero's
    // reading): a joint not homed is not checked against its limits.
    let mut r = Rig::<S>::new([0.0, -0.5, 1.0, 0.0, 0.0, -0.45]);
    r.run(3);
    r.tick(Some(Request::Home));
    let cfg = kernel::config::PAROL6;
    let over = cfg.joints[5].limit_max + cfg.position_margin + 0.02;
    assert!(
        until(&mut r, 10_000, |r| r.k.status(0).position[5].to_f32() > over),
        "J6's estimate passes its limit while seeking"
    );
    assert_eq!(r.k.homing_phases()[5], Phase::FastSeek);
    lose_link_then_recover(&mut r, "J6 seeking beyond its limit");
}

fn link_lost_in_every_phase_of_j6_recovers<S: Scalar>() {
    for phase in [Phase::FastSeek, Phase::BackOff, Phase::SlowSeek, Phase::Release, Phase::Settle] {
        let mut r = Rig::<S>::new(J1_ON_SWITCH);
        r.run(3);
        r.tick(Some(Request::Home));
        assert!(until(&mut r, 10_000, |r| r.k.homing_phases()[5] == phase), "J6 reaches {phase:?}");
        lose_link_then_recover(&mut r, &format!("J6 in {phase:?}, J1 on its switch"));
    }
}

fn stream_stopped_at_speed_holds<S: Scalar>() {
    // A 100 Hz J1 stream at 1.5 rad/s that simply stops: the set-point
    // brakes onto the last target and the arm holds there (HOLDING), the
    // estimate's residual notwithstanding.
    for (hz, speed) in [(100u32, 1.5f64), (100, 1.8), (100, 2.0), (50, 1.5)] {
        let mut r = Rig::<S>::new(DEFAULT_POSE);
        r.boot_and_home();
        r.run(200);
        let start = r.k.status(0).position.map(|x| f64::from(x.to_f32()));
        let period = 1000 / hz;
        let mut p = start;
        let mut t = 0;
        while p[0] < start[0] + 1.0 {
            if t % period == 0 {
                p[0] += speed * f64::from(period) / 1000.0;
                r.motion(p);
            } else {
                r.tick(None);
            }
            t += 1;
        }
        let before = r.events.len();
        r.run(400);
        let after = &r.events[before..];
        assert!(after.contains(&Event::Holding), "{hz} Hz at {speed} rad/s: no HOLDING: {after:?} in {:?}", r.events);
        assert!(
            !after.iter().any(|e| matches!(e, Event::SoftEstop { .. })),
            "{hz} Hz at {speed} rad/s: latched: {after:?}"
        );
        assert_eq!(r.k.state(), State::Operational, "{hz} Hz at {speed} rad/s");
        assert_eq!(faults(&r), vec![]);
    }
}

fn stall_is_invisible_at_rest_and_faults_again<S: Scalar>() {
    // A stalled J3 faults within the following-error bound; at rest the
    // stall cannot be seen, so <ENABLE> is taken, and the next motion
    // faults again within the bound.
    let mut r = Rig::<S>::new(DEFAULT_POSE);
    r.boot_and_home();
    r.run(100);
    r.plant.stalled = 0b100;
    let mut p = r.k.status(0).position.map(|x| f64::from(x.to_f32()));
    p[2] -= 0.5;
    r.goto(p);
    let n = r.run_until(500, |o| o.status.state == State::Fault).expect("faults");
    assert!(matches!(r.k.fault().map(|f| f.reason), Some(FaultReason::FollowingError { axis: 2 })));
    assert!(n < 200, "faulted after {n} ticks");
    r.run(200);
    let out = r.enable();
    assert!(out.events.iter().any(|e| *e == Event::Enabled(State::Operational)), "{:?}", out.events);
    r.run(10);
    r.goto(p);
    let n = r.run_until(500, |o| o.status.state == State::Fault).expect("faults again");
    assert!(matches!(r.k.fault().map(|f| f.reason), Some(FaultReason::FollowingError { axis: 2 })));
    assert!(n < 200, "faulted again after {n} ticks");
}
