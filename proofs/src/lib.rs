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
//! Unwind bounds: the kernel's own loops run over the six axes (`iter()` over
//! `[_; 6]`: 7 iterations including the exit test) and the three homing
//! groups; the harnesses' own loops are over ticks and say their bound where
//! they are written. `#[kani::unwind(n)]` is the largest of these plus one.

#![allow(clippy::needless_range_loop)] // six axes: indices read best

pub mod setup;

#[cfg(any(kani, test))]
mod kernel_props;
#[cfg(any(kani, test))]
mod motion_props;
#[cfg(any(kani, test))]
mod numeric;
#[cfg(any(kani, test))]
mod wire;
