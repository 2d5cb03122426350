//! The kernel's thresholds, compared strictly or inclusively as SAFETY.md
//! and docs/PROTOCOL.md state each rule ("faster than its runaway speed",
//! "outside the limits by more than the margin", "more than the
//! following-error bound", "at or below the hold speed", ...). A rule whose
//! boundary moved by one value would differ only when the compared
//! quantity is *exactly* the threshold, which no scenario reaches by
//! chance. These tests put it there: a state built with `Kernel::from_spec`
//! (feature `proof-states`, as the proofs do) whose estimate the next
//! tick's observer step keeps exactly where it is wanted.
//!
//! The construction: encoder count 0 and homing zero `z`, so the measured
//! angle is exactly `z`; with `z = x + v dt` (the observer's own
//! prediction, in the kernel's arithmetic) the residual is exactly zero,
//! and after the tick the estimate is exactly `(x + v dt, v)`.
#![cfg(feature = "proof-states")]
#![allow(clippy::needless_range_loop)] // six axes: indices read best

mod common;

use common::{axis_spec as axis, both, predicted};
use kernel::config::{AXES, HOLD_SPEED, PAROL6, PAROL6_VALIDATED, POSITION_ABS_MAX};
use kernel::{
    AxisSpec, EncoderSample, Event, FaultReason, Kernel, Request, Scalar, Sense, SpecMode, State, StateSpec, TickOutput,
};

both!(
    exactly_the_runaway_speed_is_no_runaway,
    exactly_at_the_position_limits_is_inside,
    enable_accepts_exactly_the_speed_limit_and_the_position_limits,
    the_direction_rule_is_strict_at_half_the_speed_limit,
    the_following_error_bounds_are_strict,
    an_estimate_of_exactly_32_rad_is_implausible,
    an_output_of_exactly_the_hold_speed_is_holding,
    an_estimated_speed_of_exactly_64_rad_s_is_implausible,
    a_homing_phase_may_travel_exactly_its_bound,
);

fn dt<S: Scalar>() -> S {
    S::from_f32(1.0 / PAROL6.tick_hz as f32)
}

fn spec<S: Scalar>(mode: SpecMode<S>) -> StateSpec<S> {
    StateSpec {
        mode,
        homed: 0x3f,
        axes: core::array::from_fn(|i| axis(S::from_f32(0.05 * i as f32), S::ZERO)),
        armed: false,
        since_cmd: 0,
        since_target: None,
        intervals: [0; 4],
    }
}

fn build<S: Scalar>(s: &StateSpec<S>) -> (Kernel<S>, kernel::Authority) {
    Kernel::from_spec(&PAROL6_VALIDATED, s).expect("the invariant admits the constructed state")
}

/// One tick with every encoder reading count 0 (see the module comment).
fn tick<S: Scalar>(k: &mut Kernel<S>, req: Option<Request<S>>) -> TickOutput<S> {
    let sense = Sense { encoders: [EncoderSample::Count(0); AXES], limits: 0, hardware_fault: None, link_lost: false };
    k.tick(&sense, req)
}

fn fault<S: Scalar>(out: &TickOutput<S>) -> Option<FaultReason> {
    out.status.fault.map(|f| f.reason)
}

/// SR-9: a joint *faster than* its runaway speed faults. Catches:
/// `v.abs() > runaway` as `>=` (the check in every state).
fn exactly_the_runaway_speed_is_no_runaway<S: Scalar>() {
    for (v, want) in [(0.0f32, None), (0.01, Some(FaultReason::Runaway { axis: 0 }))] {
        for sign in [1.0f32, -1.0] {
            let mut s = spec::<S>(SpecMode::Operational);
            let run = S::from_f32(sign * (PAROL6.joints[0].runaway_velocity + v));
            let x = S::from_f32(0.3);
            s.axes[0] = AxisSpec { setpoint: predicted(x, run), target: predicted(x, run), ..axis(x, run) };
            let (mut k, _) = build(&s);
            let out = tick(&mut k, None);
            assert_eq!(out.status.velocity[0], run, "the estimate kept its speed");
            assert_eq!(fault(&out), want, "J1 at {} rad/s", run.to_f32());
        }
    }
}

