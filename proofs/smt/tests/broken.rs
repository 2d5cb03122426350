//! The proofs are not vacuous: deliberately broken functions, written
//! against the same `Scalar` trait and checked with the same property, get
//! a counterexample from z3, and the counterexample, replayed on the
//! concrete type, really breaks the property.
//!
//! These need the `z3` binary, so `cargo test` skips them; `proofs/smt/run.sh`
//! runs them (`--include-ignored`).

use fixed::types::I8F24;
use kernel::interp::Profile;
use kernel::Scalar;
use smt::ctx::{self, Counterexample};
use smt::props;
use smt::sym::{SymF32, SymFx};
use smt::z3::{bv32_value, f32_value};

/// Saturation without the NaN select: `f32::min` ignores a NaN, so NaN
/// comes out as the limit (and `clamp` would pass it through).
fn saturate_without_nan_select<S: Scalar>(x: S, limit: S) -> S {
    x.min(limit).max(limit.neg())
}

/// Saturation through a shifted clamp: `x + limit` overflows (saturates)
/// in fixed point for limits above 64.
fn saturate_shifted<S: Scalar>(x: S, limit: S) -> S {
    x.plus(limit).min(limit.plus(limit)).max(S::ZERO).minus(limit)
}

fn value(cex: &Counterexample, name: &str) -> String {
    cex.iter().find(|(n, _)| n == name).map(|(_, v)| v.clone()).unwrap_or_else(|| panic!("no {name} in {cex:?}"))
}

/// The property of `props::saturate`, on concrete values.
fn saturate_ok<S: Scalar>(x: S, limit: S, y: S) -> bool {
    let inside = x.is_finite() && x >= limit.neg() && x <= limit;
    y.is_finite()
        && y.abs() <= limit
        && (x.is_finite() || y == S::ZERO)
        && (!inside || y == x)
        && (!x.is_finite() || inside || y.abs() == limit)
}

fn refuted(build: fn(usize) -> Vec<smt::sym::B>) -> Counterexample {
    let o = ctx::session(|| ctx::explore(|| build(0).into_iter().map(|b| b.0).collect()));
    println!("{} paths, {} checks, {:?}: {:?}", o.paths, o.checks, o.time, o.counterexample);
    o.counterexample.expect("a broken function must get a counterexample")
}

#[test]
#[ignore = "needs the z3 binary: proofs/smt/run.sh runs it"]
fn saturate_without_the_nan_select_is_refuted_f32() {
    let cex = refuted(|_| props::saturate::<SymF32>(saturate_without_nan_select));
    let x = f32::from_bits(f32_value(&value(&cex, "x")).expect("an f32"));
    let limit = f32::from_bits(f32_value(&value(&cex, "limit")).expect("an f32"));
    assert!(!x.is_finite(), "the counterexample is a non-finite input: {x}");
    let y = saturate_without_nan_select(x, limit);
    assert!(!saturate_ok(x, limit, y), "replayed on f32: saturate({x}, {limit}) = {y} should break the property");
    // ... and the kernel's own saturate is fine on it.
    assert!(saturate_ok(x, limit, x.saturate(limit)));
}

#[test]
#[ignore = "needs the z3 binary: proofs/smt/run.sh runs it"]
fn saturate_through_an_overflowing_shift_is_refuted_fx() {
    let cex = refuted(|_| props::saturate::<SymFx>(saturate_shifted));
    let x = I8F24::from_bits(bv32_value(&value(&cex, "x")).expect("a word") as i32);
    let limit = I8F24::from_bits(bv32_value(&value(&cex, "limit")).expect("a word") as i32);
    let y = saturate_shifted(x, limit);
    assert!(!saturate_ok(x, limit, y), "replayed on I8F24: saturate({x}, {limit}) = {y} should break the property");
    assert!(saturate_ok(x, limit, x.saturate(limit)));
}

