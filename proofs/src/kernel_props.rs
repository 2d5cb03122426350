//! Sampled end-to-end tests: multi-tick runs of the real `Kernel::tick`
//! from power-on, through the public API (see `setup`), run by the shim
//! (`setup::end_to_end!`) and **not Kani harnesses** (11 to 57 ticks each).
//!
//! Their safety assertions are carried to every tick by one-step lemmas
//! and an induction (`state_props`): the base case is the state
//! `Kernel::new` builds (`initial_state_satisfies_the_invariant`, and
//! `first_tick_is_still_and_starts_at_the_readings_*` for the first
//! tick); the step is one tick from any state the kernel's invariant
//! admits in Unhomed, Operational, Stopping, SoftEstop or Fault, with any
//! sensors and request, which keeps the invariant and asserts the
//! property (`from_any_*`, `from_one_axis_*`). The induction's condition:
//! every tick from a Boot state after the first, or from a Homing state,
//! keeps the invariant: no lemma draws those states (`Kernel::from_spec`
//! offers neither), so that rests on these runs and the model, sampled.
//! What each test adds beyond the lemmas is written beside it.

use crate::numeric::any_mostly_in;
use crate::setup::{end_to_end, here, operational, still, target, Checked, Sym, COUNTS, PROOF_CONFIG};
use kernel::config::AXES;
use kernel::homing::Phase;
use kernel::{EncoderSample, Event, FaultReason, Fx, Reject, Request, RequestKind, Scalar, State, TickOutput};

fn all_zero<S: Scalar>(o: &TickOutput<S>) -> bool {
    o.act.velocity.iter().all(|v| *v == S::ZERO) && o.act.step_rate.iter().all(|r| *r == 0)
}

// Every tick of these tests is checked by the safety monitor
// (`setup::Checked`: SR-1, SR-2, SR-4..SR-11, SR-13, SR-15..SR-19, SR-25)
// and the kernel's state invariant; each test states its own property.

/// Ticks [`from_power_on`] runs after the first: one to start homing and
/// the seven J6 needs on the stationary arm (`setup::HOMING_TICKS` / 3),
/// then two in which the second group (J5, J4) moves, so the homing-order
/// assertion sees an axis that depends on another.
const POWER_ON_TICKS: u32 = 10;

/// Induction, and where it stops. The one-step lemmas assert, from every
/// admitted Unhomed, Operational, Stopping, SoftEstop and Fault state, no
/// output outside Operational, Stopping and Homing (SR-1), the refusal of
/// motion outside Operational (SR-15), the refusal of `<HOMEn>` while a
/// dependency is unhomed (SR-13), and in the tick a homing run starts,
/// output only on an axis in a moving homing phase whose dependencies are
/// homed (SR-13, SR-16); `first_tick_is_still_and_starts_at_the_readings_*`
/// asserts SR-1 and SR-15 for the first tick from `Kernel::new`. With the
/// invariant (base `initial_state_satisfies_the_invariant`, kept by every
/// lemma) they hold on every tick from those states. What only this run
/// checks: the ticks inside a homing run (the homing order as groups
/// finish, the monitor's check) and Boot after its first tick: sampled,
/// every tick checked by the monitor.
///
/// SR-1, SR-13, SR-15, SR-16: from power-on, any sequence of
/// [`POWER_ON_TICKS`] requests and sensors: nothing moves unhomed; motion is
/// refused outside Operational; in homing, only axes whose dependencies are
/// homed move (the monitor's check, with its own copy of the homing order),
/// and the run reaches the second group.
#[cfg_attr(not(kani), kani::loops)]
fn from_power_on<S: Sym>() {
    let (mut k, auth) = Checked::<S>::new();
    // First tick: any valid readings (nothing moves at power-on).
    let mut first = still(kani::any());
    for e in first.encoders.iter_mut() {
        *e = EncoderSample::Count(kani::any::<u16>() & 0x0fff);
    }
    let o = k.tick(&first, None);
    assert!(all_zero(&o));
    // SR-1: each observer starts at rest, at its first reading.
    kani::cover!(o.status.state == State::Unhomed, "booted on the first tick");
    for i in 0..AXES {
        if let EncoderSample::Count(c) = first.encoders[i] {
            let j = &PROOF_CONFIG.joints[i];
            let expect = S::from_counts(i32::from(c), S::wide_from_f64(j.rad_per_count()));
            assert!(o.status.position[i] == expect && o.status.velocity[i] == S::ZERO);
        }
    }
    let mut second_group_moved = false;
    for n in 0..POWER_ON_TICKS {
        let before = k.state();
        // Mostly a home request on the first of these ticks, so the run can
        // get far; symbolically any request on every tick.
        let pick = if n == 0 && kani::any() { 0 } else { kani::any::<u8>() % 5 };
        let req = match pick {
            0 => Some(Request::Home),
            1 => Some(Request::HomeJoint(kani::any())),
            2 => Some(Request::Enable(auth.enable())),
            // A fixed target: outside Operational a motion request is
            // refused by its mode before any value of it is read
            // (`accept_motion` asks `mode_refusal` first), and these ticks
            // never reach Operational (asserted below), so a symbolic
            // target would only add 12 symbolic values per tick.
            3 => Some(Request::Motion(target([S::ZERO; AXES]))),
            _ => None,
        };
        // Homing takes at least `setup::HOMING_TICKS` (25) ticks: more than
        // this run has.
        assert!(before != State::Operational);
        let motion = matches!(req, Some(Request::Motion(_)));
        // Switches: mostly exactly those of the seeking axes (homing can
        // proceed), otherwise any; symbolically any value on every tick.
        let mut seeking = 0u8;
        for (i, p) in k.homing_phases().iter().enumerate() {
            if matches!(p, Phase::FastSeek | Phase::SlowSeek) {
                seeking |= 1 << i;
            }
        }
        first.limits = if !kani::any::<u8>().is_multiple_of(8) { seeking } else { kani::any() };
        let o = k.tick(&first, req);
        kani::cover!(motion && before != State::Operational, "motion outside Operational (antecedent)");
        if motion && before != State::Operational {
            assert!(o.events.iter().any(|e| matches!(e, Event::Rejected { request: RequestKind::Motion, .. })));
        }
        kani::cover!(o.status.state == State::Homing, "homing reached");
        let phases = k.homing_phases();
        second_group_moved |= o.status.state == State::Homing && (phases[3].is_moving() || phases[4].is_moving());
    }
    kani::cover!(second_group_moved, "an axis of the second homing group moved (after J6 homed)");
}

