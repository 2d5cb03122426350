//! The tick: sense -> estimate -> supervise -> act, for all six axes.

use crate::config::{
    ms_to_ticks, ArmConfig, JointConfig, AXES, COUNTS_PER_REV, HOMING_GROUPS, MAX_SEGMENT_TICKS, POSITION_ABS_MAX,
};
use crate::control::control_law;
use crate::homing::{AxisHoming, HomingParams, Phase};
use crate::interp::Interpolator;
use crate::observer::{AlphaBeta, ObserverGains, Unwrapper};
use crate::scalar::Scalar;
use crate::types::*;

/// Bit of axis `i` (0..=5) in a joint mask.
#[inline(always)]
pub(crate) const fn bit(i: usize) -> u8 {
    1u8.wrapping_shl(i as u32)
}

const ALL: u8 = 0b11_1111;

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
    pub fn new(config: &ArmConfig) -> Self {
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
    pub max_step: S,
    pub runaway: S,
    pub kp: S,
    /// Largest velocity change per tick in Operational.
    pub accel_step: S,
    pub pos_lo: S,
    pub pos_hi: S,
    pub k_count: S::Wide,
    pub k_rate: S::Wide,
    pub enc_sign: i32,
    pub max_jump: i32,
    pub switch_position: S,
    pub homing: HomingParams<S>,
}

