//! The one per-tick safety monitor of the PAROL6 kernel.
//!
//! [`Monitor::check`] judges one kernel tick (the [`Sense`] handed in, the
//! request handed in as a [`Sent`], and the [`TickOutput`]) against every
//! requirement of `SAFETY.md` that can be judged from a tick's inputs and
//! outputs plus a little history, which the monitor carries between ticks
//! (previous output, set-point and state, the latched fault, the ticks since
//! the last accepted command, the soft-stop ramp's length, encoder-loss
//! streaks, joints that must be homed again). It works for both numeric
//! variants through [`kernel::Scalar`].
//!
//! The monitor is an *independent* oracle: its limits come from the
//! requirements' text and the configuration values ([`ArmConfig`]), never
//! from the kernel's derived tables. In particular the homing order is
//! written down here ([`SEED_DEPENDENCIES`]: J6; then J5, J4; then J1, J2,
//! J3) rather than read from `kernel::config::HOMING_GROUPS` or
//! `Kernel::dependencies`, so a change to the kernel's order is caught, not
//! mirrored.
//!
//! The checks live in one module per requirement group, run in a fixed
//! order on the facts of the tick computed once (`facts::TickFacts`):
//! `acceptance` (SR-15, SR-17, SR-30), `latch` (SR-1, SR-4, SR-5, SR-6),
//! `stops` (SR-7, SR-8, SR-29, SR-31), `sensors` (SR-9, SR-10, SR-11),
//! `homing` (SR-13, SR-14, SR-16, SR-25 and SR-28 in Homing) and `motion`
//! (SR-2, SR-18, SR-19, SR-25, SR-27, SR-28 in Operational).
//!
//! Comparisons run in the kernel's scalar type where a bound is one (SR-2,
//! SR-9: I8F24 compares raw words) and otherwise in `f64` through `f32`.
//! The per-tick step checks (SR-7's ramp step, SR-18's set-point speed,
//! SR-25's acceleration) have an integer path for I8F24: the raw words'
//! difference against the bound in words, exact, with no float operation
//! on a value of the tick. The `f64` path gives the same verdict wherever
//! both operands are exact in f32 (below 1 in magnitude, or 24 significant
//! bits) and differs only where their f32 rounding, up to 7.2e-6, moves
//! the step across the bound (4,656 of 1,769,904 enumerated pairs within
//! 2,048 words of the PAROL6 bounds: `cargo test -p monitor --lib
//! step_check -- --nocapture`).
//!
//! Checks and the requirement each covers (the `sr` of a [`Violation`]):
//!
//! | SR | check |
//! |---|---|
//! | SR-1 | zero output in Boot and Unhomed; `Ready` only from Boot; with [`PlantFacts::clean_since_start`], each estimate starts at rest at the encoder's reading |
//! | SR-2 | every output finite and within the joint's max velocity; step rate within the step generator's limit and the joint's speed, with the velocity's sign (the opposite one for a motor wired reversed, `motor_reversed`) |
//! | SR-4 | zero output on every axis in the tick a fault is raised |
//! | SR-5 | Fault state iff a fault is latched; at most one fault event per tick; the first reason kept; Fault and SoftEstop left only by an accepted enable; `<HOME>` in SoftEstop or Fault refused (`Reject::Latched` for `<HOME>`) |
//! | SR-6 | [`interactions`]: after the arm has rested, an enable in a latched state with no physical cause is accepted (no lock-up); enable refused while a cause is in the sensors (a homed joint's switch) or outside Fault/SoftEstop; after enable set-points equal positions, timeout disarmed, no speed above vmax, no fault in the same tick; with [`PlantFacts::quiet_ticks`], a refusal's cause is real |
//! | SR-7 | a timeout stop only at the timeout; Stopping entered from Operational by a timeout stop or `HomingAfterStop` (or by a lost link, SR-31); the ramp never speeds up or reverses, steps at most vmax/N, ends in exactly N ticks at zero with `Stopped` and latches, or, after `<HOME>` while moving, starts homing (`HomingStarted`, the only Stopping -> Homing edge); `<HOME>` while moving stops first, at rest it does not |
//! | SR-8 | the timeout is armed only by an accepted motion command, by every accepted stream sample, never by a go-to; disarmed by homing (and a `<HOME>` while moving) and enable |
//! | SR-9 | an estimate above the runaway threshold is a fault |
//! | SR-10 | a pressed switch of a homed joint in Operational, Stopping or SoftEstop, or on a homed axis at rest during homing, is a fault (an unhomed joint's switch is its homing input); [`interactions`]: no latch without a physical cause, a switch closed in half of 6 raw samples reaches the limit mask |
//! | SR-11 | more than `encoder_invalid_limit` invalid samples in a row fault, and that joint is not homed until homed again |
//! | SR-13 | in homing no axis moves before every axis of the earlier groups is homed and still; per-joint homing accepted only with its dependencies homed |
//! | SR-14 | with [`PlantFacts::clean_homing`], a finished homing run zeroes each axis at its true angle |
//! | SR-15 | motion accepted only in Operational; every refusal reported against the request that was sent; no event lost; no `Reject::Internal` |
//! | SR-16 | in homing an axis moves only in a moving phase; no moving phase outside Homing |
//! | SR-17 | accepted targets valid; a clearly valid target in Operational accepted (or refused as a jump, SR-30) |
//! | SR-18 | in Operational the set-point moves at most vmax/tick_hz per tick, and stays inside the set-point guarantee's intervals (G1, G2: [`setpoint_guarantee`]) |
//! | SR-19 | in Operational and Stopping every axis is homed (but the aborted run's, in a stop after a lost link in homing) and within its limits plus margin; with [`PlantFacts`], after a resync inside the limits and nothing injected since, every homed joint's true angle within its limits plus `ArmConfig::overrun_bound` (+ 2 mrad) |
//! | SR-25 | in Operational and Homing the output changes by at most max_acceleration/tick_hz per tick (in Homing a stop to zero at the axis's switch may be immediate) |
//! | SR-27 | in Operational the set-point velocity, computed from consecutive set-points, changes by at most max_acceleration/tick_hz plus the landing allowance and rounding (see `Monitor::check_setpoints`); a set-point never crosses its target and stays once there; set-points within the joint limits (or the resync point) |
//! | SR-28 | homing travel per phase within `homing.max_travel` (fast seek) or `JointConfig::homing_phase_travel()`, else a fault by then; with [`PlantFacts`], no `FollowingError` unless something was injected since the last resync, and a stalled or reversed joint whose set-point stays beyond the bound (+ [`FE_LIVENESS_SLACK`]) from its true angle faults within the bound's time (+ slack) |
//! | SR-29 | at the command timeout exactly one of: a timeout stop, `Holding`, a link-loss stop; `Holding` never while a set-point moves, and it stays Operational, disarmed; no timeout stop with every set-point at rest on its target, whatever the outputs' residual |
//! | SR-30 | a stream sample is accepted only within [`max_jump`]'s high bound (+ [`JUMP_SLACK`]) of the set-point or the previous target on every axis, and refused (`TargetJump`) only beyond its low bound; never a go-to |
//! | SR-31 | a lost link while moving, homing, or stopping to home starts a soft stop (`StopCause::LinkLost`) at once, and only then; an interrupted homing run is reported failed (H3) |
//!
//! A std caller with a `TickOutput<f32>` per tick:
//!
//! ```
//! use kernel::{config::{PAROL6, PAROL6_VALIDATED}, EncoderSample, KernelF32, Request, Sense};
//! use monitor::{Monitor, Sent};
//! let (mut k, _auth) = KernelF32::new(&PAROL6_VALIDATED);
//! let mut mon = Monitor::<f32>::new(&PAROL6);
//! let sense = Sense { encoders: [EncoderSample::Count(1000); 6], limits: 0, hardware_fault: None, link_lost: false };
//! let req: Option<Request<f32>> = Some(Request::Home);
//! let sent = req.as_ref().map(Sent::of); // before the kernel takes the request
//! let out = k.tick(&sense, req);
//! if let Err(v) = mon.check(&sense, sent.as_ref(), &out, Some(&k.homing_phases()), None) {
//!     panic!("{v}"); // e.g. "SR-7 J3: soft-stop speed increased: got 0.5, bound 0.4 (tick 812, Stopping)"
//! }
//! ```
#![cfg_attr(not(any(test, feature = "plant")), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
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