/// SR-10 / PROTOCOL.md 6.7: a homed joint faults when its estimate is
/// *outside* its limits widened by the margin; exactly on them is inside.
/// Catches: `x < pos_lo` as `<=`, `x > pos_hi` as `>=` (Operational).
fn exactly_at_the_position_limits_is_inside<S: Scalar>() {
    let m = PAROL6.position_margin;
    for j in [0usize, 2, 5] {
        let jc = &PAROL6.joints[j];
        let lo = S::from_f32(jc.limit_min - m);
        let hi = S::from_f32(jc.limit_max + m);
        let beyond = [S::from_f32(jc.limit_min - m - 1e-3), S::from_f32(jc.limit_max + m + 1e-3)];
        for (x, want) in [(lo, None), (hi, None), (beyond[0], Some(j)), (beyond[1], Some(j))] {
            let mut s = spec::<S>(SpecMode::Operational);
            s.axes[j] = axis(x, S::ZERO);
            let (mut k, _) = build(&s);
            let out = tick(&mut k, None);
            assert_eq!(out.status.position[j], x);
            let want = want.map(|a| FaultReason::PositionLimit { axis: a as u8 });
            assert_eq!(fault(&out), want, "J{} at {}", j + 1, x.to_f32());
        }
    }
}

/// PROTOCOL.md 6.5: `<ENABLE>` is refused while a cause is present: a
/// joint *faster than* its speed limit, or a homed joint *outside* its
/// limits (with the margin). Exactly at them, it is accepted. Catches
/// (`present_cause`): `v.abs() > vmax` as `>=`, `x < pos_lo` as `<=`,
/// `x > pos_hi` as `>=`.
fn enable_accepts_exactly_the_speed_limit_and_the_position_limits<S: Scalar>() {
    let jc = &PAROL6.joints[1];
    let m = PAROL6.position_margin;
    let vmax = S::from_f32(jc.max_velocity);
    let x0 = S::from_f32(0.2);
    let cases = [
        ("at the speed limit", x0, vmax, true),
        ("at minus the speed limit", x0, vmax.neg(), true),
        ("above the speed limit", x0, S::from_f32(jc.max_velocity + 0.01), false),
        ("at the lower limit", S::from_f32(jc.limit_min - m), S::ZERO, true),
        ("at the upper limit", S::from_f32(jc.limit_max + m), S::ZERO, true),
        ("beyond the upper limit", S::from_f32(jc.limit_max + m + 1e-3), S::ZERO, false),
    ];
    for (what, x, v, accepted) in cases {
        let mut s = spec::<S>(SpecMode::SoftEstop);
        s.axes[1] = axis(x, v);
        let (mut k, auth) = build(&s);
        let out = tick(&mut k, Some(Request::Enable(auth.enable())));
        assert_eq!(out.status.velocity[1], v, "{what}: the estimate kept its speed");
        let refused = out.events.iter().any(|e| matches!(e, Event::Rejected { .. }));
        assert_eq!(!refused, accepted, "{what}: {:?}", out.events);
        assert_eq!(k.state() == State::Operational, accepted, "{what}");
    }
}

/// A state whose following error after the tick is exactly `e` (found by
/// trying set-points near the estimate: in f32 `(x' + e) - x'` is `e`
/// only where the addition is exact).
fn with_error<S: Scalar>(j: usize, e: S, v: S, cmd: S, fe_count: u32) -> Kernel<S> {
    for i in 0..4096 {
        let x = S::from_f32(0.004 + i as f32 * 1.0e-6);
        let xp = predicted(x, v);
        let sp = xp.plus(e);
        if sp.minus(xp) != e {
            continue;
        }
        let mut s = spec::<S>(SpecMode::Operational);
        s.axes[j] = AxisSpec { setpoint: sp, target: sp, path: sp, last_out: cmd, fe_count, ..axis(x, v) };
        let (k, _) = build(&s);
        return k;
    }
    panic!("no state with an exact following error {}", e.to_f32());
}