/// The same broken saturations are refuted in the other variant too (the
/// f32 shift loses precision; the fixed-point one without a NaN select is
/// correct, as `I8F24` has no NaN, so it is proved).
#[test]
#[ignore = "needs the z3 binary: proofs/smt/run.sh runs it"]
fn the_other_variant() {
    let cex = refuted(|_| props::saturate::<SymF32>(saturate_shifted));
    let x = f32::from_bits(f32_value(&value(&cex, "x")).expect("an f32"));
    let limit = f32::from_bits(f32_value(&value(&cex, "limit")).expect("an f32"));
    assert!(!saturate_ok(x, limit, saturate_shifted(x, limit)), "replayed on f32: x {x}, limit {limit}");
    let o = ctx::session(|| {
        ctx::explore(|| props::saturate::<SymFx>(saturate_without_nan_select).into_iter().map(|b| b.0).collect())
    });
    assert!(o.proved(), "min/max saturation is correct in fixed point: {:?}", o.counterexample);
}

fn refuted_blind(build: fn(usize) -> Vec<smt::sym::B>) -> Counterexample {
    let o = ctx::session(|| ctx::explore_blind(|| build(0).into_iter().map(|b| b.0).collect()));
    println!("{} paths, {} checks, {:?}: {:?}", o.paths, o.checks, o.time, o.counterexample);
    o.counterexample.expect("a broken function must get a counterexample")
}

fn f32_of(cex: &Counterexample, name: &str) -> f32 {
    f32::from_bits(f32_value(&value(cex, name)).expect("an f32"))
}

fn fx_of(cex: &Counterexample, name: &str) -> I8F24 {
    I8F24::from_bits(bv32_value(&value(cex, name)).expect("a word") as i32)
}

/// A set-point step whose velocity clamp lacks its upper end: it jumps to
/// the cruising speed (only deceleration is limited).
fn advance_without_the_acceleration_limit<S: Scalar>(sp: S, to: S, vel: S, speed: S, k: &Profile<S>) -> (S, S) {
    let want = S::select(to < sp, speed.neg(), speed);
    let v = want.max(vel.minus(k.dv)).min(k.vmax);
    (sp.plus(v.times(k.dt)), v)
}

/// The interpolator's acceleration bound, on concrete values.
fn acceleration_ok<S: Scalar>(vel: S, vel2: S, k: &Profile<S>) -> bool {
    vel2.minus(vel).abs() <= k.dv.plus(props::interpolator_slack(k))
}

#[test]
#[ignore = "needs the z3 binary: proofs/smt/run.sh runs it"]
fn an_interpolator_without_the_acceleration_limit_is_refuted() {
    use props::InterpProp::Acceleration;
    let cex = refuted_blind(|j| props::interpolator::<SymF32>(j, Acceleration, advance_without_the_acceleration_limit));
    let k = props::joint_profile::<f32>(0);
    let (sp, to, vel, speed) =
        (f32_of(&cex, "setpoint"), f32_of(&cex, "target"), f32_of(&cex, "velocity"), f32_of(&cex, "speed"));
    let (_, vel2) = advance_without_the_acceleration_limit(sp, to, vel, speed, &k);
    assert!(!acceleration_ok(vel, vel2, &k), "replayed on f32: {vel} -> {vel2} should break the bound");
    let (_, kernel_vel2) = props::advance(sp, to, vel, speed, &k);
    assert!(acceleration_ok(vel, kernel_vel2, &k), "the kernel's step on it: {vel} -> {kernel_vel2}");

    let cex = refuted_blind(|j| props::interpolator::<SymFx>(j, Acceleration, advance_without_the_acceleration_limit));
    let k = props::joint_profile::<I8F24>(0);
    let (sp, to, vel, speed) =
        (fx_of(&cex, "setpoint"), fx_of(&cex, "target"), fx_of(&cex, "velocity"), fx_of(&cex, "speed"));
    let (_, vel2) = advance_without_the_acceleration_limit(sp, to, vel, speed, &k);
    assert!(!acceleration_ok(vel, vel2, &k), "replayed on I8F24: {vel} -> {vel2} should break the bound");
    let (_, kernel_vel2) = props::advance(sp, to, vel, speed, &k);
    assert!(acceleration_ok(vel, kernel_vel2, &k), "the kernel's step on it: {vel} -> {kernel_vel2}");
}

