//! How many scalar operations a kernel tick runs, counted on a scalar that
//! wraps `f32` and counts every arithmetic operation and comparison it is
//! asked for (for the harnesses' footprints: in the `_f32` harnesses each
//! is a floating-point operation Kani bit-blasts). Not counted: the
//! monitor's checks (in `f64`, through `to_f32`) and integer work.

use crate::setup::{here, operational, still, target, Checked};
use kernel::{Request, Scalar, State};
use std::cell::Cell;
use std::cmp::Ordering;

thread_local! {
    static OPS: Cell<u64> = const { Cell::new(0) };
}

fn count() {
    OPS.with(|c| c.set(c.get() + 1));
}

/// `f32` whose every operation is counted.
#[derive(Clone, Copy, Debug)]
struct Counted(f32);

impl PartialEq for Counted {
    fn eq(&self, o: &Self) -> bool {
        count();
        self.0 == o.0
    }
}

impl PartialOrd for Counted {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        count();
        self.0.partial_cmp(&o.0)
    }
}

impl Scalar for Counted {
    const ZERO: Self = Counted(0.0);
    const ONE: Self = Counted(1.0);
    type Wide = f32;
    fn from_f32(x: f32) -> Self {
        Counted(<f32 as Scalar>::from_f32(x))
    }
    fn to_f32(self) -> f32 {
        self.0
    }
    fn wide_from_f64(x: f64) -> f32 {
        <f32 as Scalar>::wide_from_f64(x)
    }
    fn plus(self, rhs: Self) -> Self {
        count();
        Counted(Scalar::plus(self.0, rhs.0))
    }
    fn minus(self, rhs: Self) -> Self {
        count();
        Counted(Scalar::minus(self.0, rhs.0))
    }
    fn times(self, rhs: Self) -> Self {
        count();
        Counted(Scalar::times(self.0, rhs.0))
    }
    fn times_int(self, n: i32) -> Self {
        count();
        Counted(Scalar::times_int(self.0, n))
    }
    fn div_int(self, n: i32) -> Self {
        count();
        Counted(Scalar::div_int(self.0, n))
    }
    fn min(self, rhs: Self) -> Self {
        count();
        Counted(Scalar::min(self.0, rhs.0))
    }
    fn max(self, rhs: Self) -> Self {
        count();
        Counted(Scalar::max(self.0, rhs.0))
    }
    fn neg(self) -> Self {
        count();
        Counted(Scalar::neg(self.0))
    }
    fn abs(self) -> Self {
        count();
        Counted(Scalar::abs(self.0))
    }
    fn is_finite(self) -> bool {
        count();
        Scalar::is_finite(self.0)
    }
    fn from_counts(n: i32, k: f32) -> Self {
        count();
        Counted(<f32 as Scalar>::from_counts(n, k))
    }
    fn to_rate(self, k: f32) -> i32 {
        count();
        Scalar::to_rate(self.0, k)
    }
    fn to_scaled_int(self, scale: i64) -> i64 {
        Scalar::to_scaled_int(self.0, scale)
    }
    fn parse_decimal(text: &str) -> Option<Self> {
        <f32 as Scalar>::parse_decimal(text).map(Counted)
    }
}

/// Operations of one tick of `k` with `request`.
fn ops(k: &mut Checked<Counted>, request: Option<Request<Counted>>) -> u64 {
    OPS.with(|c| c.set(0));
    k.tick(&still(0), request);
    OPS.with(Cell::get)
}

/// The sentence of `lib.rs`'s documentation that states the figures, as
/// [`float_operations_per_tick`] measures them: the range, then each tick.
fn stated(idle: u64, accept: u64, moving: u64, stopping: u64) -> String {
    let all = [idle, accept, moving, stopping];
    let (lo, hi) = (all.iter().min().copied().unwrap_or(0), all.iter().max().copied().unwrap_or(0));
    format!(
        "a kernel tick runs {lo}-{hi} scalar operations (arithmetic, min/max, comparisons; idle {idle}, \
         accepting a target {accept}, moving {moving}, soft stop {stopping}:"
    )
}

/// `lib.rs`'s documentation as one line of words (its `//!` lines joined).
fn lib_doc() -> String {
    let doc: Vec<&str> = include_str!("lib.rs").lines().filter_map(|l| l.strip_prefix("//!")).map(str::trim).collect();
    doc.join(" ")
}

/// The figures `lib.rs` states: an operational tick that accepts a target
/// and one that moves toward it, and a soft-stop tick. Fails when the
/// documentation's figures are not the ones measured here (the failure
/// prints the sentence to write).
#[test]
fn float_operations_per_tick() {
    let (mut k, _) = operational::<Counted>();
    let p = here(&mut k);
    let idle = ops(&mut k, None);
    let mut t = target(p);
    t.position[0] = t.position[0].plus(Counted(0.01));
    let accept = ops(&mut k, Some(Request::Motion(t)));
    let moving = ops(&mut k, None);
    let mut stopping = 0;
    for _ in 0..10 {
        let before = k.state();
        let n = ops(&mut k, None);
        if before == State::Stopping {
            stopping = stopping.max(n);
        }
    }
    println!(
        "scalar operations per kernel tick (f32, monitor excluded): idle {idle}, accepting a target {accept}, moving {moving}, soft stop {stopping}"
    );
    assert!(idle > 0 && accept > idle && moving > 0 && stopping > 0, "the counter counts, and the run stopped");
    // The bound lib.rs states.
    assert!([idle, accept, moving, stopping].iter().all(|&n| n <= 1500), "{idle} {accept} {moving} {stopping}");
    let want = stated(idle, accept, moving, stopping);
    assert!(lib_doc().contains(&want), "proofs/src/lib.rs's documentation should say: \"{want}\"");
}
