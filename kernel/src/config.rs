//! Configuration as typed constant data, checked when the crate is compiled.
//!
//! [`PAROL6`] holds the values of `docs/spec/robot.md`. [`check`] is a `const fn`; the
//! crate evaluates it on [`PAROL6`] in a constant, so an inconsistent
//! configuration (a velocity the step generator cannot reach, a runaway
//! threshold at or below the clamp, unordered limits, a homing sequence that
//! cannot finish within the driver's 90 s, unstable gains) is a build error,
//! not a robot error. A firmware that defines its own configuration must do
//! the same with [`assert_valid`]:
//!
//! ```
//! const MY_ARM: kernel::config::ArmConfig = kernel::config::PAROL6;
//! const _: () = kernel::config::assert_valid(&MY_ARM);
//! ```
//!
//! ```compile_fail
//! // A runaway threshold equal to the clamp (C++ defect 7) does not build.
//! use kernel::config::*;
//! const BAD: ArmConfig = {
//!     let mut c = PAROL6;
//!     c.joints[0].runaway_velocity = c.joints[0].max_velocity;
//!     c
//! };
//! const _: () = assert_valid(&BAD);
//! ```
//!
//! All times are given in milliseconds and converted to ticks from
//! [`ArmConfig::tick_hz`]; nothing assumes a 1 ms tick (C++ defect 11).

// Evaluated at compile time: an out-of-bounds index or an integer overflow
// here is a build error, not a runtime panic, and the loops are bounded by the
// array length. (`Params::new` calls the derived-value helpers once at
// initialisation, on values `check` has bounded.)
#![allow(clippy::indexing_slicing, clippy::arithmetic_side_effects, clippy::panic)]

/// Number of axes.
pub const AXES: usize = 6;
/// MT6816 counts per motor revolution (12-bit PWM output). The kernel
/// depends on no HAL: `firmware/src/lib.rs` checks at compile time that this
/// and [`ENCODER_FRAME_S`] are the HAL's (`hal_imxrt::pure::mt6816`).
pub const COUNTS_PER_REV: i32 = 4096;
/// Unwrapped joint angles beyond this magnitude (rad) are absurd: a fault.
pub const POSITION_ABS_MAX: f32 = 32.0;
/// Period of one MT6816 PWM frame (s): 4119 clocks of 250 ns. A reading is
/// the angle of the last complete frame, so it can lag the shaft by up to
/// two frames; the plausibility window covers one tick plus two frames of
/// motion at the runaway velocity, whatever the tick rate (C++ defect 11).
pub const ENCODER_FRAME_S: f64 = 4119.0 * 250e-9;
/// Noise allowance of the encoder plausibility check, in counts.
pub const JUMP_SLACK_COUNTS: i32 = 8;

/// Homing groups in the arm's order (docs/spec/robot.md section 4): J6;
/// then J5 and J4; then J1, J2, J3.
/// Bit `i` is joint `J(i+1)`. Not configurable: the order is a mechanical fact
/// of the arm, and the safety argument depends on it.
pub const HOMING_GROUPS: [u8; 3] = [0b10_0000, 0b01_1000, 0b00_0111];

/// Direction of a homing seek, in joint coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// Toward increasing joint angle.
    Positive,
    /// Toward decreasing joint angle.
    Negative,
}

impl Direction {
    /// +1.0 or -1.0.
    pub const fn sign(self) -> f32 {
        match self {
            Direction::Positive => 1.0,
            Direction::Negative => -1.0,
        }
    }
}