/// A soft-stop output whose envelope is not clamped to the previous output.
fn stop_output_unclamped<S: Scalar>(v0: S, scale: S, prev: S, follow: Option<(S, S)>, done: bool) -> S {
    let env = v0.times(scale);
    let env = S::select(env.is_finite(), env, S::ZERO);
    let follow = match follow {
        Some((v, step)) => v.clamp_between(prev.minus(step), prev.plus(step)),
        None => env,
    };
    S::select(done, S::ZERO, follow.clamp_between(S::ZERO, env))
}

/// "Between zero and `prev`" of `props::stop_output`, on concrete values.
fn within_prev<S: Scalar>(prev: S, out: S) -> bool {
    !prev.is_finite() || (S::ZERO <= out && out <= prev) || (prev <= out && out <= S::ZERO)
}

#[test]
#[ignore = "needs the z3 binary: proofs/smt/run.sh runs it"]
fn a_soft_stop_envelope_not_clamped_to_the_previous_output_is_refuted() {
    for variant in 0..2 {
        let replay = |cex: &Counterexample| -> (bool, bool) {
            let track = value(cex, "track") == "true";
            let done = value(cex, "done") == "true";
            if variant == 0 {
                let g = |n| f32_of(cex, n);
                let (v0, scale, prev, follow) =
                    (g("v0"), g("scale"), g("prev"), track.then(|| (g("brake"), g("step"))));
                let out = stop_output_unclamped(v0, scale, prev, follow, done);
                (within_prev(prev, out), within_prev(prev, kernel::ramp::stop_output(v0, scale, prev, follow, done)))
            } else {
                let g = |n| fx_of(cex, n);
                let (v0, scale, prev, follow) =
                    (g("v0"), g("scale"), g("prev"), track.then(|| (g("brake"), g("step"))));
                let out = stop_output_unclamped(v0, scale, prev, follow, done);
                (within_prev(prev, out), within_prev(prev, kernel::ramp::stop_output(v0, scale, prev, follow, done)))
            }
        };
        let cex = if variant == 0 {
            refuted_blind(|_| props::stop_output::<SymF32>(stop_output_unclamped))
        } else {
            refuted_blind(|_| props::stop_output::<SymFx>(stop_output_unclamped))
        };
        let (broken_ok, kernel_ok) = replay(&cex);
        assert!(!broken_ok, "replayed on the concrete type, the broken output stays within prev: {cex:?}");
        assert!(kernel_ok, "the kernel's output leaves prev's interval: {cex:?}");
    }
}

/// A homing ramp that may accelerate by twice `dv`.
fn toward_twice<S: Scalar>(vel: S, want: S, dv: S) -> S {
    want.clamp_between(vel.minus(dv), vel.plus(dv).plus(dv))
}

#[test]
#[ignore = "needs the z3 binary: proofs/smt/run.sh runs it"]
fn a_homing_ramp_accelerating_by_twice_dv_is_refuted() {
    let inside = |vel: I8F24, dv: I8F24, v: I8F24| v >= vel - dv && v <= vel + dv;
    let cex = refuted_blind(|_| props::homing_ramp::<SymFx>(toward_twice));
    let (vel, want, dv) = (fx_of(&cex, "vel"), fx_of(&cex, "want"), fx_of(&cex, "dv"));
    assert!(!inside(vel, dv, toward_twice(vel, want, dv)), "replayed on I8F24: vel {vel}, want {want}, dv {dv}");
    assert!(inside(vel, dv, kernel::ramp::toward(vel, want, dv)));
    let cex = refuted_blind(|_| props::homing_ramp::<SymF32>(toward_twice));
    let (vel, want, dv) = (f32_of(&cex, "vel"), f32_of(&cex, "want"), f32_of(&cex, "dv"));
    let v = toward_twice(vel, want, dv);
    assert!(!(v >= vel - dv && v <= vel + dv), "replayed on f32: vel {vel}, want {want}, dv {dv}: {v}");
}

