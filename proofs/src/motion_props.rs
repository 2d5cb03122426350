//! The kernel's discrete motion rules, from states reached through the public API
//! (`setup`): only `<ENABLE>` clears a latch (SR-5), a lost link stops a
//! moving arm at once (SR-31), `<HOME>` while moving stops first and then
//! homes (SR-14). Every tick is also checked by the safety monitor.

use crate::numeric::any_target;
use crate::setup::{here, operational, still, target, Checked, Sym, PROOF_CONFIG};
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

/// SR-5: in SoftEstop or Fault, no request but an accepted `<ENABLE>` leaves
/// the latch: `<HOME>`, `<HOMEn>` for any n, and any motion target are
/// refused, whatever the sensors say (a new cause may turn SoftEstop into
/// Fault, never into anything else).
#[cfg_attr(not(kani), kani::loops)]
fn only_enable_clears<S: Sym>() {
    let (mut k, _) = moving::<S>();
    let to_fault: bool = kani::any();
    if to_fault {
        let switch: u8 = kani::any::<u8>() % AXES as u8;
        k.tick(&still(1 << switch), None);
        assert!(k.state() == State::Fault);
    } else {
        // Timeout 3 ticks + ramp 4 ticks: latched within 8 (loop bound).
        for _ in 0..8 {
            k.tick(&still(0), None);
        }
        assert!(k.state() == State::SoftEstop);
    }
    let before = k.state();
    let req = match kani::any::<u8>() % 3 {
        0 => Request::Home,
        1 => Request::HomeJoint(kani::any::<u8>() % 8),
        _ => Request::Motion(any_target::<S>()),
    };
    let limits: u8 = if kani::any() { 0 } else { kani::any() };
    let o = k.tick(&still(limits), Some(req));
    kani::cover!(before == State::SoftEstop, "from SoftEstop");
    kani::cover!(before == State::Fault, "from Fault");
    kani::cover!(o.status.state == State::Fault && before == State::SoftEstop, "a new cause in SoftEstop");
    assert!(o.status.state == before || o.status.state == State::Fault);
    assert!(o.events.iter().any(|e| matches!(e, Event::Rejected { .. })));
    assert!(o.act.velocity.iter().all(|v| *v == S::ZERO));
}

/// Footprint: 17 symbolic values, 38 ticks (the latch's cause and switch, the request (up to a target), the switches).
#[kani::proof]
#[kani::unwind(26)] // setup::run_homing: HOMING_TICKS = 25 ticks; 8 ticks here; 6 axes
fn only_enable_clears_a_latch_f32() {
    only_enable_clears::<f32>();
}
/// Footprint: 17 symbolic values, 38 ticks (the latch's cause and switch, the request (up to a target), the switches).
#[kani::proof]
#[kani::unwind(26)] // as above
fn only_enable_clears_a_latch_fx() {
    only_enable_clears::<Fx>();
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

/// Footprint: 14 symbolic values, 37 ticks (the extra tick, the request (up to a target)).
#[kani::proof]
#[kani::unwind(26)] // as above
fn link_loss_while_moving_soft_stops_at_once_f32() {
    link_loss::<f32>();
}
/// Footprint: 14 symbolic values, 37 ticks (the extra tick, the request (up to a target)).
#[kani::proof]
#[kani::unwind(26)] // as above
fn link_loss_while_moving_soft_stops_at_once_fx() {
    link_loss::<Fx>();
}

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

/// Footprint: 0 symbolic values, 37 ticks (none: a deterministic replay).
#[kani::proof]
#[kani::unwind(26)] // as above
fn home_while_moving_stops_first_f32() {
    home_while_moving::<f32>();
}
/// Footprint: 0 symbolic values, 37 ticks (none: a deterministic replay).
#[kani::proof]
#[kani::unwind(26)] // as above
fn home_while_moving_stops_first_fx() {
    home_while_moving::<Fx>();
}