/// Homing parameters of one joint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HomingConfig {
    /// Direction of the fast and slow seeks (toward the switch).
    pub direction: Direction,
    /// Fast seek, back-off and release speed (rad/s, joint).
    pub fast_speed: f32,
    /// Slow seek speed (rad/s, joint).
    pub slow_speed: f32,
    /// Distance travelled past the point where the switch releases, both in
    /// the back-off before the slow seek and in the final release (rad).
    pub backoff: f32,
    /// Joint angle assigned to the encoder reading at the switch: the zero is
    /// the real reading plus this offset (rad).
    pub switch_position: f32,
    /// Time allowed for this joint's whole homing sequence (ms).
    pub timeout_ms: u32,
    /// Largest travel of the fast seek (rad): a dead switch or a reversed
    /// motor faults after this distance, before the hard stop. At least the
    /// joint range plus the switch's distance beyond the limit, at most
    /// 0.25 rad more (checked).
    pub max_travel: f32,
}

/// One joint's mechanics, limits and gains.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointConfig {
    /// Motor revolutions per joint revolution.
    pub gear_ratio: f32,
    /// Motor full steps per revolution.
    pub full_steps_per_rev: u32,
    /// Driver microsteps per full step.
    pub microsteps: u32,
    /// Command clamp (rad/s, joint).
    pub max_velocity: f32,
    /// Measured speed above which the joint is running away (rad/s, joint).
    pub runaway_velocity: f32,
    /// Proportional gain (1/s).
    pub kp: f32,
    /// Largest change of the commanded velocity in Operational (rad/s^2).
    pub max_acceleration: f32,
    /// Lower joint limit (rad).
    pub limit_min: f32,
    /// Upper joint limit (rad).
    pub limit_max: f32,
    /// The encoder counts down when the joint angle increases.
    pub encoder_reversed: bool,
    /// A positive step rate decreases the joint angle.
    pub motor_reversed: bool,
    /// Homing parameters.
    pub homing: HomingConfig,
}

impl JointConfig {
    /// Microsteps per radian of joint angle.
    pub const fn steps_per_rad(&self) -> f64 {
        self.full_steps_per_rev as f64 * self.microsteps as f64 * self.gear_ratio as f64 / core::f64::consts::TAU
    }
    /// Joint radians per encoder count.
    pub const fn rad_per_count(&self) -> f64 {
        core::f64::consts::TAU / (COUNTS_PER_REV as f64 * self.gear_ratio as f64)
    }
    /// Largest plausible change of the encoder reading in one tick
    /// (counts): a tick plus two PWM frames of motion at the runaway
    /// velocity, plus the noise allowance.
    pub const fn max_jump_counts(&self, tick_hz: u32) -> i32 {
        let window_s = 1.0 / tick_hz as f64 + 2.0 * ENCODER_FRAME_S;
        let c = self.runaway_velocity as f64 / self.rad_per_count() * window_s;
        // ceil for a positive value
        let t = c as i32;
        let t = if (t as f64) < c { t + 1 } else { t };
        t + JUMP_SLACK_COUNTS
    }
    /// Nominal time (ms) homing needs at these speeds, over the whole range.
    pub const fn homing_nominal_ms(&self, settle_ms: u32) -> f32 {
        let h = &self.homing;
        let range = self.limit_max - self.limit_min;
        // fast seek over the whole range, back-off and release at fast speed,
        // slow seek over twice the back-off (switch hysteresis allowance),
        // four accelerations to or from the fast speed, and the settle time.
        let ramps = 4.0 * h.fast_speed / self.max_acceleration;
        let s = range / h.fast_speed + 4.0 * h.backoff / h.fast_speed + 2.0 * h.backoff / h.slow_speed + ramps;
        s * 1000.0 + settle_ms as f32
    }
    /// Distance (rad) to stop from `v` (rad/s) at this joint's acceleration.
    pub const fn braking_distance(&self, v: f32) -> f32 {
        v * v / (2.0 * self.max_acceleration)
    }
    /// The set-points' acceleration limit (rad/s^2): a fraction of the
    /// output's ([`SETPOINT_ACCEL_FRACTION`]), so the control law keeps some
    /// authority to correct the joint while the set-point accelerates at
    /// its limit (with none left, a reversal let the joint lag its set-point
    /// by more than half the following-error bound: found by the property
    /// tests).
    pub const fn setpoint_acceleration(&self) -> f32 {
        self.max_acceleration * SETPOINT_ACCEL_FRACTION
    }
    /// Distance (rad) a set-point needs to stop from `v` (rad/s).
    pub const fn setpoint_braking_distance(&self, v: f32) -> f32 {
        v * v / (2.0 * self.setpoint_acceleration())
    }
    /// Largest travel of a homing phase other than the fast seek (rad):
    /// back-off or release (switch travel, the back-off and the braking
    /// distance), or the slow seek back over them.
    pub const fn homing_phase_travel(&self) -> f32 {
        4.0 * self.homing.backoff + 2.0 * self.braking_distance(self.homing.fast_speed)
    }
}

