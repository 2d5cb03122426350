//! Kani harnesses for the safety requirements of `SAFETY.md`.
//!
//! Every harness is written in Kani's own syntax. On a runner with Kani
//! (`cargo kani -p proofs`) they are symbolic proofs. Here, Kani cannot run;
//! the project's shim (`proofs/kani-shim`, depended on as `kani` only when
//! `cfg(not(kani))`) turns each into a test that is enumerated exhaustively
//! when its inputs are narrow and sampled otherwise, and says which.
//!
//! Harness names end in `_f32` or `_fx`: one per numeric variant.
//!
//! The harnesses of the whole tick are one-step lemmas (`state_props`):
//! one tick from a stated state, the first tick from `Kernel::new` or any
//! state the kernel's invariant admits (built by `Kernel::from_spec`),
//! keeping the invariant and asserting the tick's properties; the
//! induction that carries them to every tick, and its condition, is
//! written in `kernel_props` and SAFETY.md. The multi-tick runs from
//! power-on (`kernel_props`, `motion_props`) are sampled end-to-end tests
//! under the shim's runner (`setup::end_to_end!`), not Kani harnesses;
//! each says what it adds to the lemmas.
//!
//! Unwind bounds: Kani's `#[kani::unwind(n)]` lets every loop run at most
//! n - 1 iterations per entry. The code under test's loops run over the six
//! axes, the three homing groups or the tick's events (`setup::KERNEL_UNWIND`,
//! 7, checked by the source scan `tests/loops.rs`); the harnesses' own loops
//! are over ticks and say their bound where they are written. Each
//! `#[kani::unwind(n)]` is the largest of these plus one, with its reason in
//! a comment. The shim enforces the bound on every loop of the harnesses
//! and their helpers (`#[cfg_attr(not(kani), kani::loops)]`) and requires
//! `KERNEL_UNWIND` of every harness that runs a tick.

//!
//! Footprint: every harness states, in its documentation, how many
//! symbolic values it draws (each primitive value a `kani::any()` gives:
//! an `f32`, a `u8`, a `bool`) and how many kernel ticks it runs, set-up
//! included, on its longest path (`/// Footprint: N symbolic values, T
//! ticks`), counted from its code. The shim counts both on every case and
//! fails a case that exceeds either (`kani::runner::Footprint`); its report
//! line gives the largest seen. `#[kani::proof]` refuses, at compile time,
//! a stated footprint beyond the budget: one kernel tick and 128 symbolic
//! values (`kani-shim-macros`); a run of several ticks is a sampled
//! end-to-end test (`setup::end_to_end!`). Draws that only steer the shim's sampling
//! (`kani::runner::hint`, in `#[cfg(not(kani))]` code) are no symbolic
//! values. Floating point: a kernel tick runs 859-1273 scalar operations
//! (arithmetic, min/max, comparisons; idle 885, accepting a target 1273,
//! moving 859, soft stop 1001: `cargo test -p proofs --lib
//! float_operations_per_tick -- --nocapture`, which fails above 1500 and
//! when these figures are not the ones it measures), so
//! a harness's floating-point footprint is about its ticks times that. In
//! an `_f32` harness each is an `f32` operation (Kani bit-blasts it); in
//! an `_fx` harness each is integer arithmetic (the kernel converts its
//! configuration to I8F24 once, in `Kernel::new`, from constants). The
//! Kani harnesses run no monitor: the one-step lemmas state their
//! properties in the kernel's scalar type, so an `_fx` lemma compares raw
//! I8F24 words (the `fixed` crate's ordering) and converts no symbolic
//! value to a float. The monitor, which compares in `f64` through `f32`,
//! checks every tick of the sampled end-to-end tests only.

#![allow(clippy::needless_range_loop)] // six axes: indices read best

pub mod setup;

#[cfg(all(test, not(kani)))]
mod float_ops;
#[cfg(all(test, not(kani)))]
mod kernel_props;
#[cfg(all(test, not(kani)))]
mod motion_props;
#[cfg(any(kani, test))]
mod numeric;
#[cfg(all(test, not(kani)))]
mod shim_checks;
#[cfg(any(kani, test))]
mod state_props;
#[cfg(any(kani, test))]
mod wire;