pub mod interactions;
#[cfg(any(test, feature = "plant"))]
pub mod plant;

/// Returns the violation `$v` from the enclosing check unless `$cond` holds.
macro_rules! ensure {
    ($cond:expr, $v:expr) => {{
        let ok: bool = $cond;
        if !ok {
            return Err($v);
        }
    }};
}

mod acceptance;
pub mod continuity;
mod facts;
mod homing;
mod latch;
mod motion;
mod sensors;
pub mod setpoint_guarantee;
mod stats;
mod stops;
mod violation;

pub use acceptance::{validity, Validity};
pub use facts::{PlantFacts, Sent};
pub use stats::{fault_kind, Stats, FAULT_KINDS};
pub use violation::{Sr, Violation};

use facts::TickFacts;
use kernel::config::{ms_to_ticks, ArmConfig, AXES, COUNTS_PER_REV};
use kernel::homing::Phase;
use kernel::{EncoderSample, Fault, Scalar, Sense, State, TickOutput};
use violation::Checked;

/// Ticks of rest with nothing injected after which the estimates have
/// settled (the observer's time constant is about 1/alpha = 10 ticks).
pub const QUIET_TICKS: u32 = 300;

/// SR-29, SR-31: an output at or below this speed (rad/s) is a joint
/// holding its set-point (correcting a count or two of error), not motion:
/// the hold rule of `SAFETY.md` (the kernel's `config::HOLD_SPEED`). The
/// monitor judges hold versus latch only outside a band of 0.1 % around it.
pub const HOLD_SPEED: f64 = 0.01;

