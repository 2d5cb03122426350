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