// Footprint: 48 symbolic values, 11 ticks (the first readings, then per tick a request and the switches). Unwind: POWER_ON_TICKS = 10 ticks; kernel, monitor and the encoder loops: 6 axes (7).
end_to_end!(nothing_moves_unless_homed_and_homing_order_holds_f32, from_power_on::<f32>, unwind 11, footprint 48 symbolic values, 11 ticks);
// Footprint: 48 symbolic values, 11 ticks (the first readings, then per tick a request and the switches). Unwind: as the f32 test.
end_to_end!(nothing_moves_unless_homed_and_homing_order_holds_fx, from_power_on::<Fx>, unwind 11, footprint 48 symbolic values, 11 ticks);

/// SR-7, SR-8, SR-29: after one accepted stream sample near the set-point,
/// silence: if a set-point still moves when the timeout expires, the ramp
/// starts (speeds never increase nor reverse, every axis exactly zero within
/// the ramp) and the stop latches; if every joint is already at rest at its
/// target, it holds (no latch) and the next command is taken. The
/// one-step lemmas assert the tick the timeout expires in (a stop with a
/// set-point travelling, a hold with every set-point at rest, nothing
/// before) and each ramp tick (never faster, never reversed, all zero and
/// SoftEstop at its last tick); this run adds what spans ticks: a
/// timeout armed by a real command reaching its expiry, the ramp's length,
/// the next command taken after a hold.
#[cfg_attr(not(kani), kani::loops)]
fn soft_stop<S: Sym>() {
    let (mut k, _) = operational::<S>();
    let p = here(&mut k);
    // No timeout before the first command (SR-8): the setup ran many ticks.
    assert!(k.state() == State::Operational);
    let mut t = target(p);
    // A sample within 0.019 rad of the set-point and inside the limits: a
    // valid stream sample (within the set-point's reach from rest, SR-30:
    // 0.020 rad under `PROOF_CONFIG`; never a TARGET_JUMP); or exactly the
    // set-point.
    let still_target: bool = kani::any();
    for i in 0..AXES {
        if still_target {
            break;
        }
        let j = &PROOF_CONFIG.joints[i];
        let d = any_mostly_in(S::from_f32(-0.019), S::from_f32(0.019));
        let d = if d.is_finite() { d.clamp_between(S::from_f32(-0.019), S::from_f32(0.019)) } else { S::ZERO };
        t.position[i] = p[i].plus(d).clamp_between(S::from_f32(j.limit_min), S::from_f32(j.limit_max));
    }
    let o = k.tick(&still(0), Some(Request::Motion(t)));
    assert!(o.status.timeout_armed, "{:?} {:?}", o.events, t);
    // Timeout 3 ticks + ramp 4 ticks + margin: 12 ticks (loop bound). The
    // monitor checks the ramp on every tick (SR-7: starts exactly at the
    // timeout, never faster, never reversed, at most vmax/N per tick,
    // exactly N ticks to zero) and the hold (SR-29).
    let mut stopped_at = None;
    let mut held = false;
    for n in 0..12u32 {
        let o = k.tick(&still(0), None);
        if o.status.state == State::SoftEstop && stopped_at.is_none() {
            stopped_at = Some(n);
            assert!(all_zero(&o));
        }
        held |= o.events.iter().any(|e| *e == Event::Holding);
    }
    kani::cover!(held, "at rest at the timeout: holds");
    kani::cover!(stopped_at.is_some(), "moving at the timeout: latches");
    if held {
        assert!(k.state() == State::Operational && stopped_at.is_none());
        // The next command is taken without <ENABLE>.
        let o = k.tick(&still(0), Some(Request::Motion(target(p))));
        assert!(o.events.iter().all(|e| !matches!(e, Event::Rejected { .. })));
    } else {
        // 3 ticks of timeout + 4 of ramp, counted from the command's tick.
        assert!(matches!(stopped_at, Some(n) if n <= 8));
        assert!(k.state() == State::SoftEstop);
        // Latched: motion and <HOME> refused.
        let o = k.tick(&still(0), Some(Request::Motion(target(p))));
        assert!(o.events.iter().any(|e| matches!(e, Event::Rejected { reason: Reject::Latched, .. })));
        let o = k.tick(&still(0), Some(Request::Home));
        assert!(o.events.iter().any(|e| matches!(e, Event::Rejected { reason: Reject::Latched, .. })));
        assert!(k.state() == State::SoftEstop);
    }
}