/// SR-28: extra distance (rad) and time (ticks) the monitor allows, beyond
/// the following-error bound and its time, before a joint with a broken
/// motor (stalled or reversed) that is commanded away from where it stays
/// must have faulted: the observer's lag behind the true angle (the monitor
/// measures against the plant's true angle).
pub const FE_LIVENESS_SLACK: (f64, u32) = (0.03, 20);

/// SR-27: the least deceleration (fraction of `max_acceleration`) the
/// monitor assumes of the set-point profile when it judges whether a new
/// target lies inside the braking distance (the kernel may brake more
/// gently than `max_acceleration`; its braking distance is then longer).
pub const PROFILE_DECEL_MIN: f64 = 0.5;

/// SR-13, the seed's homing order (J6; then J5, J4; then J1, J2, J3), written
/// out here from the requirement, independently of the kernel's tables: the
/// joints (bit i = J(i+1)) that must be homed before joint i may move.
pub const SEED_DEPENDENCIES: [u8; AXES] = [0b11_1000, 0b11_1000, 0b11_1000, 0b10_0000, 0b10_0000, 0];

/// Every joint's bit.
const ALL: u8 = 0b11_1111;

/// Bit of axis `i` in a joint mask (0 for an index beyond the mask).
const fn bit(i: usize) -> u8 {
    match 1u8.checked_shl(i as u32) {
        Some(b) => b,
        None => 0,
    }
}

/// A sample the kernel accepts as a reading: a count of the 12-bit encoder.
pub fn is_count(e: &EncoderSample) -> bool {
    matches!(*e, EncoderSample::Count(c) if i32::from(c) < COUNTS_PER_REV)
}

fn f(x: impl Scalar) -> f64 {
    f64::from(x.to_f32())
}

fn cfg_joints(cfg: &ArmConfig) -> core::slice::Iter<'_, kernel::config::JointConfig> {
    cfg.joints.iter()
}

