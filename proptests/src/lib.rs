//! Property tests of the whole PAROL6 safety kernel.
//!
//! * [`plant`]: the one test plant (steppers, encoders, switches) with fault
//!   injection, re-exported from the `monitor` crate;
//! * [`monitor`]: the one per-tick safety monitor (SR-1..SR-19, SR-25, SR-27..SR-31), the
//!   `monitor` crate, re-exported;
//! * [`scenario`]: random operating sequences and the drivers that play them
//!   against one kernel, or against the f32 and fixed-point kernels in lockstep.
//!
//! The tests are in `tests/`: `kernel_state_machine.rs` (proptest-state-machine
//! runs of both variants), `differential.rs` (f32 vs fixed point),
//! `regressions.rs` (deterministic replays of failing cases the random runs
//! can draw) and `workflow_yaml.rs` (structure of the CI
//! workflow). Failures are persisted
//! under `proptest-regressions/` and replayed first on every run.

pub use monitor::{self, plant};
pub mod scenario;

use proptest::test_runner::{Config, FileFailurePersistence};

/// The number of cases: `PROPTEST_CASES` if set, else `default`.
pub fn cases(default: u32) -> u32 {
    std::env::var("PROPTEST_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(default)
}

/// A proptest configuration with `cases(default)` cases whose failures are
/// persisted in (and replayed from) `file`, a path relative to this crate.
pub fn config(default: u32, file: &'static str) -> Config {
    Config {
        cases: cases(default),
        failure_persistence: Some(Box::new(FileFailurePersistence::Direct(file))),
        // Shrinking replays long sequences: bound it.
        max_shrink_iters: 2048,
        ..Config::default()
    }
}