/// PROTOCOL.md 6.7: the direction rule: "more than half the bound off
/// while moving *against* the command", moving meaning *faster than* half
/// the speed limit either way, the command *beyond* half the speed limit.
/// At exactly half it is no rule. Each case: the error 3/4 of the bound
/// (inside the bound, past its half), the counter one tick from its fault.
/// Catches: the four comparisons of `against` made non-strict.
fn the_direction_rule_is_strict_at_half_the_speed_limit<S: Scalar>() {
    let jc = &PAROL6.joints[0];
    let half = S::from_f32(0.5 * jc.max_velocity);
    let fast = S::from_f32(0.5 * jc.max_velocity + 0.5);
    let e = S::from_f32(0.75 * PAROL6.following_error);
    let n = kernel_fe_ticks();
    let cases = [
        ("command exactly half, moving back fast", half, fast.neg(), false),
        ("command fast, moving back at exactly half", fast, half.neg(), false),
        ("command exactly minus half, moving forward fast", half.neg(), fast, false),
        ("command back fast, moving forward at exactly half", fast.neg(), half, false),
        ("command fast, moving back fast", fast, fast.neg(), true),
        ("command back fast, moving forward fast", fast.neg(), fast, true),
    ];
    for (what, cmd, v, faults) in cases {
        let mut k = with_error::<S>(0, e, v, cmd, n);
        let out = tick(&mut k, None);
        let want = if faults { Some(FaultReason::FollowingError { axis: 0 }) } else { None };
        assert_eq!(fault(&out), want, "{what}");
    }
}

/// The following-error time in ticks (20 ms at 1 kHz for the PAROL6).
fn kernel_fe_ticks() -> u32 {
    PAROL6.following_error_ms * PAROL6.tick_hz / 1000
}

/// PROTOCOL.md 6.7: *farther than* the bound (or than half of it while
/// moving against the command) for longer than the time. Exactly the bound,
/// or exactly half of it against the command, is no error. Catches:
/// `e.abs() > fe` as `>=`, `e.abs() > fe_half` as `>=`.
fn the_following_error_bounds_are_strict<S: Scalar>() {
    let jc = &PAROL6.joints[0];
    let fast = S::from_f32(0.5 * jc.max_velocity + 0.5);
    let fe = S::from_f32(PAROL6.following_error);
    let fe_half = S::from_f32(PAROL6.following_error * 0.5);
    let n = kernel_fe_ticks();
    let above = |e: S| e.plus(S::from_f32(1e-3));
    let cases = [
        ("exactly the bound, at rest", fe, S::ZERO, S::ZERO, false),
        ("exactly minus the bound, at rest", fe.neg(), S::ZERO, S::ZERO, false),
        ("past the bound, at rest", above(fe), S::ZERO, S::ZERO, true),
        ("exactly half the bound, against the command", fe_half, fast.neg(), fast, false),
        ("past half the bound, against the command", above(fe_half), fast.neg(), fast, true),
    ];
    for (what, e, v, cmd, faults) in cases {
        let mut k = with_error::<S>(0, e, v, cmd, n);
        let out = tick(&mut k, None);
        let want = if faults { Some(FaultReason::FollowingError { axis: 0 }) } else { None };
        assert_eq!(fault(&out), want, "{what}");
    }
}

/// An estimate is plausible only *inside* the kernel's absolute bound of
/// 32 rad (a Numeric fault otherwise, in any state where the axis has been
/// read; Unhomed here, where no position limit applies). Catches:
/// `x.abs() < pos_abs` as `<=`.
fn an_estimate_of_exactly_32_rad_is_implausible<S: Scalar>() {
    let bound = S::from_f32(POSITION_ABS_MAX);
    for sign in [1.0f32, -1.0] {
        let target = S::from_f32(sign * POSITION_ABS_MAX);
        // Approach it from inside at a few rad/s: find a start whose
        // prediction lands on the bound exactly.
        let start = (1..400).find_map(|i| {
            let v = S::from_f32(sign * (1.0 + i as f32 * 0.01));
            let x = target.minus(v.times(dt()));
            (predicted(x, v) == target && x.abs() < bound).then_some((x, v))
        });
        let (x, v) = start.expect("a start whose prediction is exactly the bound");
        let mut s = spec::<S>(SpecMode::Unhomed);
        s.homed = 0;
        s.axes[3] = axis(x, v);
        let (mut k, _) = build(&s);
        let out = tick(&mut k, None);
        assert_eq!(out.status.position[3], target);
        assert_eq!(fault(&out), Some(FaultReason::Numeric { axis: 3 }), "estimate {}", target.to_f32());
    }
}