// ------------------------------------------------- the SR-2 output gate --
//
// Each gate property (`props::gate_*`) fails when one of its preconditions
// is dropped or the code it composes is broken; each counterexample,
// replayed on the concrete type through the same generic code, gives an
// output the gate would fault.

use props::{Inputs, Pre};

/// `x` finite and within `[-vmax, vmax]`: what the gate lets through.
fn passes<S: Scalar>(x: S, vmax: S) -> bool {
    x.is_finite() && x.abs() <= vmax
}

/// A counterexample's values, read as the concrete type `T`.
struct Replay<'a, T> {
    cex: &'a Counterexample,
    of: fn(&Counterexample, &str) -> T,
}

impl<T> Inputs<T> for Replay<'_, T> {
    fn scalar(&mut self, name: &str) -> T {
        (self.of)(self.cex, name)
    }
    fn flag(&mut self, name: &str) -> bool {
        value(self.cex, name) == "true"
    }
}

/// A control law without its saturation: the raw `ff + kp e`.
fn law_unsaturated<S: Scalar>(sp: S, ff: S, x: S, kp: S, _vmax: S, _deadband: S) -> (S, bool) {
    (ff.plus(kp.times(sp.minus(x))), true)
}

const NO_LAST_OUTPUT_BOUND: Pre = Pre { last_output: false, config: true };
const NO_CONFIG_BOUND: Pre = Pre { last_output: true, config: false };

/// Replays `gate_operational`'s counterexample with `law` on `T`: the
/// candidate, the kernel's law's candidate, `vmax`, `prev`, `accel_step`.
fn replay_operational<T: Scalar>(
    cex: &Counterexample,
    of: fn(&Counterexample, &str) -> T,
    law: props::Law<T>,
) -> [T; 5] {
    let g = |n| of(cex, n);
    let args = [g("setpoint"), g("feed_forward"), g("estimate"), g("kp"), g("vmax"), g("deadband")];
    let (prev, accel_step) = (g("prev"), g("accel_step"));
    let kernel_law: props::Law<T> = kernel::control::control_law;
    [
        props::operational_candidate(law, args, prev, accel_step),
        props::operational_candidate(kernel_law, args, prev, accel_step),
        g("vmax"),
        prev,
        accel_step,
    ]
}

#[test]
#[ignore = "needs the z3 binary: proofs/smt/run.sh runs it"]
fn the_operational_gate_fails_without_its_preconditions_or_the_law_s_saturation() {
    // The last output above vmax: the clamp keeps the output near it.
    let cex = refuted_blind(|_| props::gate_operational::<SymF32>(kernel::control::control_law, NO_LAST_OUTPUT_BOUND));
    let [out, _, vmax, prev, _] = replay_operational::<f32>(&cex, f32_of, kernel::control::control_law);
    assert!(!passes(prev, vmax) && !passes(out, vmax), "f32: prev {prev}, out {out}, vmax {vmax}");
    let cex = refuted_blind(|_| props::gate_operational::<SymFx>(kernel::control::control_law, NO_LAST_OUTPUT_BOUND));
    let [out, _, vmax, prev, _] = replay_operational::<I8F24>(&cex, fx_of, kernel::control::control_law);
    assert!(!passes(prev, vmax) && !passes(out, vmax), "I8F24: prev {prev}, out {out}, vmax {vmax}");
    // A negative acceleration step (config::check requires max_acceleration > 0).
    let cex = refuted_blind(|_| props::gate_operational::<SymFx>(kernel::control::control_law, NO_CONFIG_BOUND));
    let [out, _, vmax, _, step] = replay_operational::<I8F24>(&cex, fx_of, kernel::control::control_law);
    assert!(step < I8F24::ZERO && !passes(out, vmax), "I8F24: step {step}, out {out}, vmax {vmax}");
    let cex = refuted_blind(|_| props::gate_operational::<SymF32>(kernel::control::control_law, NO_CONFIG_BOUND));
    let [out, _, vmax, _, step] = replay_operational::<f32>(&cex, f32_of, kernel::control::control_law);
    let step_ok = step >= 0.0 && step.is_finite();
    assert!(!step_ok && !passes(out, vmax), "f32: step {step}, out {out}, vmax {vmax}");
    // A law that does not saturate: the kernel's law keeps the same inputs in.
    let cex = refuted_blind(|_| props::gate_operational::<SymFx>(law_unsaturated, Pre::ALL));
    let [out, kernel_out, vmax, ..] = replay_operational::<I8F24>(&cex, fx_of, law_unsaturated);
    assert!(!passes(out, vmax) && passes(kernel_out, vmax), "I8F24: out {out}, kernel {kernel_out}, vmax {vmax}");
    let cex = refuted_blind(|_| props::gate_operational::<SymF32>(law_unsaturated, Pre::ALL));
    let [out, kernel_out, vmax, ..] = replay_operational::<f32>(&cex, f32_of, law_unsaturated);
    assert!(!passes(out, vmax) && passes(kernel_out, vmax), "f32: out {out}, kernel {kernel_out}, vmax {vmax}");
}

