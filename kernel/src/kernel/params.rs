//! Parameters: every constant of a kernel, derived once from an
//! [`ArmConfig`] into the kernel's scalar type ([`Params`], per axis
//! [`AxisParams`]), and the motion-target limits shared with the protocol
//! parser ([`TargetLimits`]). Nothing here changes after `Kernel::new`.

use crate::config::{
    ms_to_ticks, ArmConfig, JointConfig, Validated, AXES, HOLD_SPEED, MAX_SEGMENT_TICKS, POSITION_ABS_MAX,
};
use crate::homing::HomingParams;
use crate::interp::{joint_profile, Profile};
use crate::observer::ObserverGains;
use crate::scalar::Scalar;
use crate::types::{MotionTarget, Reject};

/// Velocities beyond this magnitude (rad/s) in the observer are absurd.
const VELOCITY_ABS_MAX: f32 = 64.0;

/// The limits a motion target must respect, in the kernel's scalar type:
/// the one check both the protocol parser and the kernel apply, so they can
/// never disagree.
///
/// The configuration states limits as `f32`; each is widened outward by one
/// `f32` ulp (~0.2 urad) before conversion so that the fixed-point variant,
/// whose nearest value to e.g. `2.1f32` lies 1-2 LSB inside `2.1`, still
/// accepts a command of exactly `2.100`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TargetLimits<S> {
    lo: [S; AXES],
    hi: [S; AXES],
    vmax: [S; AXES],
}

impl<S: Scalar> TargetLimits<S> {
    /// The limits of `config`'s joints.
    pub fn new(config: &Validated) -> Self {
        let config = config.config();
        TargetLimits {
            lo: config.joints.map(|j| S::from_f32(j.limit_min.next_down())),
            hi: config.joints.map(|j| S::from_f32(j.limit_max.next_up())),
            vmax: config.joints.map(|j| S::from_f32(j.max_velocity)),
        }
    }
    /// Accepts the target whole, or names the first axis and reason.
    pub fn check(&self, t: &MotionTarget<S>) -> Result<(), Reject> {
        let lims = self.lo.iter().zip(self.hi.iter()).zip(self.vmax.iter());
        for (i, ((pos, vel), ((lo, hi), vmax))) in t.position.iter().zip(t.velocity.iter()).zip(lims).enumerate() {
            let axis = i as u8;
            if !(pos.is_finite() && vel.is_finite()) {
                return Err(Reject::NonFinite { axis });
            }
            if pos < lo || pos > hi {
                return Err(Reject::PositionOutOfLimits { axis });
            }
            if vel.abs() > *vmax {
                return Err(Reject::VelocityTooHigh { axis });
            }
        }
        Ok(())
    }
}

/// Per-axis constants in the kernel's scalar type.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct AxisParams<S: Scalar> {
    pub vmax: S,
    pub runaway: S,
    pub kp: S,
    /// Largest velocity change per tick in Operational.
    pub accel_step: S,
    /// Largest velocity change per tick in a soft stop: vmax / N (at most
    /// `accel_step`: `config::check`).
    pub stop_step: S,
    pub pos_lo: S,
    pub pos_hi: S,
    pub k_count: S::Wide,
    pub k_rate: S::Wide,
    pub enc_sign: i32,
    /// Plausibility window (counts) for one tick.
    pub max_jump: i32,
    pub switch_position: S,
    /// Speed (rad/s) above which the estimate moving against the command
    /// counts as the wrong direction: half the speed limit. The observer's
    /// velocity lags a reversal at full acceleration by up to ~2 rad/s (a
    /// clean plant tripped a lower threshold in the property tests); below
    /// it, the distance bound alone catches a reversed motor.
    pub dir_speed: S,
    /// Re-homing a homed joint: fast-seek travel allowed beyond the known
    /// distance to its switch (rad): 0.1 rad plus the braking distance.
    pub rehome_margin: S,
    pub homing: HomingParams<S>,
    /// The set-point profile (acceleration and speed limits).
    pub profile: Profile<S>,
    /// Stream continuity (`SAFETY.md` SR-30): a driver sample is accepted
    /// within `sample_step` per tick since the previous sample of its
    /// stream (at least [`Self::reach_period`]'s ticks) plus `jump_tol`, or
    /// within where the set-point can be within one longest segment.
    /// The speed limit per tick (rad).
    pub sample_step: S,
    /// `target_jump_tolerance` (rad).
    pub jump_tol: S,
    /// One longest segment (s): the stream period the set-point's reach is
    /// judged over.
    pub reach_period: S,
    /// `max_acceleration * period^2 / 2` (rad): what acceleration adds to
    /// the set-point's drift over one longest segment.
    pub reach_accel: S,
}

