//! Whole-kernel properties: one or a few ticks of the real `Kernel::tick`
//! from states reached through the public API (see `setup`).

use crate::numeric::{any_mostly_in, any_target};
use crate::setup::{here, operational, still, target, Checked, Sym, COUNTS, PROOF_CONFIG};
use kernel::config::AXES;
use kernel::homing::Phase;
use kernel::{EncoderSample, Event, FaultReason, Fx, Reject, Request, RequestKind, Scalar, Sense, State, TickOutput};

/// Sensors that may differ from the stationary arm in any way: a count may
/// be lost, jump, or move a little; switches and hardware faults are free.
#[cfg_attr(not(kani), kani::loops)]
fn any_sense() -> Sense {
    // Half of the samples are the clean stationary arm; symbolically this is
    // still every sensor combination.
    if kani::any() {
        return still(0);
    }
    let mut s = still(kani::any());
    for i in 0..AXES {
        let mode: u8 = kani::any();
        s.encoders[i] = match mode % 4 {
            0 => EncoderSample::Lost,
            1 => EncoderSample::Count(kani::any()),
            2 => {
                let d: i8 = kani::any();
                EncoderSample::Count((i32::from(COUNTS[i]) + i32::from(d)).rem_euclid(4096) as u16)
            }
            _ => EncoderSample::Count(COUNTS[i]),
        };
    }
    if kani::any::<u8>() == 0 {
        s.hardware_fault = Some(crate::setup::any_hardware_fault());
    }
    s
}

fn all_zero<S: Scalar>(o: &TickOutput<S>) -> bool {
    o.act.velocity.iter().all(|v| *v == S::ZERO) && o.act.step_rate.iter().all(|r| *r == 0)
}

// The per-tick invariants (SR-1, SR-2, SR-4..SR-11, SR-13, SR-15..SR-19,
// SR-25) are checked on every tick of every harness by the safety monitor
// (`setup::Checked`); the harnesses below state their own properties.

/// SR-2, SR-3, SR-4, SR-9, SR-11, SR-21: one tick from Operational with any
/// target and any sensors: outputs bounded; a fault zeroes every axis.
#[cfg_attr(not(kani), kani::loops)]
fn operational_tick<S: Sym>() {
    let (mut k, _) = operational::<S>();
    let req = if kani::any() { Some(Request::Motion(any_target::<S>())) } else { None };
    let sense = any_sense();
    let o = k.tick(&sense, req);
    kani::cover!(o.status.state == State::Fault, "a fault");
    kani::cover!(o.status.state == State::Operational, "still operational");
    // SR-10, SR-21: a pressed switch or a hardware fault in Operational faults.
    kani::cover!(sense.limits & 0x3f != 0, "a switch pressed (SR-10 antecedent)");
    kani::cover!(sense.hardware_fault.is_some(), "a hardware fault (SR-21 antecedent)");
    if sense.limits & 0x3f != 0 || sense.hardware_fault.is_some() {
        assert!(o.status.state == State::Fault);
    }
    // A second tick: the monitor checks that the fault stays latched with
    // its first reason (SR-5) and the acceleration limit across the two
    // outputs (SR-25).
    let o2 = k.tick(&any_sense(), None);
    kani::cover!(
        o2.status.state == State::Operational && o.status.state == State::Operational,
        "two operational ticks"
    );
}

/// Footprint: 49 symbolic values, 29 ticks (a target and two sensor readings (27 concrete set-up ticks, 2 symbolic)).
#[kani::proof]
#[kani::unwind(26)] // setup::run_homing: HOMING_TICKS = 25 ticks; kernel, monitor and any_sense: 6 axes (7)
fn operational_tick_is_safe_f32() {
    operational_tick::<f32>();
}
/// Footprint: 49 symbolic values, 29 ticks (a target and two sensor readings (27 concrete set-up ticks, 2 symbolic)).
#[kani::proof]
#[kani::unwind(26)] // as the f32 harness
fn operational_tick_is_safe_fx() {
    operational_tick::<Fx>();
}