/// A soft-stop output that follows the braking command within `prev +-
/// step` without clamping it into the envelope (between zero and `prev`).
fn stop_output_unenveloped<S: Scalar>(v0: S, scale: S, prev: S, follow: Option<(S, S)>, done: bool) -> S {
    let env = v0.times(scale).clamp_between(S::ZERO, prev);
    let env = S::select(env.is_finite(), env, S::ZERO);
    let out = match follow {
        Some((v, step)) => v.max(prev.minus(step)).min(prev.plus(step)),
        None => env,
    };
    S::select(done, S::ZERO, out)
}

/// Replays `gate_stopping`'s counterexample with `f` on `T`: the
/// candidate, the kernel's candidate, `vmax`, `prev`.
fn replay_stopping<T: Scalar>(
    cex: &Counterexample,
    of: fn(&Counterexample, &str) -> T,
    f: props::StopOutput<T>,
) -> [T; 4] {
    let g = |n| of(cex, n);
    let follow = (value(cex, "track") == "true").then(|| (g("brake"), g("stop_step")));
    let done = value(cex, "done") == "true";
    let (v0, scaled_left, prev) = (g("v0"), g("scaled_left"), g("prev"));
    let kernel_f: props::StopOutput<T> = kernel::ramp::stop_output;
    [
        props::stopping_candidate(f, v0, scaled_left, prev, follow, done),
        props::stopping_candidate(kernel_f, v0, scaled_left, prev, follow, done),
        g("vmax"),
        prev,
    ]
}

#[test]
#[ignore = "needs the z3 binary: proofs/smt/run.sh runs it"]
fn the_stopping_gate_fails_without_its_precondition_or_the_envelope() {
    let cex = refuted_blind(|_| props::gate_stopping::<SymF32>(kernel::ramp::stop_output, NO_LAST_OUTPUT_BOUND));
    let [out, _, vmax, prev] = replay_stopping::<f32>(&cex, f32_of, kernel::ramp::stop_output);
    assert!(!passes(prev, vmax) && !passes(out, vmax), "f32: prev {prev}, out {out}, vmax {vmax}");
    let cex = refuted_blind(|_| props::gate_stopping::<SymFx>(kernel::ramp::stop_output, NO_LAST_OUTPUT_BOUND));
    let [out, _, vmax, prev] = replay_stopping::<I8F24>(&cex, fx_of, kernel::ramp::stop_output);
    assert!(!passes(prev, vmax) && !passes(out, vmax), "I8F24: prev {prev}, out {out}, vmax {vmax}");
    let cex = refuted_blind(|_| props::gate_stopping::<SymF32>(stop_output_unenveloped, Pre::ALL));
    let [out, kernel_out, vmax, _] = replay_stopping::<f32>(&cex, f32_of, stop_output_unenveloped);
    assert!(!passes(out, vmax) && passes(kernel_out, vmax), "f32: out {out}, kernel {kernel_out}, vmax {vmax}");
    let cex = refuted_blind(|_| props::gate_stopping::<SymFx>(stop_output_unenveloped, Pre::ALL));
    let [out, kernel_out, vmax, _] = replay_stopping::<I8F24>(&cex, fx_of, stop_output_unenveloped);
    assert!(!passes(out, vmax) && passes(kernel_out, vmax), "I8F24: out {out}, kernel {kernel_out}, vmax {vmax}");
}

