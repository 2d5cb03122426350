//! The proofs are not vacuous: deliberately broken functions, written
//! against the same `Scalar` trait and checked with the same property, get
//! a counterexample from z3, and the counterexample, replayed on the
//! concrete type, really breaks the property.
//!
//! These need the `z3` binary, so `cargo test` skips them; `proofs/smt/run.sh`
//! runs them (`--include-ignored`).

use fixed::types::I8F24;
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
