//! The PAROL6 safety kernel.
//!
//! Every actuation of the arm is computed here, once per control tick, in a
//! fixed order for all six axes:
//!
//! 1. **sense**: encoder counts and debounced limit switches ([`Sense`]);
//! 2. **estimate**: exact integer 2 pi unwrapping and an alpha-beta observer
//!    ([`observer`]);
//! 3. **supervise**: the state machine ([`State`]), homing ([`homing`]), the
//!    interpolator ([`interp`]) and control law ([`control`]), the command
//!    timeout and soft E-stop ramp, and the fault checks (runaway, limit
//!    switches, encoder loss and jumps, position limits, non-finite values);
//! 4. **act**: the velocities and step rates of *all* axes, returned only
//!    after every one has been computed and checked, so a fault on any axis
//!    zeroes every axis in the same tick.
//!
//! The crate is `no_std`, allocates nothing, contains no `unsafe`, and has no
//! panicking operation outside tests (clippy denies `unwrap`, `expect`,
//! indexing, `panic!` and unchecked arithmetic). Every loop is bounded by the
//! number of axes or homing groups.
//!
//! One source serves two numeric variants through [`Scalar`]:
//! [`KernelF32`] and [`KernelFx`] (fixed point, [`Fx`] = `I8F24`).
//!
//! ```
//! use kernel::{config::PAROL6_VALIDATED, EncoderSample, KernelF32, Request, Sense, State};
//! let (mut k, authority) = KernelF32::new(&PAROL6_VALIDATED);
//! let sense = Sense { encoders: [EncoderSample::Count(1000); 6], limits: 0, hardware_fault: None, link_lost: false };
//! let out = k.tick(&sense, None);
//! assert_eq!(out.status.state, State::Unhomed);
//! assert!(out.act.velocity.iter().all(|v| *v == 0.0)); // nothing moves at power-on
//! let out = k.tick(&sense, Some(Request::Enable(authority.enable())));
//! assert!(out.events.iter().any(|e| matches!(e, kernel::Event::Rejected { .. })));
//! ```
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
// `Ord::clamp` panics when min > max; the kernel writes `max(..).min(..)`
// instead so that no panic path is reachable from the tick (checked on the
// firmware image by firmware/build.sh).
#![allow(clippy::manual_clamp)]
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::indexing_slicing,
        clippy::panic,
        clippy::arithmetic_side_effects
    )
)]

pub mod config;
pub mod control;
pub mod homing;
pub mod interp;
mod kernel;
pub mod observer;
pub mod ramp;
pub mod scalar;
mod types;

#[cfg(feature = "proof-states")]
pub use kernel::{AxisSpec, SpecMode, StateSpec};
pub use kernel::{Kernel, TargetLimits};
pub use scalar::{Fx, Scalar};
pub use types::*;

/// The kernel with `f32` arithmetic.
pub type KernelF32 = Kernel<f32>;
/// The kernel with `I8F24` fixed-point arithmetic.
pub type KernelFx = Kernel<Fx>;