fn refuted_blind_constants(build: fn(usize) -> Vec<smt::sym::B>) -> Counterexample {
    let o = ctx::session(|| ctx::explore_blind_evaluating_constants(|| build(0).into_iter().map(|b| b.0).collect()));
    println!("{} paths, {} checks, {:?}: {:?}", o.paths, o.checks, o.time, o.counterexample);
    o.counterexample.expect("a broken precondition must give a counterexample")
}

/// Replays `gate_homing`'s counterexample on `T` (the kernel's own
/// `AxisHoming::step`): whether the output and the new velocity pass the
/// gate, and the velocity before the step, the parameters and `vmax`.
fn replay_homing<T: Scalar>(
    cex: &Counterexample,
    of: fn(&Counterexample, &str) -> T,
) -> (bool, props::HomingCase<T>, T) {
    let c = props::homing_gate_case::<T>(&mut Replay { cex, of });
    let vmax = of(cex, "vmax");
    assert!(c.reached, "the preparation reached {:?}", c.start);
    (passes(c.out, vmax) && passes(c.vel_after, vmax), c, vmax)
}

#[test]
#[ignore = "needs the z3 binary: proofs/smt/run.sh runs it"]
fn the_homing_gate_fails_without_its_preconditions() {
    // A velocity above vmax before the step (the ramp's own bound dropped).
    let cex = refuted_blind_constants(|_| props::gate_homing::<SymFx>(NO_LAST_OUTPUT_BOUND));
    let (ok, c, vmax) = replay_homing::<I8F24>(&cex, fx_of);
    assert!(!ok && !passes(c.vel, vmax), "I8F24: {c:?}, vmax {vmax}");
    let cex = refuted_blind_constants(|_| props::gate_homing::<SymF32>(NO_LAST_OUTPUT_BOUND));
    let (ok, c, vmax) = replay_homing::<f32>(&cex, f32_of);
    assert!(!ok && !passes(c.vel, vmax), "f32: {c:?}, vmax {vmax}");
    // A homing speed above vmax or a negative step (config::check's bounds
    // dropped).
    let config_ok = |c: &props::HomingCase<I8F24>, vmax| {
        passes(c.params.fast_toward, vmax) && passes(c.params.slow_toward, vmax) && c.params.dv >= I8F24::ZERO
    };
    let cex = refuted_blind_constants(|_| props::gate_homing::<SymFx>(NO_CONFIG_BOUND));
    let (ok, c, vmax) = replay_homing::<I8F24>(&cex, fx_of);
    assert!(!ok && passes(c.vel, vmax) && !config_ok(&c, vmax), "I8F24: {c:?}, vmax {vmax}");
    let cex = refuted_blind_constants(|_| props::gate_homing::<SymF32>(NO_CONFIG_BOUND));
    let (ok, c, vmax) = replay_homing::<f32>(&cex, f32_of);
    let p = &c.params;
    let config_ok = passes(p.fast_toward, vmax) && passes(p.slow_toward, vmax) && p.dv.is_finite() && p.dv >= 0.0;
    assert!(!ok && passes(c.vel, vmax) && !config_ok, "f32: {c:?}, vmax {vmax}");
}
