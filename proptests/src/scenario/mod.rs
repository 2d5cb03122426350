//! Random operating sequences ("steps"), their strategies, and the drivers
//! that play them against the kernel and the plant with the monitor checking
//! every tick.
//!
//! `steps`: the steps and how one is played on a [`Driver`]; `strategy`:
//! the proptest strategies that draw them; `sut`: one kernel against its
//! plant ([`Sut`]); `pair`: the f32 and fixed-point kernels in lockstep
//! ([`Pair`]).

use kernel::config::AXES;
use kernel::homing::Phase;
use kernel::State;

use monitor::plant::{Plant, DEFAULT_OFFSETS};
use monitor::Stats;

mod pair;
mod steps;
mod strategy;
mod sut;

pub use pair::{Pair, MAX_SKEW, PROFILE_SPLIT, RESYNC_TICKS};
pub use steps::{class, on_a_switch, run_step, Bad, Req, Start, Step, STREAM_SPEED, STREAM_STEP};
pub use strategy::{start_strategy, step_strategy, Mix};
pub use sut::{Snapshot, Sut, Variant};

/// The pose the homed snapshots were homed from (also the scenario tests' start).
pub const START: [f64; AXES] = [0.3, 0.2, -0.4, 0.5, -0.3, 1.0];
/// The scenario tests' encoder offsets.
pub const OFFSETS: [f64; AXES] = DEFAULT_OFFSETS;
/// Bound on the ticks a `WaitHoming` step waits (every axis's homing timeout
/// is at most 12 s, three groups in sequence).
pub const HOMING_WAIT_MAX: u32 = 40_000;

/// Something the steps can drive: one kernel, or two in lockstep.
pub trait Driver {
    /// The (reference) plant's joint angles.
    fn q(&self) -> [f64; AXES];
    /// Changes the environment of every plant.
    fn env(&mut self, f: &dyn Fn(&mut Plant));
    /// One tick.
    fn tick(&mut self, req: Option<Req>);
    /// The (reference) kernel's state.
    fn state(&self) -> State;
    /// The (reference) kernel's homing phase of every axis.
    fn phases(&self) -> [Phase; AXES];
}

/// Adds a finished run's coverage to a shared total.
pub fn record(total: &std::sync::Mutex<Stats>, s: &Stats) {
    if let Ok(mut t) = total.lock() {
        t.merge(s);
    }
}