/// `Kernel::moving`: an output *above* the hold speed is motion; exactly
/// the hold speed is holding (PROTOCOL.md 6.2: at rest means "every output
/// at or below the hold speed 0.01 rad/s"; `Params::hold_speed`: "Outputs at
/// or below this are holding"). Catches: `v.abs() > hold` as `>=`.
fn an_output_of_exactly_the_hold_speed_is_holding<S: Scalar>() {
    for (out, moving) in [(HOLD_SPEED, false), (-HOLD_SPEED, false), (HOLD_SPEED * 2.0, true)] {
        let mut s = spec::<S>(SpecMode::Operational);
        s.axes[4].last_out = S::from_f32(out);
        let (k, _) = build(&s);
        assert_eq!(k.moving(), moving, "last output {out}");
    }
}

/// An estimate is plausible only *below* the kernel's absolute speed bound
/// of 64 rad/s. The invariant admits no state at it, so the observer puts
/// it there: a residual `r` with `v + beta r` exactly 64 (the zero chosen
/// so that the reading is the prediction plus `r`). Exactly 64 is a
/// Numeric fault; a bound compared inclusively finds it plausible and
/// reports the same tick's runaway instead. Catches: `v.abs() < vel_abs` as `<=`.
fn an_estimated_speed_of_exactly_64_rad_s_is_implausible<S: Scalar>() {
    let beta_hz = S::from_f32(PAROL6.beta() * PAROL6.tick_hz as f32);
    let top = S::from_f32(64.0);
    for sign in [1.0f32, -1.0] {
        let target = S::from_f32(sign * 64.0);
        let start = (1..2000).find_map(|i| {
            let r = S::from_f32(sign * i as f32 * 1.0e-4);
            let v = target.minus(beta_hz.times(r));
            let x = S::from_f32(0.1);
            let xp = predicted(x, v);
            let zero = xp.plus(r);
            let exact = zero.minus(xp) == r && v.plus(beta_hz.times(r)) == target && v.abs() < top;
            exact.then_some((x, v, zero))
        });
        let (x, v, zero) = start.expect("a residual that lands the speed on 64 rad/s exactly");
        let mut s = spec::<S>(SpecMode::Unhomed);
        s.homed = 0;
        s.axes[3] = AxisSpec { zero, ..axis(x, v) };
        let (mut k, _) = build(&s);
        let out = tick(&mut k, None);
        assert_eq!(out.status.velocity[3], target);
        assert_eq!(fault(&out), Some(FaultReason::Numeric { axis: 3 }), "speed {}", target.to_f32());
    }
}

/// SR-14: a homing phase that travels *farther than* its bound faults
/// (`HOMING_TRAVEL`); exactly the bound is allowed. The fast seek's bound
/// and the other phases' bound, on the homing state machine itself.
/// Catches: `x - origin > bound` as `>=`.
fn a_homing_phase_may_travel_exactly_its_bound<S: Scalar>() {
    use kernel::homing::{AxisHoming, HomingParams, Phase};
    let p = HomingParams {
        fast_toward: S::from_f32(0.5),
        slow_toward: S::from_f32(0.1),
        backoff: S::from_f32(0.05),
        timeout_ticks: 10_000,
        dv: S::from_f32(0.01),
        max_travel: S::from_f32(1.0),
        phase_travel: S::from_f32(0.25),
        settle_ticks: 10,
    };
    let past = S::from_f32(1.0e-3);
    // The fast seek from 0: exactly 1 rad away is inside, farther is not.
    for (x, too_far) in [(p.max_travel, None), (p.max_travel.plus(past), Some(Phase::FastSeek))] {
        let mut h = AxisHoming::<S>::default();
        h.reset(true);
        h.start(S::ZERO);
        assert_eq!(h.phase(), Phase::FastSeek);
        assert_eq!(h.step(false, x, &p).too_far, too_far, "fast seek at {}", x.to_f32());
    }
    // The back-off, entered at the switch at 0.5: 0.25 rad from there.
    let at = S::from_f32(0.5);
    for (x, too_far) in [(at.plus(p.phase_travel), None), (at.plus(p.phase_travel).plus(past), Some(Phase::BackOff))] {
        let mut h = AxisHoming::<S>::default();
        h.reset(true);
        h.start(S::ZERO);
        h.step(true, at, &p);
        assert_eq!(h.phase(), Phase::BackOff);
        assert_eq!(h.step(true, x, &p).too_far, too_far, "back-off at {}", x.to_f32());
    }
}