/// Ticks [`from_power_on`] runs after the first: one to start homing and
/// the seven J6 needs on the stationary arm (`setup::HOMING_TICKS` / 3),
/// then two in which the second group (J5, J4) moves, so the homing-order
/// assertion sees an axis that depends on another.
const POWER_ON_TICKS: u32 = 10;

/// Induction beside the 10 ticks, and where it stops: the one-step lemmas
/// (`state_props`: from every admitted Unhomed, Operational, Stopping,
/// SoftEstop and Fault state) assert the refusal of motion outside
/// Operational (SR-15), and the invariant carries them over ticks (see
/// `runaway`); they assert no homing order and draw no Boot or Homing
/// state. Those rest on this run: every tick of it checked by the
/// monitor, sampled under the shim, bounded to 10 ticks under Kani.
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

/// Footprint: 48 symbolic values, 11 ticks (the first readings, then per tick a request and the switches).
#[kani::proof]
#[kani::unwind(11)] // POWER_ON_TICKS = 10 ticks; kernel, monitor and the encoder loops: 6 axes (7)
fn nothing_moves_unless_homed_and_homing_order_holds_f32() {
    from_power_on::<f32>();
}
/// Footprint: 48 symbolic values, 11 ticks (the first readings, then per tick a request and the switches).
#[kani::proof]
#[kani::unwind(11)] // as the f32 harness
fn nothing_moves_unless_homed_and_homing_order_holds_fx() {
    from_power_on::<Fx>();
}

/// SR-7, SR-8, SR-29: after one accepted stream sample near the set-point,
/// silence: if a set-point still moves when the timeout expires, the ramp
/// starts (speeds never increase nor reverse, every axis exactly zero within
/// the ramp) and the stop latches; if every joint is already at rest at its
/// target, it holds (no latch) and the next command is taken.
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

/// Footprint: 7 symbolic values, 43 ticks (a sample near the set-point; 28 set-up ticks, then the silence).
#[kani::proof]
#[kani::unwind(26)] // setup::run_homing: 25 ticks; 12 ticks of silence here; 6 axes
fn soft_stop_ramps_monotonically_to_zero_and_latches_f32() {
    soft_stop::<f32>();
}
/// Footprint: 7 symbolic values, 43 ticks (a sample near the set-point; 28 set-up ticks, then the silence).
#[kani::proof]
#[kani::unwind(26)] // as the f32 harness
fn soft_stop_ramps_monotonically_to_zero_and_latches_fx() {
    soft_stop::<Fx>();
}

/// SR-5, SR-6: a limit fault; enable with any sensors is refused while any
/// cause is present, and when accepted the set-points equal the measured
/// positions (no jump) and the timeout is disarmed.
#[cfg_attr(not(kani), kani::loops)]
fn enable<S: Sym>() {
    let (mut k, auth) = operational::<S>();
    let switch: u8 = kani::any::<u8>() % AXES as u8;
    let o = k.tick(&still(1 << switch), None);
    assert!(o.status.state == State::Fault);
    let sense = any_sense();
    let cause = sense.limits & 0x3f != 0
        || sense.hardware_fault.is_some()
        || sense.encoders.iter().any(|e| !matches!(e, EncoderSample::Count(c) if *c < 4096));
    let o = k.tick(&sense, Some(Request::Enable(auth.enable())));
    kani::cover!(o.status.state == State::Fault, "refused");
    kani::cover!(o.status.state != State::Fault, "accepted");
    // The monitor checks the accepted case (SR-6: set-points equal the
    // positions, timeout disarmed, no cause in the sensors); stated here too.
    kani::cover!(cause, "a cause present (antecedent)");
    if cause {
        assert!(o.status.state == State::Fault);
    }
    if o.status.state != State::Fault {
        assert!(!o.status.timeout_armed);
        for i in 0..AXES {
            assert!(o.status.setpoint[i] == o.status.position[i]);
        }
    }
}