/// The monitor's memory between ticks. Create it together with the kernel
/// ([`Monitor::new`]) and hand it every tick, in order.
#[derive(Clone, Debug)]
pub struct Monitor<S> {
    cfg: ArmConfig,
    timeout_ticks: u32,
    stop_ticks: u32,
    prev_out: [S; AXES],
    prev_state: State,
    prev_armed: bool,
    prev_setpoint: [S; AXES],
    prev_homed: u8,
    latched: Option<Fault>,
    stopping_ticks: u32,
    since_accept: Option<u32>,
    lost_streak: [u32; AXES],
    must_rehome: u8,
    /// SR-27: the set-point velocity of the last tick (rad/s, from
    /// consecutive set-points), when the last tick was Operational.
    sp_vel: Option<[f64; AXES]>,
    /// SR-29, SR-31: the set-points did not change in the last tick (known
    /// when it was Operational).
    prev_sp_static: Option<bool>,
    /// SR-19: the running stop came from Homing (a lost link): joints of
    /// the aborted run are not homed.
    stopping_from_homing: bool,
    /// SR-27, SR-30: the target the set-points move toward (the last
    /// accepted one, or the resynchronised set-point), when known.
    target: Option<[S; AXES]>,
    /// SR-27: the set-points where Operational was entered (resync).
    anchor: [f64; AXES],
    /// SR-18: the set-point guarantee's intervals.
    guarantee: setpoint_guarantee::Guarantee,
    /// SR-27: axes given a target inside their braking distance, not
    /// judged for acceleration until at rest at it for long enough.
    infeasible: u8,
    /// SR-27: ticks each set-point has rested (unchanged).
    rest_ticks: [u32; AXES],
    /// SR-27: for an axis given a target inside its braking distance, the
    /// farthest point its set-point may reach (and the direction), until
    /// the next target.
    reach: [Option<(f64, f64)>; AXES],
    /// SR-7: the running ramp ends in homing (`HomingAfterStop`).
    pending_home: bool,
    /// SR-19, SR-28: something was injected since the set-points were last
    /// resynchronised (only with plant facts).
    dirty: bool,
    /// SR-19: at the last resync every homed joint was inside its limits.
    inside_at_resync: bool,
    /// SR-28: each axis's homing phase and the estimate where it began.
    home_phase: [Phase; AXES],
    home_origin: [f64; AXES],
    /// SR-28: consecutive Operational ticks a broken joint's set-point has
    /// been beyond the following-error bound from its true angle.
    fe_over: [u32; AXES],
    /// SR-2: each joint's largest step rate (its max velocity in steps,
    /// 0.1 % and one step of slack), computed once from `cfg`.
    rate_max: [f64; AXES],
    /// Per-joint bounds computed once from `cfg` rather than every tick:
    /// SR-7's soft-stop step
    /// `max_velocity / N`, SR-18's `max_velocity / tick_hz`, SR-25's and
    /// SR-27's `max_acceleration / tick_hz`, SR-28's phase travel bounds.
    stop_step: [f64; AXES],
    /// `S` is the fixed-point variant (I8F24): step checks compare raw
    /// words ([`motion::is_fixed_point`]).
    fixed: bool,
    vel_per_tick: [f64; AXES],
    acc_per_tick: [f64; AXES],
    fast_seek_travel: [f64; AXES],
    phase_travel: [f64; AXES],
    /// Coverage counters.
    pub stats: Stats,
    /// Lock-up and latches without a cause (SR-6, SR-10, SR-19).
    interactions: interactions::Interactions,
}