impl<S: Scalar> AxisParams<S> {
    fn new(j: &JointConfig, c: &ArmConfig) -> Self {
        // `c` passed `config::check` (the only way to a `Validated`).
        let dir = j.homing.direction.sign();
        let motor = if j.motor_reversed { -1.0 } else { 1.0 };
        let seg_s = ms_to_ticks(c.segment_max_ms, c.tick_hz) as f32 / c.tick_hz as f32;
        AxisParams {
            vmax: S::from_f32(j.max_velocity),
            runaway: S::from_f32(j.runaway_velocity),
            kp: S::from_f32(j.kp),
            accel_step: S::from_f32(j.max_acceleration / c.tick_hz as f32),
            stop_step: S::from_f32(j.max_velocity / ms_to_ticks(c.soft_stop_ms, c.tick_hz).max(1) as f32),
            pos_lo: S::from_f32(j.limit_min - c.position_margin),
            pos_hi: S::from_f32(j.limit_max + c.position_margin),
            k_count: S::wide_from_f64(j.rad_per_count()),
            k_rate: S::wide_from_f64(j.steps_per_rad() * motor),
            enc_sign: if j.encoder_reversed { -1 } else { 1 },
            max_jump: j.max_jump_counts(c.tick_hz),
            switch_position: S::from_f32(j.homing.switch_position),
            rehome_margin: S::from_f32(0.1 + j.braking_distance(j.homing.fast_speed)),
            dir_speed: S::from_f32(0.5 * j.max_velocity),
            homing: HomingParams {
                fast_toward: S::from_f32(j.homing.fast_speed * dir),
                slow_toward: S::from_f32(j.homing.slow_speed * dir),
                backoff: S::from_f32(j.homing.backoff),
                timeout_ticks: ms_to_ticks(j.homing.timeout_ms, c.tick_hz),
                dv: S::from_f32(j.max_acceleration / c.tick_hz as f32),
                max_travel: S::from_f32(j.homing.max_travel),
                phase_travel: S::from_f32(j.homing_phase_travel()),
                settle_ticks: ms_to_ticks(c.homing_settle_ms, c.tick_hz),
            },
            profile: joint_profile(j, c.tick_hz),
            sample_step: S::from_f32(j.max_velocity / c.tick_hz as f32),
            jump_tol: S::from_f32(c.target_jump_tolerance),
            reach_period: S::from_f32(seg_s),
            reach_accel: S::from_f32(j.max_acceleration * seg_s * seg_s * 0.5),
        }
    }
}

/// All constants of a kernel, derived once from an [`ArmConfig`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Params<S: Scalar> {
    pub axes: [AxisParams<S>; AXES],
    pub limits: TargetLimits<S>,
    pub gains: ObserverGains<S>,
    pub tick_hz: i32,
    pub deadband: S,
    pub timeout_ticks: u32,
    pub stop_ticks: u32,
    pub inv_stop: S,
    pub seg_min: u32,
    pub seg_max: u32,
    pub boot_ticks: u32,
    /// Ticks a homing run rests before it moves (the settle time).
    pub home_wait_ticks: u32,
    /// Following-error bound (rad), half of it, and its time (ticks).
    pub fe: S,
    pub fe_half: S,
    pub fe_ticks: u32,

    /// Outputs at or below this are holding, not moving (rad/s).
    pub hold_speed: S,
    pub invalid_limit: u32,
    pub pos_abs: S,
    pub vel_abs: S,
}

