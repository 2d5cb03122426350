//! Everything that can be computed without touching a register. No
//! dependencies, no floats, no panics outside `const` evaluation and tests.

#![deny(clippy::arithmetic_side_effects)]

pub mod channel;
pub mod clock;
pub mod clock_check;
pub mod debounce;
pub mod encoder;
pub mod frame;
pub mod march;
pub mod mpu;
pub mod mt6816;
pub mod pins;
pub mod reset_cause;
pub mod step;
pub mod tmc5160;
pub mod uart;