// Footprint: 7 symbolic values, 43 ticks (a sample near the set-point; 28 set-up ticks, then the silence). Unwind: setup::run_homing: 25 ticks; 12 ticks of silence here; 6 axes.
end_to_end!(soft_stop_ramps_monotonically_to_zero_and_latches_f32, soft_stop::<f32>, unwind 26, footprint 7 symbolic values, 43 ticks);
// Footprint: 7 symbolic values, 43 ticks (a sample near the set-point; 28 set-up ticks, then the silence). Unwind: as the f32 test.
end_to_end!(soft_stop_ramps_monotonically_to_zero_and_latches_fx, soft_stop::<Fx>, unwind 26, footprint 7 symbolic values, 43 ticks);

/// SR-11: up to `encoder_invalid_limit` lost samples in a row are ridden
/// through; one more faults every axis. The one-step lemmas assert each
/// step from every admitted state (below the limit an invalid sample is
/// ridden through, at the limit one more faults); this run adds the count
/// from sample to sample (each loss counted, none forgiven early), which
/// the invariant states as a bound but no lemma can read back.
#[cfg_attr(not(kani), kani::loops)]
fn encoder_loss<S: Sym>() {
    let (mut k, _) = operational::<S>();
    let axis = usize::from(kani::any::<u8>() % AXES as u8);
    kani::cover!(axis == AXES - 1, "last axis");
    let mut s = still(0);
    s.encoders[axis] = EncoderSample::Lost;
    // Bound: encoder_invalid_limit (2) + 1 ticks.
    for _ in 0..PROOF_CONFIG.encoder_invalid_limit {
        let o = k.tick(&s, None);
        assert!(o.status.state == State::Operational);
    }
    let o = k.tick(&s, None);
    assert!(o.status.state == State::Fault);
    assert!(o.status.fault.map(|f| f.reason) == Some(kernel::FaultReason::EncoderLost { axis: axis as u8 }));
}

// Footprint: 1 symbolic values, 30 ticks (the axis). Unwind: setup::run_homing: 25 ticks; encoder_invalid_limit (2) ticks here; 6 axes.
end_to_end!(encoder_loss_beyond_the_tolerance_faults_f32, encoder_loss::<f32>, unwind 26, footprint 1 symbolic values, 30 ticks);
// Footprint: 1 symbolic values, 30 ticks (the axis). Unwind: as the f32 test.
end_to_end!(encoder_loss_beyond_the_tolerance_faults_fx, encoder_loss::<Fx>, unwind 26, footprint 1 symbolic values, 30 ticks);