/// The whole arm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArmConfig {
    /// Control tick rate (Hz). Every time constant is derived from it.
    pub tick_hz: u32,
    /// Joints J1..J6.
    pub joints: [JointConfig; AXES],
    /// Alpha-beta observer position gain (1/s): alpha = gain / tick_hz.
    pub observer_position_gain: f32,
    /// Alpha-beta observer velocity gain (1/s^2): beta = gain / tick_hz^2.
    pub observer_velocity_gain: f32,
    /// Control output deadband (rad/s); 0 disables it.
    pub deadband: f32,
    /// Command timeout after which the soft E-stop starts (ms).
    pub command_timeout_ms: u32,
    /// Duration of the soft E-stop ramp from any speed to zero (ms).
    pub soft_stop_ms: u32,
    /// Budget from the last command to standstill (ms): timeout + ramp must fit.
    pub stop_budget_ms: u32,
    /// Highest step rate the step generator produces (steps/s).
    pub max_step_rate: u32,
    /// Shortest interpolation segment (ms), i.e. the fastest target rate.
    pub segment_min_ms: u32,
    /// Longest interpolation segment (ms), i.e. the slowest target rate.
    pub segment_max_ms: u32,
    /// Time allowed for every encoder to give a first valid reading (ms).
    pub boot_timeout_ms: u32,
    /// Time the ROS 2 driver waits for homing, minus a margin (ms).
    pub homing_budget_ms: u32,
    /// Distance beyond the joint limits tolerated before a position fault (rad).
    pub position_margin: f32,
    /// Consecutive invalid or implausible encoder samples tolerated (the
    /// observer coasts on its prediction meanwhile); one more is a fault.
    pub encoder_invalid_limit: u32,
    /// Following error (rad): a joint whose estimate is farther than this
    /// from its commanded path (or, while more than half of it behind,
    /// moves against the command) for longer than
    /// [`ArmConfig::following_error_ms`] faults.
    pub following_error: f32,
    /// Time the following error may persist (ms).
    pub following_error_ms: u32,
    /// Time each joint rests at the end of its homing before it counts as
    /// done, so the set-point then taken from the estimate is where the
    /// joint is (ms).
    pub homing_settle_ms: u32,
    /// Tolerance (rad) added to the distance a stream segment can travel at
    /// the joint's speed limit before a driver-dialect target is refused as
    /// a jump.
    pub target_jump_tolerance: f32,
}

impl ArmConfig {
    /// The observer's alpha (per tick).
    pub const fn alpha(&self) -> f32 {
        self.observer_position_gain / self.tick_hz as f32
    }
    /// The observer's beta (per tick).
    pub const fn beta(&self) -> f32 {
        self.observer_velocity_gain / (self.tick_hz as f32 * self.tick_hz as f32)
    }
    /// How far past its last validated target a joint can travel: a soft
    /// stop's ramp (linear over `soft_stop_ms`) started at speed `v` goes
    /// `v T / 2`, the set-point's own braking `v^2 / 2a`; the difference is
    /// largest at `v = a T / 2`: `a T^2 / 8` (rad), plus the following error
    /// (beyond which the joint faults).
    pub const fn overrun_bound(&self, j: &JointConfig) -> f32 {
        let t = self.soft_stop_ms as f32 / 1000.0;
        j.max_acceleration * t * t / 8.0 + self.following_error
    }
}