/// Footprint: 19 symbolic values, 29 ticks (the switch and one sensor reading).
#[kani::proof]
#[kani::unwind(26)] // setup::run_homing: 25 ticks; any_sense, kernel, monitor: 6 axes
fn enable_is_refused_while_a_cause_persists_and_never_jumps_f32() {
    enable::<f32>();
}
/// Footprint: 19 symbolic values, 29 ticks (the switch and one sensor reading).
#[kani::proof]
#[kani::unwind(26)] // as the f32 harness
fn enable_is_refused_while_a_cause_persists_and_never_jumps_fx() {
    enable::<Fx>();
}

/// SR-11: up to `encoder_invalid_limit` lost samples in a row are ridden
/// through; one more faults every axis.
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

/// Footprint: 1 symbolic values, 30 ticks (the axis).
#[kani::proof]
#[kani::unwind(26)] // setup::run_homing: 25 ticks; encoder_invalid_limit (2) ticks here; 6 axes
fn encoder_loss_beyond_the_tolerance_faults_f32() {
    encoder_loss::<f32>();
}
/// Footprint: 1 symbolic values, 30 ticks (the axis).
#[kani::proof]
#[kani::unwind(26)] // as the f32 harness
fn encoder_loss_beyond_the_tolerance_faults_fx() {
    encoder_loss::<Fx>();
}

/// SR-14: homing can be repeated: a second `<HOME>` from Operational runs
/// and completes again.
#[cfg_attr(not(kani), kani::loops)]
fn rehome<S: Sym>() {
    let (mut k, _) = operational::<S>();
    let o = k.tick(&still(0), Some(Request::Home));
    assert!(o.status.state == State::Homing);
    crate::setup::run_homing(&mut k);
    assert!(k.state() == State::Operational);
    kani::cover!(true);
}

/// Footprint: 0 symbolic values, 53 ticks (none: a deterministic replay).
#[kani::proof]
#[kani::unwind(26)] // setup::run_homing, twice: 25 ticks per entry; 6 axes
fn homing_is_repeatable_f32() {
    rehome::<f32>();
}
/// Footprint: 0 symbolic values, 53 ticks (none: a deterministic replay).
#[kani::proof]
#[kani::unwind(26)] // as the f32 harness
fn homing_is_repeatable_fx() {
    rehome::<Fx>();
}

/// Ticks [`runaway`] drives one encoder: enough for the observer's estimate
/// to pass the runaway threshold at the largest plausible step per tick
/// (measured: J1 crosses 3.75 rad/s in about 15 ticks at 55 counts/tick).
const RUNAWAY_TICKS: u32 = 30;

/// Induction beside the 30 ticks. The assertion ("a tick whose estimate
/// is above the runaway threshold ends in Fault") is the SR-9 clause of
/// the one-step lemmas `from_any_operational_state_*` and
/// `from_one_axis_operational_state_*` (`state_props`): it holds for one
/// tick from every state the kernel's invariant admits, with any sensors
/// and request. The invariant holds initially
/// (`initial_state_satisfies_the_invariant`) and after every such tick
/// (each lemma asserts it again); the ticks from Boot and Homing, which
/// no lemma draws, assert it on every replayed tick (`setup::Checked`,
/// sampled). So the assertion holds on every tick of every run of the
/// real configuration (the lemmas use `PAROL6`), not only the 30 here. What this run adds is reachability: the covers (the
/// threshold is reached under a plausible constant step, and the fault
/// is a runaway), for which Kani needs one path; its symbolic step makes
/// Kani check the assertion on all of them as well.
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

/// Footprint: 3 symbolic values, 57 ticks (the axis, the step and its sign).
#[kani::proof]
#[kani::unwind(31)] // RUNAWAY_TICKS = 30 (setup::run_homing: 21); 6 axes
fn runaway_faults_when_the_estimate_exceeds_the_threshold_f32() {
    runaway::<f32>();
}
/// Footprint: 3 symbolic values, 57 ticks (the axis, the step and its sign).
#[kani::proof]
#[kani::unwind(31)] // as the f32 harness
fn runaway_faults_when_the_estimate_exceeds_the_threshold_fx() {
    runaway::<Fx>();
}