/// SR-14: homing can be repeated: a second `<HOME>` from Operational runs
/// and completes again (a deterministic replay; a homing run is a Homing
/// state, which no lemma draws).
#[cfg_attr(not(kani), kani::loops)]
fn rehome<S: Sym>() {
    let (mut k, _) = operational::<S>();
    let o = k.tick(&still(0), Some(Request::Home));
    assert!(o.status.state == State::Homing);
    crate::setup::run_homing(&mut k);
    assert!(k.state() == State::Operational);
    kani::cover!(true);
}

// Footprint: 0 symbolic values, 53 ticks (none: a deterministic replay). Unwind: setup::run_homing, twice: 25 ticks per entry; 6 axes.
end_to_end!(homing_is_repeatable_f32, rehome::<f32>, unwind 26, footprint 0 symbolic values, 53 ticks);
// Footprint: 0 symbolic values, 53 ticks (none: a deterministic replay). Unwind: as the f32 test.
end_to_end!(homing_is_repeatable_fx, rehome::<Fx>, unwind 26, footprint 0 symbolic values, 53 ticks);

/// Ticks [`runaway`] drives one encoder: enough for the observer's estimate
/// to pass the runaway threshold at the largest plausible step per tick
/// (measured: J1 crosses 3.75 rad/s in about 15 ticks at 55 counts/tick).
const RUNAWAY_TICKS: u32 = 30;

/// Induction: the assertion ("a tick whose estimate is above the
/// runaway threshold ends in Fault") is the SR-9 clause of the one-step
/// lemmas `from_any_*_state_*` and `from_one_axis_*_state_*`
/// (`state_props`), which hold for one tick from every state the kernel's
/// invariant admits in the modes they draw, with any sensors and request,
/// and keep the invariant; the base case is
/// `initial_state_satisfies_the_invariant`. So, under the condition stated
/// in the module documentation (the Boot and Homing ticks keep the
/// invariant, sampled), the assertion holds on every tick of every run of
/// the real configuration (the lemmas use `PAROL6`). The operational
/// lemmas also cover a runaway fault in one tick, from an admitted state.
/// What this run adds is reachability from power-on: the threshold is
/// reached under a plausible constant step from rest, and the fault is a
/// runaway (its covers).
///
/// SR-9: one joint's encoder advances by a constant step per tick, any step
/// up to the plausibility window (so the estimate follows it rather than
/// faulting as a jump): in every tick whose estimated speed is above the
/// runaway threshold, the kernel is in Fault. The cover shows the threshold
/// is reached and the fault is a runaway.
#[cfg_attr(not(kani), kani::loops)]
fn runaway<S: Sym>() {
    let (mut k, _) = operational::<S>();
    let axis = usize::from(kani::any::<u8>() % AXES as u8);
    let j = &PROOF_CONFIG.joints[axis];
    let window = j.max_jump_counts(PROOF_CONFIG.tick_hz);
    // Any step in -window..=window (u8 draws clamped: every value reachable,
    // the largest often).
    let step = i32::from(kani::any::<u8>()).min(window);
    let step = if kani::any() { step } else { -step };
    let runaway = S::from_f32(j.runaway_velocity);
    let mut s = still(0);
    let mut count = i32::from(COUNTS[axis]);
    let mut fired = false;
    for _ in 0..RUNAWAY_TICKS {
        count = (count + step).rem_euclid(4096);
        s.encoders[axis] = EncoderSample::Count(count as u16);
        let o = k.tick(&s, None);
        let fast = o.status.velocity[axis].abs() > runaway;
        kani::cover!(fast, "estimate above the runaway threshold (antecedent)");
        if fast {
            assert!(o.status.state == State::Fault);
        }
        fired |= matches!(o.status.fault.map(|f| f.reason), Some(FaultReason::Runaway { .. }));
        if o.status.state == State::Fault {
            break; // latched; nothing further to see
        }
    }
    kani::cover!(fired, "a runaway fault");
}

// Footprint: 3 symbolic values, 57 ticks (the axis, the step and its sign). Unwind: RUNAWAY_TICKS = 30 (setup::run_homing: 21); 6 axes.
end_to_end!(runaway_faults_when_the_estimate_exceeds_the_threshold_f32, runaway::<f32>, unwind 31, footprint 3 symbolic values, 57 ticks);
// Footprint: 3 symbolic values, 57 ticks (the axis, the step and its sign). Unwind: as the f32 test.
end_to_end!(runaway_faults_when_the_estimate_exceeds_the_threshold_fx, runaway::<Fx>, unwind 31, footprint 3 symbolic values, 57 ticks);