impl<S: Scalar> Params<S> {
    pub(crate) fn new(v: &Validated) -> Self {
        let c: &ArmConfig = v.config();
        let stop_ticks = ms_to_ticks(c.soft_stop_ms, c.tick_hz).max(1);
        Params {
            axes: c.joints.map(|j| AxisParams::new(&j, c)),
            limits: TargetLimits::new(v),
            gains: ObserverGains {
                alpha: S::from_f32(c.alpha()),
                beta_hz: S::from_f32(c.beta() * c.tick_hz as f32),
                dt: S::from_f32(1.0 / c.tick_hz as f32),
            },
            tick_hz: i32::try_from(c.tick_hz).unwrap_or(1000),
            deadband: S::from_f32(c.deadband),
            timeout_ticks: ms_to_ticks(c.command_timeout_ms, c.tick_hz),
            stop_ticks,
            inv_stop: S::from_f32(1.0 / stop_ticks as f32),
            seg_min: ms_to_ticks(c.segment_min_ms, c.tick_hz).max(1),
            seg_max: ms_to_ticks(c.segment_max_ms, c.tick_hz).max(1).min(MAX_SEGMENT_TICKS),
            fe: S::from_f32(c.following_error),
            fe_half: S::from_f32(c.following_error * 0.5),
            fe_ticks: ms_to_ticks(c.following_error_ms, c.tick_hz),
            hold_speed: S::from_f32(HOLD_SPEED),
            boot_ticks: ms_to_ticks(c.boot_timeout_ms, c.tick_hz),
            home_wait_ticks: ms_to_ticks(c.homing_settle_ms, c.tick_hz),
            invalid_limit: c.encoder_invalid_limit,
            pos_abs: S::from_f32(POSITION_ABS_MAX),
            vel_abs: S::from_f32(VELOCITY_ABS_MAX),
        }
    }
}

#[cfg(test)]
mod figures {
    use super::Params;
    use crate::config::PAROL6_VALIDATED;
    use crate::interp::Interpolator;
    use crate::scalar::Scalar;

    /// Ticks a set-point moving at the speed limit needs to come to rest
    /// on a target one braking distance ahead (the kernel's own profile,
    /// stepped).
    fn braking_ticks<S: Scalar>(p: &super::AxisParams<S>) -> u32 {
        let stop_at = p.vmax.times(p.vmax).times(p.profile.inv_2a);
        let mut i = Interpolator::from_parts(S::ZERO, stop_at, p.vmax, p.vmax, &p.profile);
        let mut n = 0;
        while !i.at_rest() && n < 10_000 {
            i.advance(&p.profile);
            n += 1;
        }
        n
    }

    /// The figures the documents quote (docs/PROTOCOL.md 6.2, 6.3;
    /// SAFETY.md SR-30, section 8), printed from the kernel's parameters:
    /// `cargo test -p kernel --lib figures -- --nocapture`.
    #[test]
    fn document_figures() {
        let p = Params::<f32>::new(&PAROL6_VALIDATED);
        for (i, (a, j)) in p.axes.iter().zip(PAROL6_VALIDATED.config().joints.iter()).enumerate() {
            // The stepped profile stops within a few ticks of v / a, and the
            // continuity bound admits a full-speed stream's set-point lag.
            let ideal = (j.max_velocity / j.setpoint_acceleration() * p.tick_hz as f32).ceil() as u32;
            let n = braking_ticks(a);
            assert!((ideal..=ideal + 3).contains(&n), "J{}: {n} ticks, v/a {ideal}", i + 1);
            let seg = p.seg_max as i32;
            let sample = a.sample_step.times_int(seg).plus(a.jump_tol);
            let rest = a.reach_accel.plus(a.jump_tol);
            println!(
                "J{}: stream continuity {:.4} rad from the previous sample per {} ms, {:.4} rad from rest; set-point braking from {:.1} rad/s: {} ms",
                i + 1,
                sample,
                seg,
                rest,
                a.vmax,
                n
            );
        }
    }
}