/// A configuration that passed [`check`]: the only kind a kernel accepts.
///
/// ```compile_fail
/// // A kernel cannot be built from an unchecked configuration.
/// let _ = kernel::KernelF32::new(&kernel::config::PAROL6);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Validated(ArmConfig);

impl Validated {
    /// `c` if it passes [`check`], else the first inconsistency.
    pub const fn new(c: ArmConfig) -> Result<Self, &'static str> {
        match check(&c) {
            Ok(()) => Ok(Validated(c)),
            Err(e) => Err(e),
        }
    }
    /// `c` if valid; fails the build when evaluated in a constant otherwise.
    pub const fn assert(c: ArmConfig) -> Self {
        match check(&c) {
            Ok(()) => Validated(c),
            Err(e) => panic!("{}", e),
        }
    }
    /// The configuration.
    pub const fn config(&self) -> &ArmConfig {
        &self.0
    }
    /// A configuration that skips [`check`], for analyses that shrink the
    /// robot to make a state space tractable (the model check, the proofs).
    /// Only with the `relaxed-config` feature, which the firmware and the
    /// simulator never enable; each user states what it relaxes and why.
    #[cfg(feature = "relaxed-config")]
    pub const fn relaxed(c: ArmConfig) -> Self {
        Validated(c)
    }
}

/// Upper bound of segment lengths, in ticks.
pub const MAX_SEGMENT_TICKS: u32 = 256;
/// The set-points accelerate at this fraction of the output's limit
/// (`JointConfig::setpoint_acceleration`).
pub const SETPOINT_ACCEL_FRACTION: f32 = 0.8;
/// Output speed (rad/s) at or below which a joint whose set-point is at rest
/// counts as holding, not moving (the command timeout holds instead of
/// latching; a link loss or `<HOME>` needs no stop). A joint holding its
/// set-point corrects a count or two of error at Kp: a few mrad/s.
pub const HOLD_SPEED: f32 = 0.01;

const fn joint(
    gear_ratio: f32,
    microsteps: u32,
    max_velocity: f32,
    kp: f32,
    limits: (f32, f32),
    homing: HomingConfig,
) -> JointConfig {
    JointConfig {
        gear_ratio,
        full_steps_per_rev: 200,
        microsteps,
        max_velocity,
        runaway_velocity: max_velocity * 1.25,
        kp,
        // Full speed in 100 ms: the same rate as the soft-stop ramp.
        max_acceleration: max_velocity * 10.0,
        limit_min: limits.0,
        limit_max: limits.1,
        encoder_reversed: false,
        motor_reversed: false,
        homing,
    }
}

const fn homing(
    direction: Direction,
    fast_speed: f32,
    switch_position: f32,
    timeout_ms: u32,
    limits: (f32, f32),
) -> HomingConfig {
    // The fast seek may cross the whole range, reach the switch beyond the
    // limit, and brake: 0.1 rad more than that.
    let beyond = if switch_position > limits.1 { switch_position - limits.1 } else { limits.0 - switch_position };
    let max_travel = limits.1 - limits.0 + beyond + 0.1;
    HomingConfig { direction, fast_speed, slow_speed: 0.05, backoff: 0.05, switch_position, timeout_ms, max_travel }
}