impl<S: Scalar> AxisParams<S> {
    fn new(j: &JointConfig, c: &ArmConfig) -> Self {
        let dir = j.homing.direction.sign();
        let motor = if j.motor_reversed { -1.0 } else { 1.0 };
        AxisParams {
            vmax: S::from_f32(j.max_velocity),
            max_step: S::from_f32(j.max_velocity / c.tick_hz as f32),
            runaway: S::from_f32(j.runaway_velocity),
            kp: S::from_f32(j.kp),
            accel_step: S::from_f32(j.max_acceleration / c.tick_hz as f32),
            pos_lo: S::from_f32(j.limit_min - c.position_margin),
            pos_hi: S::from_f32(j.limit_max + c.position_margin),
            k_count: S::wide_from_f64(j.rad_per_count()),
            k_rate: S::wide_from_f64(j.steps_per_rad() * motor),
            enc_sign: if j.encoder_reversed { -1 } else { 1 },
            max_jump: j.max_jump_counts(c.tick_hz),
            switch_position: S::from_f32(j.homing.switch_position),
            homing: HomingParams {
                fast_toward: S::from_f32(j.homing.fast_speed * dir),
                slow_toward: S::from_f32(j.homing.slow_speed * dir),
                backoff: S::from_f32(j.homing.backoff),
                timeout_ticks: ms_to_ticks(j.homing.timeout_ms, c.tick_hz),
            },
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
    /// `recip[n] = 1/n` (index 0 unused).
    pub recip: [S; MAX_SEGMENT_TICKS as usize + 1],
    pub boot_ticks: u32,
    pub invalid_limit: u32,
    pub pos_abs: S,
    pub vel_abs: S,
}

impl<S: Scalar> Params<S> {
    fn new(c: &ArmConfig) -> Self {
        let stop_ticks = ms_to_ticks(c.soft_stop_ms, c.tick_hz).max(1);
        Params {
            axes: c.joints.map(|j| AxisParams::new(&j, c)),
            limits: TargetLimits::new(c),
            gains: ObserverGains {
                alpha: S::from_f32(c.alpha),
                beta_hz: S::from_f32(c.beta * c.tick_hz as f32),
                dt: S::from_f32(1.0 / c.tick_hz as f32),
            },
            tick_hz: i32::try_from(c.tick_hz).unwrap_or(1000),
            deadband: S::from_f32(c.deadband),
            timeout_ticks: ms_to_ticks(c.command_timeout_ms, c.tick_hz),
            stop_ticks,
            inv_stop: S::from_f32(1.0 / stop_ticks as f32),
            seg_min: ms_to_ticks(c.segment_min_ms, c.tick_hz).max(1),
            seg_max: ms_to_ticks(c.segment_max_ms, c.tick_hz).max(1).min(MAX_SEGMENT_TICKS),
            recip: core::array::from_fn(|n| if n == 0 { S::ZERO } else { S::from_f32(1.0 / n as f32) }),
            boot_ticks: ms_to_ticks(c.boot_timeout_ms, c.tick_hz),
            invalid_limit: c.encoder_invalid_limit,
            pos_abs: S::from_f32(POSITION_ABS_MAX),
            vel_abs: S::from_f32(VELOCITY_ABS_MAX),
        }
    }
}

/// Per-axis state.
#[derive(Clone, Copy, Debug, PartialEq, Hash)]
pub(crate) struct Axis<S: Scalar> {
    pub ready: bool,
    pub unwrap: Unwrapper,
    pub obs: AlphaBeta<S>,
    pub interp: Interpolator<S>,
    pub zero: S,
    pub homing: AxisHoming<S>,
    /// The unwrapped count can no longer be trusted (encoder fault).
    pub needs_reinit: bool,
    /// Consecutive invalid or implausible samples (the observer coasts).
    pub invalid: u32,
}

impl<S: Scalar> Axis<S> {
    fn new() -> Self {
        Axis {
            ready: false,
            unwrap: Unwrapper::new(0),
            obs: AlphaBeta::at(S::ZERO),
            interp: Interpolator::hold(S::ZERO),
            zero: S::ZERO,
            homing: AxisHoming::default(),
            needs_reinit: false,
            invalid: 0,
        }
    }
    /// The measured joint angle from the unwrapped count.
    fn measured(&self, p: &AxisParams<S>) -> S {
        S::from_counts(self.unwrap.total().saturating_mul(p.enc_sign), p.k_count).plus(self.zero)
    }
    /// (Re)starts from a real reading: observer at rest on it.
    fn init_from(&mut self, count: u16, p: &AxisParams<S>) {
        self.unwrap = Unwrapper::new(count);
        self.ready = true;
        self.needs_reinit = false;
        self.invalid = 0;
        self.obs = AlphaBeta::at(self.measured(p));
        self.interp = Interpolator::hold(self.obs.x);
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Hash)]
enum Mode<S> {
    Boot,
    Unhomed,
    Homing,
    Operational,
    Stopping { k: u32, v0: [S; AXES] },
    SoftEstop,
    Fault,
}

/// The safety kernel for one arm, generic over the scalar type.
#[derive(Clone, Debug)]
pub struct Kernel<S: Scalar> {
    /// Identity: only capabilities minted by this kernel's [`Authority`]
    /// are accepted. Not part of the state (`Hash` ignores it).
    id: KernelId,
    p: Params<S>,
    axes: [Axis<S>; AXES],
    mode: Mode<S>,
    fault: Option<Fault>,
    homing_status: HomingStatus,
    /// Joints of the current homing run, and the group being homed.
    run_mask: u8,
    run_group: usize,
    /// `<HOME>` received while booting, started when boot completes.
    home_queued: bool,
    homed: u8,
    tick: u32,
    boot_ticks: u32,
    since_cmd: u32,
    armed: bool,
    /// Ticks since the last accepted target (saturates at `seg_max`), or
    /// `None` after a resync.
    since_target: Option<u32>,
    /// Recent target intervals, each already bounded to `seg_min..=seg_max`.
    intervals: [u32; 4],
    /// Outputs applied last tick (the soft stop ramps down from these).
    last_out: [S; AXES],
}

/// Median of four values (mean of the middle two), with a fixed network of
/// comparisons: bounded, branch-light, no indexing.
fn median4(v: [u32; 4]) -> u32 {
    let [a, b, c, d] = v;
    let (a, b) = (a.min(b), a.max(b));
    let (c, d) = (c.min(d), c.max(d));
    let lo2 = a.max(c); // second smallest is max of the two minima or ...
    let hi2 = b.min(d); // ... together with the min of the two maxima
    let (m1, m2) = (lo2.min(hi2), lo2.max(hi2));
    m1.midpoint(m2)
}

impl<S: Scalar> Kernel<S> {
    /// A kernel in [`State::Boot`], and the one [`Authority`] that can mint
    /// enable capabilities for it. The configuration must be valid (check it
    /// at compile time with [`crate::config::assert_valid`]).
    ///
    /// Each call draws a fresh identity: the [`Authority`] of one kernel
    /// mints capabilities that every other kernel refuses
    /// ([`Reject::ForeignCapability`]).
    pub fn new(config: &ArmConfig) -> (Self, Authority) {
        let id = KernelId::fresh();
        let k = Kernel {
            id,
            p: Params::new(config),
            axes: [Axis::new(); AXES],
            mode: Mode::Boot,
            fault: None,
            homing_status: HomingStatus::NotRequested,
            run_mask: 0,
            run_group: 0,
            home_queued: false,
            homed: 0,
            tick: 0,
            boot_ticks: 0,
            since_cmd: 0,
            armed: false,
            since_target: None,
            intervals: [0; 4],
            last_out: [S::ZERO; AXES],
        };
        (k, Authority::new(id))
    }

    /// A copy of this kernel in the same state but with a fresh identity,
    /// and the one [`Authority`] for the copy (restoring a snapshot in
    /// tests). The copy refuses this kernel's capabilities and this kernel
    /// refuses the copy's: holding `&self` gives no power over `self`. A
    /// plain `clone` keeps the identity (the same kernel, as a model
    /// checker's states are) and comes with no authority.
    pub fn fork(&self) -> (Self, Authority) {
        let id = KernelId::fresh();
        (Kernel { id, ..self.clone() }, Authority::new(id))
    }

    /// Current supervisor state.
    pub fn state(&self) -> State {
        match self.mode {
            Mode::Boot => State::Boot,
            Mode::Unhomed => State::Unhomed,
            Mode::Homing => State::Homing,
            Mode::Operational => State::Operational,
            Mode::Stopping { .. } => State::Stopping,
            Mode::SoftEstop => State::SoftEstop,
            Mode::Fault => State::Fault,
        }
    }

    /// The latched fault, if any.
    pub fn fault(&self) -> Option<Fault> {
        self.fault
    }

    /// The outputs returned by the last tick.
    pub fn last_output(&self) -> [S; AXES] {
        self.last_out
    }

    /// Homing status (`H0`..`H3`).
    pub fn homing_status(&self) -> HomingStatus {
        self.homing_status
    }

    /// Homing phase of each axis (for tests, proofs and reports).
    pub fn homing_phases(&self) -> [Phase; AXES] {
        self.axes.map(|a| a.homing.phase())
    }

    /// Joints homed (bit per joint).
    pub fn homed(&self) -> u8 {
        self.homed
    }

    /// Joints that must be homed before joint `j` (index) may move.
    pub fn dependencies(j: usize) -> u8 {
        let mut needs = 0;
        for g in HOMING_GROUPS {
            if g & bit(j) != 0 {
                return needs;
            }
            needs |= g;
        }
        needs
    }

    /// One control tick: sense, estimate, handle at most one request,
    /// supervise, and return the checked outputs for every axis.
    pub fn tick(&mut self, sense: &Sense, request: Option<Request<S>>) -> TickOutput<S> {
        self.tick = self.tick.wrapping_add(1);
        let cap = self.p.seg_max;
        self.since_target = self.since_target.map(|t| t.saturating_add(1).min(cap));
        let mut events = Events::new();
        let mut fault: Option<FaultReason> = sense.hardware_fault.map(FaultReason::Hardware);
        let limits = sense.limits & ALL;

        // 1-2. Sense and estimate.
        self.sense_and_estimate(sense, &mut fault);
        if self.mode == Mode::Boot {
            if self.axes.iter().all(|a| a.ready) {
                self.mode = Mode::Unhomed;
                events.push(Event::Ready);
                if self.home_queued {
                    self.home_queued = false;
                    if self.start_homing(ALL).is_ok() {
                        events.push(Event::HomingStarted { mask: ALL });
                    }
                }
            } else {
                self.boot_ticks = self.boot_ticks.saturating_add(1);
                if self.boot_ticks > self.p.boot_ticks {
                    let axis = self.axes.iter().position(|a| !a.ready).unwrap_or(0);
                    fault.get_or_insert(FaultReason::EncoderNotReady { axis: axis as u8 });
                }
            }
        }

        // Requests are handled after estimation, so they see this tick's
        // measurements, and before supervision, so their effect is checked.
        if let Some(r) = request {
            let kind = r.kind();
            if let Err(reason) = self.handle(r, sense, fault) {
                events.push(Event::Rejected { request: kind, reason });
            } else if let Some(e) = self.request_event(kind) {
                events.push(e);
            }
        }

        // 3. Supervise: candidate outputs for every axis.
        let mut out = [S::ZERO; AXES];
        let mut homing_event = None;
        match self.mode {
            Mode::Operational => {
                if self.armed {
                    self.since_cmd = self.since_cmd.saturating_add(1);
                }
                if self.armed && self.since_cmd > self.p.timeout_ticks {
                    self.mode = Mode::Stopping { k: 0, v0: self.last_out };
                    let ms =
                        self.since_cmd.saturating_mul(1000).checked_div(self.p.tick_hz.unsigned_abs()).unwrap_or(0);
                    events.push(Event::SoftEstop { since_command_ms: ms });
                } else {
                    self.follow(&mut out, &mut fault);
                }
            }
            Mode::Homing => homing_event = self.home_step(limits, &mut out, &mut fault),
            _ => {}
        }
        if let Mode::Stopping { k, v0 } = self.mode {
            let k = k.saturating_add(1);
            self.ramp(k, &v0, &mut out);
            if k >= self.p.stop_ticks {
                self.mode = Mode::SoftEstop;
                events.push(Event::Stopped);
            } else {
                self.mode = Mode::Stopping { k, v0 };
            }
        }
        if let Some(e) = homing_event {
            events.push(e);
        }
        self.check(limits, &out, &mut fault);

        // Latch the first fault; every output is zero in the same tick.
        if let Some(reason) = fault {
            if self.mode != Mode::Fault {
                self.enter_fault(reason);
                events.push(Event::Fault(reason));
            }
        }
        if self.mode == Mode::Fault {
            out = [S::ZERO; AXES];
        }

        // 4. Act: every output was computed and checked above.
        self.last_out = out;
        let mut step_rate = [0i32; AXES];
        for ((r, v), p) in step_rate.iter_mut().zip(out.iter()).zip(self.p.axes.iter()) {
            *r = v.to_rate(p.k_rate);
        }
        TickOutput { act: Actuation { velocity: out, step_rate }, status: self.status(limits), events }
    }

    fn status(&self, limits: u8) -> Status<S> {
        Status {
            state: self.state(),
            homing: self.homing_status,
            fault: self.fault,
            position: self.axes.map(|a| a.obs.x),
            velocity: self.axes.map(|a| a.obs.v),
            setpoint: self.axes.map(|a| a.interp.setpoint()),
            limits,
            homed: self.homed,
            timeout_armed: self.armed,
            tick: self.tick,
        }
    }

    fn sense_and_estimate(&mut self, sense: &Sense, fault: &mut Option<FaultReason>) {
        let gains = self.p.gains;
        let (pos_abs, vel_abs) = (self.p.pos_abs, self.p.vel_abs);
        let invalid_limit = self.p.invalid_limit;
        for (i, ((ax, p), sample)) in
            self.axes.iter_mut().zip(self.p.axes.iter()).zip(sense.encoders.iter()).enumerate()
        {
            let axis = i as u8;
            let count = match *sample {
                EncoderSample::Count(c) if i32::from(c) < COUNTS_PER_REV => Some(c),
                _ => None,
            };
            if !ax.ready {
                // Boot (or after a boot timeout): start from the first real reading.
                if let Some(c) = count {
                    ax.init_from(c, p);
                }
            } else if ax.needs_reinit {
                // Count lost under a latched fault; enable re-initialises it.
            } else {
                // A lost or implausible sample is skipped and the observer
                // coasts; more than `invalid_limit` in a row is a fault. The
                // plausibility window grows with the samples skipped.
                let window = p.max_jump.unsigned_abs().saturating_mul(ax.invalid.saturating_add(1));
                let delta = count.map(|c| (c, ax.unwrap.delta(c)));
                match delta {
                    Some((c, d)) if d.unsigned_abs() <= window => {
                        ax.invalid = 0;
                        ax.unwrap.update(c);
                        let z = ax.measured(p);
                        ax.obs.step(z, &gains);
                    }
                    _ => {
                        ax.invalid = ax.invalid.saturating_add(1);
                        ax.obs.coast(&gains);
                        if ax.invalid > invalid_limit {
                            let reason = match delta {
                                Some((_, d)) => FaultReason::EncoderJump { axis, delta: d },
                                None => FaultReason::EncoderLost { axis },
                            };
                            fault.get_or_insert(reason);
                            ax.needs_reinit = true;
                        }
                    }
                }
            }
            let x = ax.obs.x;
            let v = ax.obs.v;
            let plausible = x.is_finite() && v.is_finite() && x.abs() < pos_abs && v.abs() < vel_abs;
            if ax.ready && !plausible {
                fault.get_or_insert(FaultReason::Numeric { axis });
            }
        }
    }

    /// Operational: interpolate, control law, saturate.
    fn follow(&mut self, out: &mut [S; AXES], fault: &mut Option<FaultReason>) {
        let hz = self.p.tick_hz;
        let db = self.p.deadband;
        let axes = self.axes.iter_mut().zip(self.p.axes.iter()).zip(out.iter_mut()).zip(self.last_out.iter());
        for (i, (((ax, p), o), prev)) in axes.enumerate() {
            let (sp, moved) = ax.interp.advance();
            let ff = moved.times_int(hz);
            let (v, ok) = control_law(sp, ff, ax.obs.x, p.kp, p.vmax, db);
            if !ok {
                fault.get_or_insert(FaultReason::Numeric { axis: i as u8 });
            }
            // Acceleration limit: within one tick's change of the last
            // output (which is within +-vmax, so the result is too).
            *o = v.clamp_between(prev.minus(p.accel_step), prev.plus(p.accel_step));
        }
    }

    /// Soft E-stop ramp: `v0 * (N - k) / N`, never above the previous output
    /// in magnitude, exactly zero from `k = N` on.
    fn ramp(&self, k: u32, v0: &[S; AXES], out: &mut [S; AXES]) {
        let n = self.p.stop_ticks;
        let left = i32::try_from(n.saturating_sub(k)).unwrap_or(0);
        let scale = self.p.inv_stop.times_int(left).min(S::ONE).max(S::ZERO);
        for ((o, v), prev) in out.iter_mut().zip(v0.iter()).zip(self.last_out.iter()) {
            let r = v.times(scale).clamp_between(S::ZERO, *prev);
            let r = S::select(r.is_finite(), r, S::ZERO);
            *o = S::select(k >= n, S::ZERO, r);
        }
    }

    /// Homing: sequence the groups, step the active axes.
    fn home_step(&mut self, limits: u8, out: &mut [S; AXES], fault: &mut Option<FaultReason>) -> Option<Event> {
        // Advance past finished groups (at most three).
        for _ in 0..HOMING_GROUPS.len() {
            let group = HOMING_GROUPS.get(self.run_group).copied().unwrap_or(0) & self.run_mask;
            let done =
                self.axes.iter().enumerate().all(|(i, a)| group & bit(i) == 0 || a.homing.phase() == Phase::Done);
            if done && self.run_group < HOMING_GROUPS.len() {
                self.run_group = self.run_group.saturating_add(1);
            } else {
                break;
            }
        }
        let Some(group) = HOMING_GROUPS.get(self.run_group).map(|g| g & self.run_mask) else {
            return Some(self.finish_homing());
        };
        for (i, ((ax, p), o)) in self.axes.iter_mut().zip(self.p.axes.iter()).zip(out.iter_mut()).enumerate() {
            if group & bit(i) == 0 {
                continue;
            }
            ax.homing.start();
            let s = ax.homing.step(limits & bit(i) != 0, ax.obs.x, &p.homing);
            if let Some(phase) = s.timed_out {
                fault.get_or_insert(FaultReason::HomingTimeout { axis: i as u8, phase });
            }
            if s.capture_zero {
                // Zero from the real reading plus the configured offset; the
                // estimate moves with it, so the residual is unchanged.
                let raw = S::from_counts(ax.unwrap.total().saturating_mul(p.enc_sign), p.k_count);
                let zero = p.switch_position.minus(raw);
                ax.obs.shift(zero.minus(ax.zero));
                ax.zero = zero;
                self.homed |= bit(i);
            }
            *o = s.velocity;
        }
        None
    }

    fn finish_homing(&mut self) -> Event {
        let mask = self.run_mask;
        for ax in self.axes.iter_mut() {
            ax.homing.reset(false);
        }
        self.resync();
        if self.homed == ALL {
            self.mode = Mode::Operational;
            self.homing_status = HomingStatus::Complete;
        } else {
            self.mode = Mode::Unhomed;
            self.homing_status = HomingStatus::NotRequested;
        }
        self.run_mask = 0;
        Event::HomingDone { mask }
    }

    /// Set-points to the measured positions, timeout disarmed, no history.
    /// Also called on entering Homing and Fault, where nothing reads them, so
    /// no stale set-point or interval survives a mode change.
    fn resync(&mut self) {
        for ax in self.axes.iter_mut() {
            ax.interp = Interpolator::hold(ax.obs.x);
        }
        self.armed = false;
        self.since_cmd = 0;
        self.since_target = None;
    }

    /// Checks that apply in every state, and the outputs themselves.
    fn check(&self, limits: u8, out: &[S; AXES], fault: &mut Option<FaultReason>) {
        let limit_is_fault = matches!(self.mode, Mode::Operational | Mode::Stopping { .. } | Mode::SoftEstop);
        for (i, ((ax, p), o)) in self.axes.iter().zip(self.p.axes.iter()).zip(out.iter()).enumerate() {
            let axis = i as u8;
            let pressed = limits & bit(i) != 0;
            if ax.ready && ax.obs.v.abs() > p.runaway {
                fault.get_or_insert(FaultReason::Runaway { axis });
            }
            // During homing a switch is the homing input of a seeking axis
            // and expected on axes not yet homed; on a homed axis at rest it
            // means something moved it.
            let homed_still = self.homed & bit(i) != 0 && !ax.homing.phase().is_moving();
            if pressed && (limit_is_fault || (self.mode == Mode::Homing && homed_still)) {
                fault.get_or_insert(FaultReason::LimitSwitch { axis });
            }
            let homed_moving = matches!(self.mode, Mode::Operational | Mode::Stopping { .. });
            if homed_moving && (ax.obs.x < p.pos_lo || ax.obs.x > p.pos_hi) {
                fault.get_or_insert(FaultReason::PositionLimit { axis });
            }
            if !(o.is_finite() && o.abs() <= p.vmax) {
                fault.get_or_insert(FaultReason::Numeric { axis });
            }
        }
    }

    fn enter_fault(&mut self, reason: FaultReason) {
        if self.mode == Mode::Homing || self.home_queued {
            self.home_queued = false;
            self.homing_status = HomingStatus::Failed;
            // Axes of the aborted run are not homed.
            self.homed &= !self.run_mask;
            for ax in self.axes.iter_mut() {
                ax.homing.reset(false);
            }
            self.run_mask = 0;
        }
        for (i, ax) in self.axes.iter().enumerate() {
            if ax.needs_reinit {
                self.homed &= !bit(i);
            }
        }
        if self.homed != ALL && self.homing_status == HomingStatus::Complete {
            self.homing_status = HomingStatus::NotRequested;
        }
        self.fault = Some(Fault { reason, tick: self.tick });
        self.mode = Mode::Fault;
        self.resync();
    }

    fn request_event(&self, kind: RequestKind) -> Option<Event> {
        match kind {
            RequestKind::Home if self.home_queued => Some(Event::HomingQueued),
            RequestKind::Home | RequestKind::HomeJoint(_) => Some(Event::HomingStarted { mask: self.run_mask }),
            RequestKind::Enable => Some(Event::Enabled(self.state())),
            RequestKind::Motion => None,
        }
    }

    fn handle(&mut self, r: Request<S>, sense: &Sense, detected: Option<FaultReason>) -> Result<(), Reject> {
        match r {
            Request::Motion(t) => self.accept_motion(&t),
            Request::Home if self.mode == Mode::Boot => {
                self.home_queued = true;
                self.homing_status = HomingStatus::InProgress;
                Ok(())
            }
            Request::Home => self.start_homing(ALL),
            Request::HomeJoint(j) => {
                let j = usize::from(j);
                if j >= AXES {
                    return Err(Reject::NoSuchJoint);
                }
                let needs = Self::dependencies(j);
                if self.homed & needs != needs {
                    return Err(Reject::DependencyNotHomed { needs: needs & !self.homed });
                }
                self.start_homing(bit(j))
            }
            Request::Enable(cap) if cap.kernel() != self.id => Err(Reject::ForeignCapability),
            Request::Enable(_) => self.enable(sense, detected),
        }
    }

    fn mode_refusal(&self) -> Option<Reject> {
        match self.mode {
            Mode::Boot => Some(Reject::Booting),
            Mode::Unhomed => Some(Reject::NotHomed),
            Mode::Homing => Some(Reject::Homing),
            Mode::Operational => None,
            Mode::Stopping { .. } => Some(Reject::Stopping),
            Mode::SoftEstop | Mode::Fault => Some(Reject::Latched),
        }
    }

    /// Validates a target against every joint's limits; the frame is
    /// accepted whole or not at all.
    pub fn validate(&self, t: &MotionTarget<S>) -> Result<(), Reject> {
        self.p.limits.check(t)
    }

    fn accept_motion(&mut self, t: &MotionTarget<S>) -> Result<(), Reject> {
        if let Some(r) = self.mode_refusal() {
            return Err(r);
        }
        self.validate(t)?;
        // Segment length: median of recent target intervals, bounded.
        let n = match self.since_target {
            None => self.p.seg_max,
            Some(gap) => {
                // max/min rather than `clamp`, which panics if min > max: the
                // tick must have no panic path even for a bad configuration.
                let gap = gap.max(self.p.seg_min).min(self.p.seg_max);
                let [_, a, b, c] = self.intervals;
                self.intervals = if self.intervals == [0; 4] { [gap; 4] } else { [a, b, c, gap] };
                median4(self.intervals)
            }
        };
        self.since_target = Some(0);
        let inv_n = self.p.recip.get(n as usize).copied().unwrap_or(S::ZERO);
        for ((ax, p), target) in self.axes.iter_mut().zip(self.p.axes.iter()).zip(t.position.iter()) {
            ax.interp.retarget(*target, inv_n, p.max_step);
        }
        self.armed = true;
        self.since_cmd = 0;
        Ok(())
    }

    fn start_homing(&mut self, mask: u8) -> Result<(), Reject> {
        match self.mode {
            Mode::Boot => return Err(Reject::Booting),
            Mode::Homing => return Err(Reject::Homing),
            Mode::Stopping { .. } => return Err(Reject::Stopping),
            Mode::Fault => return Err(Reject::Latched),
            Mode::Unhomed | Mode::Operational | Mode::SoftEstop => {}
        }
        self.homed &= !mask;
        for (i, ax) in self.axes.iter_mut().enumerate() {
            ax.homing.reset(mask & bit(i) != 0);
        }
        self.resync();
        self.run_mask = mask;
        self.run_group = 0;
        self.mode = Mode::Homing;
        self.homing_status = HomingStatus::InProgress;
        self.armed = false;
        self.since_cmd = 0;
        Ok(())
    }

    /// The first fault condition present right now, if any.
    fn present_cause(&self, sense: &Sense) -> Option<FaultReason> {
        if let Some(h) = sense.hardware_fault {
            return Some(FaultReason::Hardware(h));
        }
        for (i, ((ax, p), s)) in self.axes.iter().zip(self.p.axes.iter()).zip(sense.encoders.iter()).enumerate() {
            let axis = i as u8;
            let valid = matches!(*s, EncoderSample::Count(c) if i32::from(c) < COUNTS_PER_REV);
            if !valid {
                return Some(FaultReason::EncoderLost { axis });
            }
            if sense.limits & bit(i) != 0 {
                return Some(FaultReason::LimitSwitch { axis });
            }
            // An axis whose count was lost has a frozen estimate: enable
            // re-initialises it from the reading at rest, so its stale
            // velocity is no cause (it blocked enable forever otherwise).
            if !ax.needs_reinit && ax.obs.v.abs() > p.vmax {
                return Some(FaultReason::Runaway { axis });
            }
            let homed = self.homed & bit(i) != 0 && !ax.needs_reinit;
            if homed && (ax.obs.x < p.pos_lo || ax.obs.x > p.pos_hi) {
                return Some(FaultReason::PositionLimit { axis });
            }
        }
        None
    }

    /// `detected`: a fault condition found earlier in this same tick (it is
    /// latched at the end of the tick, so it must block the enable too).
    fn enable(&mut self, sense: &Sense, detected: Option<FaultReason>) -> Result<(), Reject> {
        match self.mode {
            Mode::Fault | Mode::SoftEstop => {}
            Mode::Stopping { .. } => return Err(Reject::Stopping),
            _ => return Err(Reject::NothingToClear),
        }
        if let Some(cause) = detected.or_else(|| self.present_cause(sense)) {
            return Err(Reject::CauseActive(cause));
        }
        // Encoders whose count was lost restart from their reading; their
        // joints must be homed again.
        for (i, ((ax, p), s)) in self.axes.iter_mut().zip(self.p.axes.iter()).zip(sense.encoders.iter()).enumerate() {
            if let (true, EncoderSample::Count(c)) = (ax.needs_reinit || !ax.ready, *s) {
                ax.init_from(c, p);
                self.homed &= !bit(i);
            }
        }
        self.fault = None;
        self.resync();
        self.mode = if self.homed == ALL { Mode::Operational } else { Mode::Unhomed };
        if self.homed != ALL && self.homing_status == HomingStatus::Complete {
            self.homing_status = HomingStatus::NotRequested;
        }
        Ok(())
    }
}

/// Hashes the state that determines the kernel's future behaviour, for model
/// checkers: everything but the constant parameters, the tick counter and
/// the fault's timestamp (both only label reports; no decision reads them).
/// Available when the scalar is hashable (the fixed-point variant).
impl<S: Scalar + core::hash::Hash> core::hash::Hash for Kernel<S> {
    fn hash<H: core::hash::Hasher>(&self, h: &mut H) {
        self.axes.hash(h);
        self.mode.hash(h);
        self.fault.map(|f| f.reason).hash(h);
        self.homing_status.hash(h);
        self.run_mask.hash(h);
        self.run_group.hash(h);
        self.home_queued.hash(h);
        self.homed.hash(h);
        self.boot_ticks.hash(h);
        self.since_cmd.hash(h);
        self.armed.hash(h);
        self.since_target.hash(h);
        self.intervals.hash(h);
        self.last_out.hash(h);
    }
}

#[cfg(test)]
mod tests {
    use super::median4;

    #[test]
    fn median_of_four() {
        assert_eq!(median4([10, 10, 10, 10]), 10);
        assert_eq!(median4([10, 20, 10, 10]), 10);
        assert_eq!(median4([20, 10, 10, 20]), 15);
        assert_eq!(median4([8, 40, 9, 11]), 10);
        assert_eq!(median4([u32::MAX, u32::MAX, 1, 1]), u32::MAX / 2 + 1);
    }
}