impl<S: Scalar> Monitor<S> {
    /// A monitor for a kernel that has just been created with `cfg` (no
    /// tick run yet).
    pub fn new(cfg: &ArmConfig) -> Self {
        let stop = ms_to_ticks(cfg.soft_stop_ms, cfg.tick_hz);
        let stop_ticks = if stop == 0 { 1 } else { stop };
        let (hz, n) = (f64::from(cfg.tick_hz), f64::from(stop_ticks));
        Monitor {
            cfg: *cfg,
            timeout_ticks: ms_to_ticks(cfg.command_timeout_ms, cfg.tick_hz),
            stop_ticks,
            prev_out: [S::ZERO; AXES],
            prev_state: State::Boot,
            prev_armed: false,
            prev_setpoint: [S::ZERO; AXES],
            prev_homed: 0,
            latched: None,
            stopping_ticks: 0,
            since_accept: None,
            lost_streak: [0; AXES],
            must_rehome: 0,
            sp_vel: None,
            prev_sp_static: None,
            stopping_from_homing: false,
            target: None,
            anchor: [0.0; AXES],
            guarantee: setpoint_guarantee::Guarantee::default(),
            infeasible: 0,
            rest_ticks: [0; AXES],
            reach: [None; AXES],
            pending_home: false,
            dirty: false,
            inside_at_resync: false,
            home_phase: [Phase::Idle; AXES],
            home_origin: [0.0; AXES],
            fe_over: [0; AXES],
            rate_max: cfg.joints.map(|j| f64::from(j.max_velocity) * j.steps_per_rad() * 1.001 + 1.0),
            stop_step: cfg.joints.map(|j| f64::from(j.max_velocity) / n),
            fixed: motion::is_fixed_point::<S>(),
            vel_per_tick: cfg.joints.map(|j| f64::from(j.max_velocity) / hz),
            acc_per_tick: cfg.joints.map(|j| f64::from(j.max_acceleration) / hz),
            fast_seek_travel: cfg.joints.map(|j| f64::from(j.homing.max_travel)),
            phase_travel: cfg.joints.map(|j| f64::from(j.homing_phase_travel())),
            interactions: interactions::Interactions::new(cfg),
            stats: Stats::default(),
        }
    }

    /// Checks one tick: `sense` and `sent` as handed to the kernel, `out` as
    /// returned; `phases` are the kernel's homing phases after the tick
    /// (`Kernel::homing_phases`; without them the phase checks of SR-10,
    /// SR-13 and SR-16 are skipped), `plant` the test plant's facts (see
    /// [`PlantFacts`]). Returns the first violated requirement. Call it for
    /// every tick, also after a violation.
    pub fn check(
        &mut self,
        sense: &Sense,
        sent: Option<&Sent<S>>,
        out: &TickOutput<S>,
        phases: Option<&[Phase; AXES]>,
        plant: Option<&PlantFacts>,
    ) -> Checked {
        let r = self.check_inner(sense, sent, out, phases, plant);
        // Where modes meet (`interactions`): checked every tick too.
        let enable_sent = sent.is_some_and(|s| s.kind() == kernel::RequestKind::Enable);
        let r = r.and(self.interactions.check(sense, enable_sent, out));
        // Memory for the next tick.
        self.prev_out = out.act.velocity;
        self.prev_state = out.status.state;
        self.prev_armed = out.status.timeout_armed;
        self.prev_setpoint = out.status.setpoint;
        self.prev_homed = out.status.homed;
        r
    }

    /// The checks in their fixed order (the first violation is returned;
    /// the memory a check updates is updated only when the checks before
    /// it passed).
    fn check_inner(
        &mut self,
        sense: &Sense,
        sent: Option<&Sent<S>>,
        out: &TickOutput<S>,
        phases: Option<&[Phase; AXES]>,
        plant: Option<&PlantFacts>,
    ) -> Checked {
        self.count(out, plant);
        let t = TickFacts::new(self, sense, sent, out, phases, plant);
        self.check_reports(&t)?;
        self.check_outputs(&t)?;
        self.check_zero_output(&t)?;
        self.check_ready(&t)?;
        self.check_latch(&t)?;
        self.check_enable(&t)?;
        self.check_stop_causes(&t)?;
        self.check_ramp(&t)?;
        self.check_timeout(&t)?;
        self.check_sensors(&t)?;
        self.check_homing_order(&t)?;
        self.check_homing_zero(&t)?;
        self.check_acceptance(&t)?;
        self.check_setpoint_speed(&t)?;
        self.check_setpoints(&t)?;
        self.check_guarantee(&t)?;
        self.check_limits(&t)?;
        self.check_following_error(&t)?;
        self.check_homing_travel(&t)?;
        self.check_output_acceleration(&t)?;
        self.check_homing_acceleration(&t)
    }
}

#[cfg(test)]
mod tests;