/// The PAROL6 as in `docs/spec/robot.md` section 1. Homing directions,
/// switch angles and speeds are not in it: the values here put each switch 0.02 rad
/// beyond the URDF limit in the seek direction and must be confirmed on the
/// robot before first use.
#[allow(clippy::approx_constant)] // J6's limits are the URDF's literal 6.283, not TAU
pub const PAROL6: ArmConfig = ArmConfig {
    tick_hz: 1000,
    joints: [
        joint(6.4, 32, 3.0, 5.0, (-1.7, 1.7), homing(Direction::Negative, 0.5, -1.72, 12_000, (-1.7, 1.7))),
        joint(20.0, 32, 3.0, 5.0, (-0.802, 1.0), homing(Direction::Negative, 0.3, -0.822, 12_000, (-0.802, 1.0))),
        joint(18.0952, 32, 6.0, 2.0, (-2.0, 1.29), homing(Direction::Positive, 0.5, 1.31, 12_000, (-2.0, 1.29))),
        joint(4.0, 32, 6.0, 2.0, (-2.529, 1.849), homing(Direction::Negative, 1.0, -2.549, 10_000, (-2.529, 1.849))),
        joint(4.0, 32, 6.0, 2.0, (-2.1, 2.1), homing(Direction::Negative, 1.0, -2.12, 10_000, (-2.1, 2.1))),
        joint(10.0, 16, 6.0, 2.0, (-6.283, 6.283), homing(Direction::Positive, 2.0, 6.303, 12_000, (-6.283, 6.283))),
    ],
    // alpha 0.1 and beta 0.005 at 1 kHz (docs/spec/robot.md section 1), per second.
    observer_position_gain: 100.0,
    observer_velocity_gain: 5000.0,
    deadband: 0.0,
    command_timeout_ms: 100,
    soft_stop_ms: 100,
    stop_budget_ms: 200,
    max_step_rate: 120_000,
    segment_min_ms: 8,
    segment_max_ms: 40,
    boot_timeout_ms: 50,
    homing_budget_ms: 85_000,
    // A soft stop mid-motion can carry a joint up to a T^2/8 = 75 mrad
    // (J3..J6) past its last target, plus the following error (50 mrad):
    // `check` requires the margin to cover both.
    position_margin: 0.15,
    encoder_invalid_limit: 2,
    following_error: 0.05,
    following_error_ms: 20,
    homing_settle_ms: 50,
    target_jump_tolerance: 0.02,
};

const _: () = assert_valid(&PAROL6);
/// [`PAROL6`], checked: what the firmware and the simulator run.
pub const PAROL6_VALIDATED: Validated = Validated::assert(PAROL6);
static_assertions::const_assert!(HOMING_GROUPS[0] & HOMING_GROUPS[1] == 0);
static_assertions::const_assert!(HOMING_GROUPS[1] & HOMING_GROUPS[2] == 0);
static_assertions::const_assert!(HOMING_GROUPS[0] & HOMING_GROUPS[2] == 0);
static_assertions::const_assert!(HOMING_GROUPS[0] | HOMING_GROUPS[1] | HOMING_GROUPS[2] == 0b11_1111);

/// Converts milliseconds to ticks, rounding up.
pub const fn ms_to_ticks(ms: u32, tick_hz: u32) -> u32 {
    let t = ms as u64 * tick_hz as u64;
    let q = t / 1000;
    let q = if q * 1000 < t { q + 1 } else { q };
    if q > u32::MAX as u64 {
        u32::MAX
    } else {
        q as u32
    }
}

const fn finite(x: f32) -> bool {
    x.is_finite()
}

