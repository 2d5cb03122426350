//! The PAROL6 firmware's kernel and protocol against a simulated arm.
//!
//! [`root::Root`] is the firmware's composition root (`firmware::root`, the
//! code that is flashed) on a simulated board: a [`plant::Plant`] whose encoders
//! produce real MT6816 PWM frames decoded with `hal-imxrt`'s pure decoder.
//! [`runner`] runs [`scenario`]s against it and checks the safety
//! requirements at every tick; [`live`] serves the wire protocol on a
//! pseudo-terminal (and optionally TCP) in real time.

pub mod client;
pub mod encoder;
pub mod live;
pub mod numfmt;
pub mod plant;
pub mod report;
pub mod rng;
pub mod root;
pub mod runner;
pub mod scenario;
pub mod stream;
pub mod svg;
pub mod trace;
