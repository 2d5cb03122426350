//! The project's stand-in for the `kani` crate, used only when the proofs are
//! *not* built by Kani (`cfg(not(kani))`; `cargo kani` sets `--cfg kani` and
//! supplies the real crate, so this one drops out).
//!
//! Under the shim every `#[kani::proof]` harness becomes a `#[test]` that the
//! [`runner`] executes many times:
//!
//! - **exhaustive**: if the harness's choice tree (every `kani::any()` call
//!   and its domain, recorded on a first run) has at most
//!   [`runner::EXHAUSTIVE_LIMIT`] leaves and every draw is narrow (a domain of
//!   at most 2^16 values), every combination is enumerated, depth first;
//! - **sampled**: otherwise, [`runner::samples`] cases are drawn from a seeded
//!   generator that puts weight on boundaries (0, +-1, MIN, MAX, and for
//!   floats NaN, infinities, subnormals, +-0).
//!
//! Each harness prints one line saying which it did, how many cases ran, how
//! many were discarded by `kani::assume`, and how many of its `kani::cover!`
//! were satisfied. Every cover of the harness is known before it can be
//! reached (the macros declare the covers of each function body they
//! instrument at its entry), and one never satisfied fails the harness,
//! whether its line ran or not: an assumption made the harness vacuous, a
//! branch is unreachable, or the samples were too few.
//!
//! Each harness states its symbolic footprint in its documentation
//! (`Footprint: N symbolic values, T ticks`, required by `#[kani::proof]`);
//! every case counts the primitive values `kani::any()` draws and the
//! ticks reported through [`runner::tick`], and one that exceeds either
//! figure fails the harness ([`runner::Footprint`]). Draws that only steer
//! sampling go through [`runner::hint`] and are not counted. A stated
//! footprint beyond the budget (one kernel tick, 128 symbolic values) is a
//! compile error of `#[kani::proof]` (`kani-shim-macros`).
//!
//! Loop bounds are checked as Kani checks them: with `#[kani::unwind(N)]`
//! every loop the shim can see (the harness's own body and helpers marked
//! `#[cfg_attr(not(kani), kani::loops)]`) may run at most N - 1 iterations
//! per entry, and loops it cannot see (in the code under test) are declared
//! with [`runner::needs_unwind`]; see the `kani-shim-macros` crate.
//!
//! This is *sampled* or *exhaustive* evidence in the sense of
//! `docs/spec/evidence.md`, never *symbolic*: only Kani itself gives that.

pub use kani_shim_macros::{loops, proof, solver, unwind};

pub mod runner;

/// Values `kani::any()` can produce.
pub trait Arbitrary: Sized {
    /// Draws one value.
    fn any_from(src: &mut runner::Source) -> Self;
}

/// A value of any bit pattern (Kani's `kani::any`).
pub fn any<T: Arbitrary>() -> T {
    runner::with_source(T::any_from)
}

/// A value satisfying `f` (Kani's `kani::any_where`).
pub fn any_where<T: Arbitrary, F: FnOnce(&T) -> bool>(f: F) -> T {
    let v = any::<T>();
    assume(f(&v));
    v
}

/// Discards the current case unless `cond` holds (Kani's `kani::assume`).
pub fn assume(cond: bool) {
    if !cond {
        std::panic::panic_any(runner::Discarded);
    }
}

/// Kani's `kani::assert`.
#[track_caller]
pub fn assert(cond: bool, msg: &'static str) {
    if !cond {
        panic!("kani::assert failed: {msg}");
    }
}

/// Records whether a `cover!` condition held (used by the macro).
#[doc(hidden)]
pub fn cover_hit(file: &'static str, line: u32, label: &'static str, cond: bool) {
    runner::record_cover(file, line, label, cond);
}

/// Kani's `kani::cover!(cond, "message")`: the harness must be able to reach
/// a state where `cond` holds. Under the shim every cover is declared before
/// it can be reached: `#[kani::proof]` and `kani::loops` declare the covers
/// written in their function's body when it is entered (see the
/// `kani-shim-macros` crate), and a declared cover never satisfied fails the
/// harness, reached or not. A cover in a function without either attribute
/// fails the harness when it is reached.
#[macro_export]
macro_rules! cover {
    () => {
        $crate::cover_hit(file!(), line!(), "", true)
    };
    ($cond:expr $(,)?) => {
        $crate::cover_hit(file!(), line!(), stringify!($cond), $cond)
    };
    ($cond:expr, $msg:literal $(,)?) => {
        $crate::cover_hit(file!(), line!(), $msg, $cond)
    };
}

macro_rules! narrow_int {
    ($($t:ty => $u:ty),*) => {$(
        impl Arbitrary for $t {
            fn any_from(src: &mut runner::Source) -> Self {
                src.draw(1u64 << <$u>::BITS) as $u as $t
            }
        }
    )*};
}
narrow_int!(u8 => u8, i8 => u8, u16 => u16, i16 => u16);

macro_rules! wide_int {
    ($($t:ty => $u:ty),*) => {$(
        impl Arbitrary for $t {
            fn any_from(src: &mut runner::Source) -> Self {
                const EDGES: [$t; 7] = [0, 1, 2, <$t>::MAX, <$t>::MIN, <$t>::MAX / 2, <$t>::MIN.wrapping_add(1)];
                src.wide(|rng| {
                    let pick = rng.next() % 4;
                    if pick == 0 {
                        EDGES[(rng.next() % EDGES.len() as u64) as usize]
                            .wrapping_sub((rng.next() % 3) as $t)
                    } else {
                        rng.next() as $u as $t
                    }
                })
            }
        }
    )*};
}
wide_int!(u32 => u32, i32 => u32, u64 => u64, i64 => u64, usize => usize, isize => usize);

impl Arbitrary for bool {
    fn any_from(src: &mut runner::Source) -> Self {
        src.draw(2) == 1
    }
}

impl Arbitrary for f32 {
    fn any_from(src: &mut runner::Source) -> Self {
        const EDGES: [f32; 14] = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MAX,
            f32::MIN,
            f32::MIN_POSITIVE,
            1.0e-45,
            -1.0e-45,
            f32::EPSILON,
            0.5,
        ];
        src.wide(|rng| match rng.next() % 8 {
            0 | 1 => EDGES[(rng.next() % EDGES.len() as u64) as usize],
            // Moderate magnitudes, where the interesting arithmetic happens.
            2..=4 => ((rng.next() % 2_000_001) as f32 - 1_000_000.0) * 1e-4,
            _ => f32::from_bits(rng.next() as u32),
        })
    }
}

impl Arbitrary for f64 {
    fn any_from(src: &mut runner::Source) -> Self {
        src.wide(|rng| match rng.next() % 4 {
            0 => [0.0, -0.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY, f64::MAX, f64::MIN][(rng.next() % 7) as usize],
            1 => ((rng.next() % 2_000_001) as f64 - 1_000_000.0) * 1e-4,
            _ => f64::from_bits(rng.next()),
        })
    }
}

impl<T: Arbitrary, const N: usize> Arbitrary for [T; N] {
    fn any_from(src: &mut runner::Source) -> Self {
        core::array::from_fn(|_| T::any_from(src))
    }
}

impl<T: Arbitrary> Arbitrary for Option<T> {
    fn any_from(src: &mut runner::Source) -> Self {
        if bool::any_from(src) {
            Some(T::any_from(src))
        } else {
            None
        }
    }
}