/// Checks a configuration; `Err` names the first inconsistency.
pub const fn check(c: &ArmConfig) -> Result<(), &'static str> {
    if c.tick_hz < 100 || c.tick_hz > 10_000 {
        return Err("tick_hz must be within 100..=10000");
    }
    let dt = 1.0 / c.tick_hz as f32;
    let (alpha, beta) = (c.alpha(), c.beta());
    if !(finite(alpha) && alpha > 0.0 && alpha < 1.0) {
        return Err("observer alpha (position gain / tick_hz) must be in (0, 1)");
    }
    // Jury stability of the alpha-beta filter is 0 < beta < 4 - 2 alpha; we
    // also require no oscillatory response: beta <= alpha^2 / (2 - alpha)
    // (critically damped or slower), which alpha 0.1 / beta 0.005 meet.
    if !(finite(beta) && beta > 0.0 && beta <= alpha * alpha / (2.0 - alpha) * 1.001) {
        return Err("observer beta must be in (0, alpha^2/(2-alpha)] (stable, not oscillatory)");
    }
    if !(finite(c.deadband) && c.deadband >= 0.0) {
        return Err("deadband must be >= 0");
    }
    if c.command_timeout_ms == 0 || c.soft_stop_ms == 0 {
        return Err("command timeout and soft-stop ramp must be > 0");
    }
    if c.command_timeout_ms as u64 + c.soft_stop_ms as u64 > c.stop_budget_ms as u64 {
        return Err("command timeout + soft-stop ramp exceed the stop budget");
    }
    if ms_to_ticks(c.soft_stop_ms, c.tick_hz) > 100_000 {
        return Err("soft-stop ramp too long");
    }
    let smin = ms_to_ticks(c.segment_min_ms, c.tick_hz);
    let smax = ms_to_ticks(c.segment_max_ms, c.tick_hz);
    if smin < 1 || smin > smax || smax > MAX_SEGMENT_TICKS {
        return Err("segment lengths must satisfy 1 <= min <= max <= MAX_SEGMENT_TICKS ticks");
    }
    if c.segment_max_ms >= c.command_timeout_ms {
        return Err("the longest segment must be shorter than the command timeout");
    }
    if ms_to_ticks(c.boot_timeout_ms, c.tick_hz) < 2 {
        return Err("boot timeout must allow at least two ticks");
    }
    if c.encoder_invalid_limit > 10 {
        return Err("encoder_invalid_limit above 10 samples: coasting that long is not safe");
    }
    if !(finite(c.position_margin) && c.position_margin >= 0.0 && c.position_margin < 1.0) {
        return Err("position margin must be in [0, 1) rad");
    }
    if !(finite(c.following_error) && c.following_error > 0.0 && c.following_error < c.position_margin) {
        return Err("following error must be in (0, position_margin)");
    }
    let fe_ticks = ms_to_ticks(c.following_error_ms, c.tick_hz);
    if fe_ticks < 2 || c.following_error_ms > 200 {
        return Err("following error time must be at least two ticks and at most 200 ms");
    }
    if c.homing_settle_ms > 1000 {
        return Err("homing settle time above 1 s");
    }
    if !(finite(c.target_jump_tolerance) && c.target_jump_tolerance >= 0.0 && c.target_jump_tolerance <= 0.1) {
        return Err("target jump tolerance must be in [0, 0.1] rad");
    }
    let mut i = 0;
    while i < AXES {
        let j = &c.joints[i];
        if let Err(e) = check_joint(j, c, dt) {
            return Err(e);
        }
        i += 1;
    }
    // Homing budget: groups run one after the other; a group lasts as long as
    // its slowest joint's timeout.
    let mut total: u64 = 0;
    let mut g = 0;
    while g < HOMING_GROUPS.len() {
        let mut worst: u32 = 0;
        let mut i = 0;
        while i < AXES {
            if HOMING_GROUPS[g] & (1 << i) != 0 && c.joints[i].homing.timeout_ms > worst {
                worst = c.joints[i].homing.timeout_ms;
            }
            i += 1;
        }
        total += worst as u64;
        g += 1;
    }
    // The run rests for the settle time before it moves.
    let total = total + c.homing_settle_ms as u64;
    if total > c.homing_budget_ms as u64 {
        return Err("homing can take longer than the driver waits (sum of group timeouts > homing_budget_ms)");
    }
    if c.homing_budget_ms > 90_000 {
        return Err("homing budget above the ROS 2 driver's 90 s wait");
    }
    Ok(())
}

