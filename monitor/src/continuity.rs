//! SR-30, stream continuity, written from `SAFETY.md` and the
//! configuration: a driver sample is refused (`TargetJump`) when, on some
//! axis, it is farther than the speed limit allows from the previous sample
//! of a live stream (over the time between them, at least one longest
//! segment, plus `target_jump_tolerance`) **and** not where the set-point
//! can be within one longest segment `T` from its velocity `v` at the
//! joint's `max_acceleration` `a`: between the set-point and
//! `sp + v T +- a T^2 / 2`, widened by the tolerance, and at most the
//! tolerance inside the set-point's stopping distance (its stopping point
//! lies no farther than that beyond both the set-point and the sample).
//!
//! The monitor's set-point velocity comes from consecutive set-points and
//! its stopping distance from the stated profile, so each test is judged as
//! a band: [`Continuity::surely`] (the kernel must accept) and
//! [`Continuity::possibly`] (the kernel may accept).

use kernel::config::{ms_to_ticks, ArmConfig, JointConfig};

/// Slack (rad) of the distance to the previous sample: rounding of the
/// kernel's distances and bound (f32 at |x| < 16: 2e-6; I8F24: 6e-8).
pub const SAMPLE_SLACK: f64 = 1e-4;

/// Slack (rad) of the set-point tests: the kernel's own set-point velocity
/// differs from the monitor's (from consecutive set-points) by rounding,
/// and its stopping point is a bound above `v^2 / 2a + |v| dt / 2` by at
/// most `dv dt / 8` plus its rounding allowance.
pub const REACH_SLACK: f64 = 1e-3;

/// One axis's sample, as the monitor sees it.
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    /// The stream is live: its previous sample is the previous target.
    pub live: bool,
    /// Ticks since the previous accepted sample.
    pub gap_ticks: u32,
    /// The sample, the previous target, the set-point and its velocity
    /// (rad, rad/s).
    pub x: f64,
    /// The previous target.
    pub prev: f64,
    /// The set-point.
    pub sp: f64,
    /// The set-point's velocity (rad/s).
    pub v: f64,
}

/// The two sides of the band.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Continuity {
    /// Within the bounds by more than the slack: the kernel must accept.
    pub surely: bool,
    /// Within the bounds plus the slack: the kernel may accept.
    pub possibly: bool,
}

/// Where the set-point comes to rest if it brakes at once, along its
/// velocity: `|v| dt` (this tick's step) plus `v^2 / 2a_sp - |v| dt / 2`
/// (the braking sum's bound at the set-point acceleration).
pub fn stop_point(cfg: &ArmConfig, j: &JointConfig, sp: f64, v: f64) -> f64 {
    let dt = 1.0 / f64::from(cfg.tick_hz);
    let a = f64::from(j.setpoint_acceleration());
    let d = v.abs() * dt + (v * v / (2.0 * a) - v.abs() * dt / 2.0).max(0.0);
    if v < 0.0 {
        sp - d
    } else {
        sp + d
    }
}

/// Judges one axis of a stream sample.
pub fn judge(cfg: &ArmConfig, j: &JointConfig, s: &Sample) -> Continuity {
    let hz = f64::from(cfg.tick_hz);
    let tol = f64::from(cfg.target_jump_tolerance);
    let seg = ms_to_ticks(cfg.segment_max_ms, cfg.tick_hz);
    let t = f64::from(seg) / hz;
    let bound = f64::from(j.max_velocity) * f64::from(s.gap_ticks.max(seg)) / hz + tol;
    let d = (s.x - s.prev).abs();
    let a = f64::from(j.max_acceleration);
    let drift = s.sp + s.v * t;
    let lo = s.sp.min(drift - a * t * t / 2.0) - tol;
    let hi = s.sp.max(drift + a * t * t / 2.0) + tol;
    // How far outside [lo, hi] (negative: inside by that much).
    let outside = (lo - s.x).max(s.x - hi);
    let stop = stop_point(cfg, j, s.sp, s.v);
    let along = |y: f64| if s.v < 0.0 { -y } else { y };
    let excursion = along(stop) - along(s.sp).max(along(s.x));
    Continuity {
        surely: (s.live && d <= bound - SAMPLE_SLACK) || (outside <= -REACH_SLACK && excursion <= tol - REACH_SLACK),
        possibly: (s.live && d <= bound + SAMPLE_SLACK) || (outside <= REACH_SLACK && excursion <= tol + REACH_SLACK),
    }
}
