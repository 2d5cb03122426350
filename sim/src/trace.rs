//! The per-tick trace of a run: what the report's statistics, the
//! expectations and the plots are computed from.

use kernel::config::AXES;
use kernel::State;

/// Standstill: every commanded speed below this (rad/s). A joint holding its
/// target is servoed: its encoder noise makes the command dither by a few
/// mrad/s, which is not motion.
pub const STILL_SPEED: f32 = 0.01;

/// One recorded tick (what the plots and the report need).
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    /// Time (ms).
    pub t: u64,
    /// Kernel state.
    pub state: State,
    /// True joint angles (rad).
    pub q: [f32; AXES],
    /// Kernel's estimate (rad).
    pub est: [f32; AXES],
    /// Kernel's set-point (rad).
    pub sp: [f32; AXES],
    /// Commanded velocity (rad/s).
    pub v: [f32; AXES],
    /// Every commanded speed below [`STILL_SPEED`] (standstill or holding).
    pub still: bool,
    /// A motion command was accepted this tick.
    pub accepted: bool,
    /// Some request (motion, home, enable) was accepted this tick.
    pub request_ok: bool,
    /// The active stream's continuous reference (rad), NaN when none.
    pub reference: [f32; AXES],
}

/// The change of joint `i`'s commanded velocity from `a` to `b` (rad/s per
/// tick), or `None` where no acceleration limit applies: the tick a fault
/// zeroes every output, and homing's stop at a switch (an axis's output
/// becoming exactly zero in Homing: SR-14 lets that stop be
/// instantaneous).
pub fn accel_step(a: &Sample, b: &Sample, i: usize) -> Option<f64> {
    if b.state == State::Fault && a.state != State::Fault {
        return None;
    }
    if b.state == State::Homing && b.v[i] == 0.0 {
        return None;
    }
    Some((f64::from(b.v[i]) - f64::from(a.v[i])).abs())
}

/// The samples from time `at` on (the trace's times increase strictly: one
/// sample per tick).
pub fn from_t(trace: &[Sample], at: u64) -> &[Sample] {
    &trace[trace.partition_point(|s| s.t < at)..]
}