const fn check_joint(j: &JointConfig, c: &ArmConfig, dt: f32) -> Result<(), &'static str> {
    if !(finite(j.gear_ratio) && j.gear_ratio > 0.0 && j.gear_ratio < 1000.0) {
        return Err("gear ratio must be in (0, 1000)");
    }
    if j.full_steps_per_rev == 0 || !j.microsteps.is_power_of_two() || j.microsteps > 256 {
        return Err("microsteps must be a power of two <= 256, full steps > 0");
    }
    if !(finite(j.max_velocity) && j.max_velocity > 0.0 && j.max_velocity <= 16.0) {
        return Err("max velocity must be in (0, 16] rad/s");
    }
    if j.steps_per_rad() >= 32_000.0 {
        return Err("steps per rad must stay below 32000 (fixed-point step-rate scale)");
    }
    if j.max_velocity as f64 * j.steps_per_rad() > c.max_step_rate as f64 {
        return Err("max velocity not reachable within the step-rate limit");
    }
    if !(finite(j.runaway_velocity) && j.runaway_velocity >= j.max_velocity * 1.1) {
        return Err("runaway threshold must be at least 10 % above the command clamp");
    }
    if j.runaway_velocity > 32.0 {
        return Err("runaway threshold absurdly high");
    }
    // After coasting over invalid samples the window is multiplied by their
    // count plus one (`Axis::sense_and_estimate`).
    if j.max_jump_counts(c.tick_hz) * (c.encoder_invalid_limit as i32 + 1) >= COUNTS_PER_REV / 4 {
        return Err("encoder plausibility window too wide to unwrap unambiguously");
    }
    if !(finite(j.max_acceleration) && j.max_acceleration > 0.0 && j.max_acceleration <= 200.0) {
        return Err("max acceleration must be in (0, 200] rad/s^2");
    }
    // The soft stop's linear ramp must decelerate no faster than the joint
    // may: from the clamp to zero within the ramp at most `max_acceleration`.
    if j.max_velocity * 1000.0 > j.max_acceleration * c.soft_stop_ms as f32 * 1.0001 {
        return Err("soft-stop ramp decelerates faster than max_acceleration");
    }
    // How far a joint can go past its last validated target (a soft stop
    // from the worst speed, plus the following error) must fit inside the
    // position margin, so a position fault means something is wrong.
    if c.overrun_bound(j) >= c.position_margin {
        return Err("stopping overrun (a T^2 / 8 + following error) exceeds position_margin");
    }
    if !(finite(j.kp) && j.kp > 0.0 && j.kp * dt <= 0.5) {
        return Err("Kp must be > 0 and Kp * dt <= 0.5 (discrete loop stable, not oscillatory)");
    }
    if !(finite(j.limit_min) && finite(j.limit_max) && j.limit_min < j.limit_max) {
        return Err("joint limits must be finite and ordered");
    }
    if j.limit_min < -POSITION_ABS_MAX + 2.0 || j.limit_max > POSITION_ABS_MAX - 2.0 {
        return Err("joint limits beyond the plausible range");
    }
    if c.deadband >= j.max_velocity {
        return Err("deadband at or above a joint's max velocity");
    }
    let h = &j.homing;
    if !(finite(h.fast_speed) && finite(h.slow_speed) && h.slow_speed > 0.0 && h.slow_speed <= h.fast_speed) {
        return Err("homing speeds must satisfy 0 < slow <= fast");
    }
    if h.fast_speed > j.max_velocity {
        return Err("homing fast speed above the joint's max velocity");
    }
    // The fast seek may cross the whole range and reach the switch; it must
    // not be allowed much farther (the hard stop is near).
    let beyond = if h.switch_position > j.limit_max {
        h.switch_position - j.limit_max
    } else if h.switch_position < j.limit_min {
        j.limit_min - h.switch_position
    } else {
        0.0
    };
    let need = j.limit_max - j.limit_min + beyond;
    if !(finite(h.max_travel) && h.max_travel >= need && h.max_travel <= need + 0.25) {
        return Err("homing max_travel must be within [range + switch distance, + 0.25 rad]");
    }
    if !(finite(h.backoff) && h.backoff > 0.0 && h.backoff < 0.5) {
        return Err("homing back-off must be in (0, 0.5) rad");
    }
    if !(finite(h.switch_position)
        && h.switch_position >= j.limit_min - c.position_margin
        && h.switch_position <= j.limit_max + c.position_margin)
    {
        return Err("homing switch position outside limits + margin");
    }
    let landing = h.switch_position - h.direction.sign() * (h.backoff + j.braking_distance(h.fast_speed));
    if landing < j.limit_min || landing > j.limit_max {
        return Err("homing release does not end inside the joint limits");
    }
    if (h.timeout_ms as f32) < j.homing_nominal_ms(c.homing_settle_ms) * 1.2 {
        return Err("homing timeout shorter than 1.2x the nominal homing time: homing is impossible");
    }
    Ok(())
}

