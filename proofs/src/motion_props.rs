//! Sampled end-to-end tests of the kernel's discrete motion rules, from
//! states reached through the public API (`setup`; run by the shim,
//! `setup::end_to_end!`, **not Kani harnesses**): a lost link stops a
//! moving arm at once and the stop latches (SR-31), `<HOME>` while moving
//! stops first and then homes (SR-14). Every tick is also checked by the
//! safety monitor. The one-tick clauses (a moving arm that loses the link
//! leaves Operational in that tick; only `<ENABLE>` leaves a latch, SR-5)
//! are the one-step lemmas' (`state_props`, with the induction argued in
//! `kernel_props`); these runs add the ramp's end in a latch after a lost
//! link, and the homing run a `<HOME>` queued behind a stop starts, which
//! no lemma draws (a Stopping state with a queued home is not offered by
//! `Kernel::from_spec`).

use crate::numeric::any_target;
use crate::setup::{end_to_end, here, operational, still, target, Checked, Sym, PROOF_CONFIG};
use kernel::config::AXES;
use kernel::{Authority, Event, Fx, Reject, Request, State, StopCause};

/// An operational kernel with every set-point moving toward a target
/// 0.019 rad away (a valid stream sample: within the set-point's reach from
/// rest, SR-30, 0.020 rad under `PROOF_CONFIG`'s 2 ms longest segment).
#[cfg_attr(not(kani), kani::loops)]
fn moving<S: Sym>() -> (Checked<S>, Authority) {
    let (mut k, a) = operational::<S>();
    let p = here(&mut k);
    let mut t = target(p);
    for i in 0..AXES {
        let j = &PROOF_CONFIG.joints[i];
        // Away from the limit the arm homed next to.
        let d = if j.homing.direction.sign() > 0.0 { -0.019 } else { 0.019 };
        t.position[i] = p[i].plus(S::from_f32(d));
    }
    let o = k.tick(&still(0), Some(Request::Motion(t)));
    assert!(o.events.is_empty());
    (k, a)
}

/// SR-31: the host link lost while the arm moves starts the soft stop in
/// the same tick (`SOFT_ESTOP LINK_LOST`), whatever request comes with it;
/// the stop latches.
#[cfg_attr(not(kani), kani::loops)]
fn link_loss<S: Sym>() {
    let (mut k, _) = moving::<S>();
    let extra: u8 = kani::any::<u8>() % 2;
    for _ in 0..extra {
        k.tick(&still(0), None);
    }
    let mut sense = still(0);
    sense.link_lost = true;
    let req = if kani::any() { Some(Request::Motion(any_target::<S>())) } else { None };
    let o = k.tick(&sense, req);
    kani::cover!(o.status.state == State::Stopping, "stopping");
    assert!(o.status.state == State::Stopping || o.status.state == State::Fault);
    if o.status.state == State::Stopping {
        assert!(o.events.iter().any(|e| *e == Event::SoftEstop { cause: StopCause::LinkLost }));
    }
    // Ramp of 4 ticks (loop bound 6).
    for _ in 0..6 {
        k.tick(&sense, None);
    }
    assert!(k.state() == State::SoftEstop || k.state() == State::Fault);
}

// Footprint: 14 symbolic values, 37 ticks (the extra tick, the request (up to a target)). Unwind: setup::run_homing: HOMING_TICKS = 25 ticks; 6 ticks of ramp here; 6 axes.
end_to_end!(link_loss_while_moving_soft_stops_at_once_f32, link_loss::<f32>, unwind 26, footprint 14 symbolic values, 37 ticks);
// Footprint: 14 symbolic values, 37 ticks (the extra tick, the request (up to a target)). Unwind: as the f32 test.
end_to_end!(link_loss_while_moving_soft_stops_at_once_fx, link_loss::<Fx>, unwind 26, footprint 14 symbolic values, 37 ticks);

/// SR-14: `<HOME>` while the arm moves is not a step into homing: the arm
/// stops first (Stopping, `HOMING_QUEUED stopping first`), then homing
/// starts when the ramp ends; no latch on the way.
#[cfg_attr(not(kani), kani::loops)]
fn home_while_moving<S: Sym>() {
    let (mut k, _) = moving::<S>();
    let o = k.tick(&still(0), Some(Request::Home));
    assert!(o.status.state == State::Stopping);
    assert!(o.events.iter().any(|e| *e == Event::HomingAfterStop));
    // Ramp of 4 ticks (loop bound 6).
    let mut started = false;
    for _ in 0..6 {
        let o = k.tick(&still(0), None);
        assert!(o.status.state != State::SoftEstop);
        started |= o.events.iter().any(|e| matches!(e, Event::HomingStarted { .. }));
    }
    assert!(started && k.state() == State::Homing);
    // A second <HOME> meanwhile is refused as homing.
    let o = k.tick(&still(0), Some(Request::Home));
    assert!(o.events.iter().any(|e| matches!(e, Event::Rejected { reason: Reject::Homing, .. })));
}

// Footprint: 0 symbolic values, 37 ticks (none: a deterministic replay). Unwind: setup::run_homing: 25 ticks; 6 ticks of ramp here; 6 axes.
end_to_end!(home_while_moving_stops_first_f32, home_while_moving::<f32>, unwind 26, footprint 0 symbolic values, 37 ticks);
// Footprint: 0 symbolic values, 37 ticks (none: a deterministic replay). Unwind: as the f32 test.
end_to_end!(home_while_moving_stops_first_fx, home_while_moving::<Fx>, unwind 26, footprint 0 symbolic values, 37 ticks);