/// Fails the build (when used in a constant) if `c` is inconsistent.
pub const fn assert_valid(c: &ArmConfig) {
    if let Err(msg) = check(c) {
        panic!("{}", msg);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parol6_is_valid_and_derived_values_match_robot_md() {
        assert_eq!(check(&PAROL6), Ok(()));
        let spr: [f64; 6] = [6518.99, 20371.83, 18431.62, 4074.37, 4074.37, 5092.96];
        for (j, want) in PAROL6.joints.iter().zip(spr) {
            assert!((j.steps_per_rad() - want).abs() < 0.01, "{} vs {want}", j.steps_per_rad());
        }
        assert!(PAROL6.joints.iter().all(|j| j.max_jump_counts(1000) < 400));
        for j in PAROL6.joints {
            assert!(PAROL6.overrun_bound(&j) < PAROL6.position_margin);
        }
    }

    fn with(f: impl Fn(&mut ArmConfig)) -> Result<(), &'static str> {
        let mut c = PAROL6;
        f(&mut c);
        check(&c)
    }

    #[test]
    fn each_inconsistency_is_rejected() {
        // C++ defect: 20 kHz step cap made J2/J3 unable to reach max velocity.
        assert!(with(|c| c.max_step_rate = 20_000).is_err());
        // C++ defect 7: runaway threshold equal to the clamp.
        assert!(with(|c| c.joints[1].runaway_velocity = c.joints[1].max_velocity).is_err());
        assert!(with(|c| c.joints[2].limit_min = 2.0).is_err());
        assert!(with(|c| c.joints[5].homing.timeout_ms = 80_000).is_err());
        assert!(with(|c| c.joints[1].microsteps = 64).is_err());
        assert!(with(|c| c.joints[0].homing.timeout_ms = 1_000).is_err());
        assert!(with(|c| c.joints[0].kp = 1000.0).is_err());
        assert!(with(|c| c.observer_velocity_gain = 500_000.0).is_err());
        assert!(with(|c| c.observer_position_gain = f32::NAN).is_err());
        assert!(with(|c| c.following_error = 0.2).is_err());
        assert!(with(|c| c.joints[2].homing.max_travel = 10.0).is_err());
        assert!(with(|c| c.joints[2].homing.max_travel = 1.0).is_err());
        assert!(with(|c| c.soft_stop_ms = 50).is_err()); // ramp faster than max_acceleration
        assert!(with(|c| c.joints[5].max_acceleration = 150.0).is_err()); // overrun past the margin
        assert!(with(|c| c.command_timeout_ms = 150).is_err());
        assert!(with(|c| c.segment_max_ms = 100).is_err());
        assert!(with(|c| c.joints[3].homing.fast_speed = 7.0).is_err());
        assert!(with(|c| c.joints[3].homing.switch_position = -3.0).is_err());
        assert!(with(|c| c.encoder_invalid_limit = 11).is_err());
        assert!(with(|c| c.encoder_invalid_limit = 4).is_err()); // J3's window x5 exceeds 1024 counts
        assert!(with(|c| c.joints[4].max_acceleration = 0.0).is_err());
    }

    #[test]
    fn ms_to_ticks_rounds_up() {
        assert_eq!(ms_to_ticks(100, 1000), 100);
        assert_eq!(ms_to_ticks(100, 500), 50);
        assert_eq!(ms_to_ticks(1, 333), 1);
        assert_eq!(ms_to_ticks(u32::MAX, 10_000), u32::MAX);
    }
}
