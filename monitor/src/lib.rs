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
//! Checks and the requirement each covers (the `sr` of a [`Violation`]):
//!
//! | SR | check |
//! |---|---|
//! | SR-1 | zero output in Boot and Unhomed; `Ready` only from Boot; with [`PlantFacts::clean_since_start`], each estimate starts at rest at the encoder's reading |
//! | SR-2 | every output finite and within the joint's max velocity; step rate within the step generator's limit and the joint's speed, with the velocity's sign |
//! | SR-4 | zero output on every axis in the tick a fault is raised |
//! | SR-5 | Fault state iff a fault is latched; at most one fault event per tick; the first reason kept; Fault and SoftEstop left only by an accepted enable; `<HOME>` in SoftEstop or Fault refused (`Reject::Latched` for `<HOME>`) |
//! | SR-6 | enable refused while a cause is in the sensors or outside Fault/SoftEstop; after enable set-points equal positions, timeout disarmed, no speed above vmax, no fault in the same tick; with [`PlantFacts::quiet_ticks`], a refusal's cause is real |
//! | SR-7 | a timeout stop only at the timeout; Stopping entered from Operational by a timeout stop or `HomingAfterStop` (or by a lost link, SR-31); the ramp never speeds up or reverses, steps at most vmax/N, ends in exactly N ticks at zero with `Stopped` and latches, or, after `<HOME>` while moving, starts homing (`HomingStarted`, the only Stopping -> Homing edge); `<HOME>` while moving stops first, at rest it does not |
//! | SR-8 | the timeout is armed only by an accepted motion command, by every accepted stream sample, never by a go-to; disarmed by homing (and a `<HOME>` while moving) and enable |
//! | SR-9 | an estimate above the runaway threshold is a fault |
//! | SR-10 | a pressed switch in Operational, Stopping or SoftEstop, or on a homed axis at rest during homing, is a fault |
//! | SR-11 | more than `encoder_invalid_limit` invalid samples in a row fault, and that joint is not homed until homed again |
//! | SR-13 | in homing no axis moves before every axis of the earlier groups is homed and still; per-joint homing accepted only with its dependencies homed |
//! | SR-14 | with [`PlantFacts::clean_homing`], a finished homing run zeroes each axis at its true angle |
//! | SR-15 | motion accepted only in Operational; every refusal reported against the request that was sent; no event lost; no `Reject::Internal` |
//! | SR-16 | in homing an axis moves only in a moving phase; no moving phase outside Homing |
//! | SR-17 | accepted targets valid; a clearly valid target in Operational accepted (or refused as a jump, SR-30) |
//! | SR-18 | in Operational the set-point moves at most vmax/tick_hz per tick |
//! | SR-19 | in Operational and Stopping every axis is homed (but the aborted run's, in a stop after a lost link in homing) and within its limits plus margin; with [`PlantFacts`], after a resync inside the limits and nothing injected since, every homed joint's true angle within its limits plus `ArmConfig::overrun_bound` (+ 2 mrad) |
//! | SR-25 | in Operational and Homing the output changes by at most max_acceleration/tick_hz per tick (in Homing a stop to zero at the axis's switch may be immediate) |
//! | SR-27 | in Operational the set-point velocity, computed from consecutive set-points, changes by at most max_acceleration/tick_hz plus the landing allowance and rounding (see `Monitor::check_setpoints`); a set-point never crosses its target and stays once there; set-points within the joint limits (or the resync point) |
//! | SR-28 | homing travel per phase within `homing.max_travel` (fast seek) or `JointConfig::homing_phase_travel()`, else a fault by then; with [`PlantFacts`], no `FollowingError` unless something was injected since the last resync, and a stalled or reversed joint whose set-point stays beyond the bound (+ [`FE_LIVENESS_SLACK`]) from its true angle faults within the bound's time (+ slack) |
//! | SR-29 | at the command timeout exactly one of: a timeout stop, `Holding`, a link-loss stop; `Holding` never while a set-point or an output above [`HOLD_SPEED`] moves, and it stays Operational, disarmed; no timeout stop of an arm at rest at its targets |
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

#[cfg(any(test, feature = "plant"))]
pub mod plant;

use core::fmt;

use kernel::config::{ms_to_ticks, ArmConfig, AXES, COUNTS_PER_REV};
use kernel::homing::Phase;
use kernel::{
    EncoderSample, Event, Fault, FaultReason, HomingStatus, MotionKind, MotionTarget, Reject, Request, RequestKind,
    Scalar, Sense, State, StopCause, TickOutput,
};

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

/// A request as the monitor sees it: what was handed to the kernel this
/// tick (the enable capability itself is not `Copy`, so it is not kept).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sent<S> {
    /// `Request::Motion`, with its target when the caller has it (the
    /// SR-17 validity checks need it; without it they are skipped).
    Motion(Option<MotionTarget<S>>),
    /// `Request::Home`.
    Home,
    /// `Request::HomeJoint`.
    HomeJoint(u8),
    /// `Request::Enable`.
    Enable,
}

impl<S: Copy> Sent<S> {
    /// The monitor's view of `r` (take it before the kernel consumes `r`).
    pub fn of(r: &Request<S>) -> Self {
        match r {
            Request::Motion(t) => Sent::Motion(Some(*t)),
            Request::Home => Sent::Home,
            Request::HomeJoint(j) => Sent::HomeJoint(*j),
            Request::Enable(_) => Sent::Enable,
        }
    }

    /// From the request kind only (a motion target's validity is then not judged).
    pub fn from_kind(k: RequestKind) -> Self {
        match k {
            RequestKind::Motion => Sent::Motion(None),
            RequestKind::Home => Sent::Home,
            RequestKind::HomeJoint(j) => Sent::HomeJoint(j),
            RequestKind::Enable => Sent::Enable,
        }
    }

    /// The kind of this request.
    pub fn kind(&self) -> RequestKind {
        match self {
            Sent::Motion(_) => RequestKind::Motion,
            Sent::Home => RequestKind::Home,
            Sent::HomeJoint(j) => RequestKind::HomeJoint(*j),
            Sent::Enable => RequestKind::Enable,
        }
    }
}

/// Facts about the arm that only a test plant knows; the checks that need
/// them (SR-1's initial estimate, SR-6's liveness, SR-14's zero) run only
/// when the caller passes them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlantFacts {
    /// True joint angles after this tick's sensing (before applying outputs).
    pub q: [f64; AXES],
    /// Nothing has been injected since power-on (SR-1's check of the
    /// observer's initial value needs undisturbed readings).
    pub clean_since_start: bool,
    /// Consecutive ticks (up to this one) with the arm at rest and nothing
    /// injected: no outside force, glitch, loss, slip, switch or hardware
    /// fault.
    pub quiet_ticks: u32,
    /// Nothing was injected during the current homing run (SR-14's check of
    /// the captured zero needs a real switch edge).
    pub clean_homing: bool,
    /// Something that can move a joint off its command or fool the
    /// estimate is injected in this tick: an encoder fault, glitch or
    /// slip, a forced switch, an outside force, a hardware fault, a
    /// reversed or stalled motor, a hand-made sensor value (not a lost
    /// link, not a dead switch). SR-28's and SR-19's clean-plant checks
    /// need a run with none since the set-points were last resynchronised.
    pub disturbed: bool,
    /// Joints whose motor is stalled or turns the wrong way (bit per joint),
    /// for SR-28's liveness check.
    pub broken_motor: u8,
}

/// A violated requirement: which one, on which axis, what, and the numbers.
/// `Display` formats it on one line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Violation {
    /// The requirement, e.g. `"SR-7"`.
    pub sr: &'static str,
    /// The axis (0..=5), if the check is per axis.
    pub axis: Option<u8>,
    /// What was wrong.
    pub what: &'static str,
    /// The offending value, where there is one.
    pub got: Option<f64>,
    /// The bound it broke, where there is one.
    pub bound: Option<f64>,
    /// The kernel's tick count (`status.tick`).
    pub tick: u32,
    /// The kernel's state after the tick.
    pub state: State,
}

impl Violation {
    fn on(mut self, axis: usize) -> Self {
        self.axis = u8::try_from(axis).ok();
        self
    }
    fn got(mut self, x: f64) -> Self {
        self.got = Some(x);
        self
    }
    fn bound(mut self, x: f64) -> Self {
        self.bound = Some(x);
        self
    }
}

impl fmt::Display for Violation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.sr)?;
        if let Some(a) = self.axis {
            write!(f, " J{}", u16::from(a).saturating_add(1))?;
        }
        write!(f, ": {}", self.what)?;
        if let Some(g) = self.got {
            write!(f, ": got {g}")?;
        }
        if let Some(b) = self.bound {
            write!(f, ", bound {b}")?;
        }
        write!(f, " (tick {}, {:?})", self.tick, self.state)
    }
}

/// What the monitor saw over a run (for coverage reports).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// Ticks checked.
    pub ticks: u64,
    /// Ticks per state, in `State` declaration order.
    pub state_ticks: [u64; 7],
    /// Motion targets accepted.
    pub accepted: u64,
    /// Requests rejected.
    pub rejected: u64,
    /// Faults latched, by reason kind (see [`fault_kind`]).
    pub faults: [u64; 11],
    /// Enables accepted.
    pub enabled: u64,
    /// Enables refused because a cause was present.
    pub enable_refused: u64,
    /// Soft E-stops started.
    pub soft_stops: u64,
    /// Soft E-stop ramps completed.
    pub stopped: u64,
    /// Homing runs completed (`HomingDone`).
    pub homing_done: u64,
    /// Ticks in Operational with a non-zero output.
    pub moving_ticks: u64,
    /// Enables sent in Fault or SoftEstop after the arm had rested with
    /// nothing injected for `QUIET_TICKS` (SR-6's liveness check applies).
    pub quiet_enables: u64,
    /// Go-to targets accepted.
    pub goto_accepted: u64,
    /// Stream samples refused as a jump (`TargetJump`).
    pub target_jumps: u64,
    /// Command timeouts that held (`Holding`) instead of latching.
    pub holds: u64,
    /// Soft stops started by a lost link.
    pub link_stops: u64,
    /// `<HOME>` accepted while moving (a stop first, `HomingAfterStop`).
    pub homes_after_stop: u64,
    /// Targets accepted inside the set-point's braking distance, in its
    /// direction of motion, per axis (SR-27's "never past the target"
    /// cannot hold with its acceleration bound: the passing is bounded
    /// instead until the axis rests; see `Monitor::check_setpoints`).
    pub infeasible_retargets: u64,
    /// Ticks with a broken motor (stalled or reversed) on some joint.
    pub broken_motor_ticks: u64,
}

fn inc(x: &mut u64) {
    *x = x.saturating_add(1);
}

impl Stats {
    /// Adds `o` into `self`.
    pub fn merge(&mut self, o: &Stats) {
        let add = |a: &mut u64, b: u64| *a = a.saturating_add(b);
        add(&mut self.ticks, o.ticks);
        for (a, b) in self.state_ticks.iter_mut().zip(o.state_ticks.iter()) {
            add(a, *b);
        }
        for (a, b) in self.faults.iter_mut().zip(o.faults.iter()) {
            add(a, *b);
        }
        add(&mut self.accepted, o.accepted);
        add(&mut self.rejected, o.rejected);
        add(&mut self.enabled, o.enabled);
        add(&mut self.enable_refused, o.enable_refused);
        add(&mut self.soft_stops, o.soft_stops);
        add(&mut self.stopped, o.stopped);
        add(&mut self.homing_done, o.homing_done);
        add(&mut self.moving_ticks, o.moving_ticks);
        add(&mut self.quiet_enables, o.quiet_enables);
        add(&mut self.goto_accepted, o.goto_accepted);
        add(&mut self.target_jumps, o.target_jumps);
        add(&mut self.holds, o.holds);
        add(&mut self.link_stops, o.link_stops);
        add(&mut self.homes_after_stop, o.homes_after_stop);
        add(&mut self.infeasible_retargets, o.infeasible_retargets);
        add(&mut self.broken_motor_ticks, o.broken_motor_ticks);
    }
}

/// Names of the fault kinds counted in [`Stats::faults`].
pub const FAULT_KINDS: [&str; 11] = [
    "EncoderLost",
    "EncoderJump",
    "EncoderNotReady",
    "Runaway",
    "LimitSwitch",
    "PositionLimit",
    "Numeric",
    "HomingTimeout",
    "Hardware",
    "HomingTravel",
    "FollowingError",
];

/// Index of a fault reason in [`FAULT_KINDS`].
pub fn fault_kind(r: &FaultReason) -> usize {
    match r {
        FaultReason::EncoderLost { .. } => 0,
        FaultReason::EncoderJump { .. } => 1,
        FaultReason::EncoderNotReady { .. } => 2,
        FaultReason::Runaway { .. } => 3,
        FaultReason::LimitSwitch { .. } => 4,
        FaultReason::PositionLimit { .. } => 5,
        FaultReason::Numeric { .. } => 6,
        FaultReason::HomingTimeout { .. } => 7,
        FaultReason::Hardware(_) => 8,
        FaultReason::HomingTravel { .. } => 9,
        FaultReason::FollowingError { .. } => 10,
    }
}

fn state_index(s: State) -> usize {
    match s {
        State::Boot => 0,
        State::Unhomed => 1,
        State::Homing => 2,
        State::Operational => 3,
        State::Stopping => 4,
        State::SoftEstop => 5,
        State::Fault => 6,
    }
}

/// The monitor's own verdict on a motion target (SR-17).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Validity {
    /// Finite, inside every limit with room to spare: must be accepted.
    Valid,
    /// Within a rounding distance of a limit: either answer is fine.
    Edge,
    /// Non-finite or clearly outside a limit: must be rejected.
    Invalid,
}

/// Classifies `t` against the configuration's limits (SR-17).
pub fn validity<S: Scalar>(cfg: &ArmConfig, t: &MotionTarget<S>) -> Validity {
    const EPS: f64 = 1e-5;
    let mut edge = false;
    for ((j, p), v) in cfg.joints.iter().zip(t.position.iter()).zip(t.velocity.iter()) {
        if !(p.is_finite() && v.is_finite()) {
            return Validity::Invalid;
        }
        let (p, v) = (f64::from(p.to_f32()), f64::from(v.to_f32()).abs());
        let (lo, hi, vmax) = (f64::from(j.limit_min), f64::from(j.limit_max), f64::from(j.max_velocity));
        if p < lo - EPS || p > hi + EPS || v > vmax + EPS {
            return Validity::Invalid;
        }
        if p < lo + EPS || p > hi - EPS || v > vmax - EPS {
            edge = true;
        }
    }
    if edge {
        Validity::Edge
    } else {
        Validity::Valid
    }
}

fn f(x: impl Scalar) -> f64 {
    f64::from(x.to_f32())
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
    /// Per-joint bounds computed once from `cfg` (the same expressions the
    /// checks below once evaluated every tick): SR-7's soft-stop step
    /// `max_velocity / N`, SR-18's `max_velocity / tick_hz`, SR-25's and
    /// SR-27's `max_acceleration / tick_hz`, SR-28's phase travel bounds.
    stop_step: [f64; AXES],
    vel_per_tick: [f64; AXES],
    acc_per_tick: [f64; AXES],
    fast_seek_travel: [f64; AXES],
    phase_travel: [f64; AXES],
    /// Coverage counters.
    pub stats: Stats,
}

type Checked = Result<(), Violation>;

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
            vel_per_tick: cfg.joints.map(|j| f64::from(j.max_velocity) / hz),
            acc_per_tick: cfg.joints.map(|j| f64::from(j.max_acceleration) / hz),
            fast_seek_travel: cfg.joints.map(|j| f64::from(j.homing.max_travel)),
            phase_travel: cfg.joints.map(|j| f64::from(j.homing_phase_travel())),
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
        // Memory for the next tick.
        self.prev_out = out.act.velocity;
        self.prev_state = out.status.state;
        self.prev_armed = out.status.timeout_armed;
        self.prev_setpoint = out.status.setpoint;
        self.prev_homed = out.status.homed;
        r
    }

    fn count(&mut self, out: &TickOutput<S>) {
        let st = out.status.state;
        inc(&mut self.stats.ticks);
        if let Some(n) = self.stats.state_ticks.get_mut(state_index(st)) {
            inc(n);
        }
        for e in out.events.iter() {
            match e {
                Event::Rejected { reason: Reject::CauseActive(_), .. } => {
                    inc(&mut self.stats.rejected);
                    inc(&mut self.stats.enable_refused);
                }
                Event::Rejected { .. } => inc(&mut self.stats.rejected),
                Event::Fault(r) => {
                    if let Some(n) = self.stats.faults.get_mut(fault_kind(r)) {
                        inc(n);
                    }
                }
                Event::Enabled(_) => inc(&mut self.stats.enabled),
                Event::SoftEstop { .. } => inc(&mut self.stats.soft_stops),
                Event::Stopped => inc(&mut self.stats.stopped),
                Event::HomingDone { .. } => inc(&mut self.stats.homing_done),
                _ => {}
            }
        }
        if st == State::Operational && out.act.velocity.iter().any(|v| *v != S::ZERO) {
            inc(&mut self.stats.moving_ticks);
        }
    }

    fn check_inner(
        &mut self,
        sense: &Sense,
        sent: Option<&Sent<S>>,
        out: &TickOutput<S>,
        phases: Option<&[Phase; AXES]>,
        plant: Option<&PlantFacts>,
    ) -> Checked {
        self.count(out);
        let st = out.status.state;
        let prev = self.prev_state;
        let fail = |sr: &'static str, what: &'static str| Violation {
            sr,
            axis: None,
            what,
            got: None,
            bound: None,
            tick: out.status.tick,
            state: st,
        };
        macro_rules! ensure {
            ($cond:expr, $v:expr) => {{
                let ok: bool = $cond;
                if !ok {
                    return Err($v);
                }
            }};
        }
        // The unit-like events the checks below look for, in one pass.
        let (mut ev_ready, mut ev_after_stop, mut ev_link_stop, mut ev_holding, mut ev_stopped) =
            (false, false, false, false, false);
        for e in out.events.iter() {
            match e {
                Event::Ready => ev_ready = true,
                Event::HomingAfterStop => ev_after_stop = true,
                Event::SoftEstop { cause: StopCause::LinkLost } => ev_link_stop = true,
                Event::Holding => ev_holding = true,
                Event::Stopped => ev_stopped = true,
                _ => {}
            }
        }

        // SR-15: refusals are reported; none may be lost.
        ensure!(out.events.dropped() == 0, fail("SR-15", "events dropped").got(f64::from(out.events.dropped())));

        // What happened to this tick's request.
        let rejected = out.events.iter().find_map(|e| match e {
            Event::Rejected { request, reason } => Some((*request, *reason)),
            _ => None,
        });
        if let Some((k, _)) = rejected {
            ensure!(sent.map(Sent::kind) == Some(k), fail("SR-15", "a rejection without that request"));
        }
        let accepted = sent.is_some() && rejected.is_none();
        let mut n_faults = 0u32;
        let mut fault_event = None;
        for e in out.events.iter() {
            if let Event::Fault(r) = e {
                n_faults = n_faults.saturating_add(1);
                fault_event = fault_event.or(Some(*r));
            }
        }
        let all_zero = out.act.velocity.iter().all(|v| *v == S::ZERO) && out.act.step_rate.iter().all(|r| *r == 0);
        let motion_accepted = accepted && matches!(sent, Some(Sent::Motion(_)));
        let accepted_target = match sent {
            Some(Sent::Motion(Some(t))) if motion_accepted => Some(*t),
            _ => None,
        };
        let home_sent = matches!(sent, Some(Sent::Home | Sent::HomeJoint(_)));
        let after_stop = ev_after_stop;
        let homing_started = out.events.iter().any(|e| matches!(e, Event::HomingStarted { .. }));
        // The target the set-points move toward in this tick (Operational):
        // this tick's accepted target, else the last one.
        let old_target = self.target;
        let target_now = if motion_accepted { accepted_target.map(|t| t.position) } else { old_target };
        if let Some(p) = plant {
            if p.broken_motor != 0 {
                inc(&mut self.stats.broken_motor_ticks);
            }
        }

        self.check_outputs(out, &fail)?;

        // SR-1, SR-4: zero output in Boot, Unhomed, SoftEstop, Fault, and in
        // the tick a fault is raised (for every axis).
        if n_faults > 0 {
            ensure!(all_zero, fail("SR-4", "the tick a fault is raised did not zero every axis"));
        }
        if matches!(st, State::Boot | State::Unhomed) {
            ensure!(all_zero, fail("SR-1", "non-zero output before homing"));
        }
        if matches!(st, State::SoftEstop | State::Fault) {
            ensure!(all_zero, fail("SR-5", "non-zero output while latched"));
        }

        // SR-1: leaving Boot, each estimate is the encoder's actual reading.
        if ev_ready {
            ensure!(prev == State::Boot, fail("SR-1", "Ready outside Boot"));
            if plant.is_some_and(|p| p.clean_since_start) {
                for (i, ((j, e), (x, v))) in cfg_joints(&self.cfg)
                    .zip(sense.encoders.iter())
                    .zip(out.status.position.iter().zip(out.status.velocity.iter()))
                    .enumerate()
                {
                    let EncoderSample::Count(c) = *e else {
                        return Err(fail("SR-1", "Ready with an encoder lost").on(i));
                    };
                    let want = f64::from(c) * j.rad_per_count();
                    let got = f(*x);
                    let tol = 2.0 * j.rad_per_count() + 1e-5;
                    ensure!(
                        (got - want).abs() <= tol,
                        fail("SR-1", "estimate does not start at the reading").on(i).got(got).bound(want)
                    );
                    ensure!(*v == S::ZERO, fail("SR-1", "estimate does not start at rest").on(i).got(f(*v)));
                }
            }
        }

        // SR-5: a fault latches with its first reason until an accepted enable.
        ensure!(
            (st == State::Fault) == out.status.fault.is_some(),
            fail("SR-5", "Fault state and latched fault disagree")
        );
        ensure!(n_faults <= 1, fail("SR-5", "several faults in one tick").got(f64::from(n_faults)));
        let enabled = out.events.iter().find_map(|e| if let Event::Enabled(s) = e { Some(*s) } else { None });
        let enable_sent = matches!(sent, Some(Sent::Enable));
        match (prev == State::Fault, st == State::Fault) {
            (false, true) => {
                let Some(fl) = out.status.fault else {
                    return Err(fail("SR-5", "Fault without a reason"));
                };
                ensure!(
                    n_faults == 1 && fault_event == Some(fl.reason),
                    fail("SR-5", "entered Fault without its fault event")
                );
                self.latched = Some(fl);
            }
            (true, true) => {
                ensure!(n_faults == 0, fail("SR-5", "a second fault event while latched"));
                ensure!(out.status.fault == self.latched, fail("SR-5", "the latched fault changed"));
            }
            (true, false) => {
                ensure!(enable_sent && enabled == Some(st), fail("SR-5", "left Fault without an accepted enable"));
                self.latched = None;
            }
            (false, false) => ensure!(n_faults == 0, fail("SR-5", "a fault event outside Fault")),
        }

        // SR-5: SoftEstop is latched until an accepted enable; `<HOME>` in
        // SoftEstop or Fault is refused (only `<ENABLE>` clears a latch).
        if prev == State::SoftEstop && !matches!(st, State::SoftEstop | State::Fault) {
            ensure!(enable_sent && enabled == Some(st), fail("SR-5", "left SoftEstop without an accepted enable"));
        }
        if home_sent && matches!(prev, State::SoftEstop | State::Fault) {
            ensure!(!accepted, fail("SR-5", "HOME accepted while a soft E-stop or fault is latched"));
            if matches!(sent, Some(Sent::Home)) {
                ensure!(
                    matches!(rejected, Some((_, Reject::Latched))),
                    fail("SR-5", "HOME while latched refused for a reason other than Latched")
                );
            }
        }

        // SR-6: enable is refused while a cause is present in this tick's
        // sensors or state; after it, set-points are the measured positions
        // and the timeout is disarmed.
        let sensed_cause =
            sense.hardware_fault.is_some() || sense.limits & ALL != 0 || !sense.encoders.iter().all(is_count);
        // SR-6, liveness: a cause named by a refusal is real. After the arm
        // has rested with nothing injected for `QUIET_TICKS` the estimates
        // have settled, so no speed is a cause, and a lost encoder, a switch
        // or a hardware fault must be in this tick's sensors. (A frozen
        // estimate of a lost encoder once blocked enable for good.)
        if let (true, Some(p)) = (enable_sent, plant) {
            if p.quiet_ticks >= QUIET_TICKS {
                if matches!(prev, State::Fault | State::SoftEstop) {
                    inc(&mut self.stats.quiet_enables);
                }
                for e in out.events.iter() {
                    if let Event::Rejected { reason: Reject::CauseActive(c), .. } = e {
                        let real = match *c {
                            FaultReason::Runaway { .. } => false,
                            FaultReason::EncoderLost { axis } => {
                                !sense.encoders.get(usize::from(axis)).is_some_and(is_count)
                            }
                            FaultReason::LimitSwitch { axis } => sense.limits & bit(usize::from(axis)) != 0,
                            FaultReason::Hardware(_) => sense.hardware_fault.is_some(),
                            _ => true,
                        };
                        ensure!(
                            real,
                            fail("SR-6", "enable refused for a cause not present after the arm rested")
                                .got(f64::from(p.quiet_ticks))
                        );
                    }
                }
            }
        }
        if enable_sent {
            if matches!(prev, State::Fault | State::SoftEstop) && sensed_cause {
                ensure!(enabled.is_none(), fail("SR-6", "enable accepted with a cause in the sensors"));
            }
            if !matches!(prev, State::Fault | State::SoftEstop) {
                ensure!(enabled.is_none(), fail("SR-6", "enable accepted with nothing latched"));
            }
        }
        if let Some(s) = enabled {
            ensure!(enable_sent, fail("SR-6", "Enabled without an enable request"));
            ensure!(matches!(prev, State::Fault | State::SoftEstop), fail("SR-6", "enabled from a state not latched"));
            ensure!(!sensed_cause, fail("SR-6", "enabled with a cause in the sensors"));
            ensure!(n_faults == 0, fail("SR-6", "enabled and faulted in the same tick"));
            ensure!(
                s == st && matches!(st, State::Operational | State::Unhomed),
                fail("SR-6", "enabled into a state other than Operational or Unhomed")
            );
            ensure!(!out.status.timeout_armed, fail("SR-6", "timeout armed after enable"));
            for (i, ((sp, x), (v, j))) in out
                .status
                .setpoint
                .iter()
                .zip(out.status.position.iter())
                .zip(out.status.velocity.iter().zip(cfg_joints(&self.cfg)))
                .enumerate()
            {
                ensure!(
                    sp == x,
                    fail("SR-6", "set-point differs from the position after enable").on(i).got(f(*sp)).bound(f(*x))
                );
                ensure!(
                    v.abs() <= S::from_f32(j.max_velocity),
                    fail("SR-6", "enabled while the axis moves above vmax")
                        .on(i)
                        .got(f(*v))
                        .bound(f64::from(j.max_velocity))
                );
            }
            if st == State::Operational {
                ensure!(out.status.homed == ALL, fail("SR-6", "Operational after enable but not every joint homed"));
            }
        }

        // SR-7, SR-29, SR-31: what starts a stop. At the command timeout
        // (exactly `timeout` ticks after the last accepted stream sample,
        // armed) the kernel either latches interrupted motion (a soft stop)
        // or holds an arm at rest at its target; a lost link may have
        // stopped it first. Nothing else starts a timeout stop or a hold.
        let stop_event = out.events.iter().any(|e| matches!(e, Event::SoftEstop { .. }));
        let timeout_stop =
            out.events.iter().any(|e| matches!(e, Event::SoftEstop { cause: StopCause::CommandTimeout { .. } }));
        let link_stop = ev_link_stop;
        let holding = ev_holding;
        let waited = self.since_accept.map(|t| t.saturating_add(1));
        let due = prev == State::Operational && self.prev_armed && waited == Some(self.timeout_ticks) && !accepted;
        let timing = |sr, what| fail(sr, what).got(waited.map_or(-1.0, f64::from)).bound(f64::from(self.timeout_ticks));
        if due {
            let n = [timeout_stop, holding, link_stop].iter().filter(|x| **x).count();
            ensure!(n == 1, timing("SR-29", "not exactly one of soft stop, hold, link stop at the command timeout"));
        } else {
            ensure!(!timeout_stop, timing("SR-7", "a soft stop other than at the command timeout"));
            ensure!(!holding, timing("SR-29", "Holding other than at the command timeout"));
        }
        // Moving or at rest, judged from the last tick (the kernel decides
        // before this tick's outputs): set-points at rest at their target
        // (unchanged for a tick, equal to it), outputs at or below the
        // holding speed. Unknown without the target (then not judged).
        let out_over = self.prev_out.iter().any(|v| f(*v).abs() > HOLD_SPEED * 1.001);
        let out_under = self.prev_out.iter().all(|v| f(*v).abs() <= HOLD_SPEED * 0.999);
        let at_target = target_now.map(|t| t == self.prev_setpoint);
        let surely_still = at_target == Some(true) && self.prev_sp_static == Some(true) && out_under;
        let surely_moving = out_over || at_target == Some(false) || self.prev_sp_static == Some(false);
        if holding {
            inc(&mut self.stats.holds);
            ensure!(!surely_moving, fail("SR-29", "Holding while a set-point or an output still moves"));
            ensure!(
                matches!(st, State::Operational | State::Fault) && !out.status.timeout_armed,
                fail("SR-29", "Holding did not stay Operational with the timeout disarmed")
            );
        }
        if timeout_stop {
            ensure!(!surely_still, fail("SR-29", "latched at the timeout with every joint at rest at its target"));
        }
        // SR-31: a lost link stops a moving arm, a homing run, and a stop
        // that was to end in homing, at once; an arm at rest holds.
        let eff_homing = prev == State::Homing || (homing_started && prev != State::Stopping);
        let eff_pending = (prev == State::Stopping && self.pending_home) || after_stop;
        let op = prev == State::Operational && !eff_homing && !eff_pending;
        if sense.link_lost && (eff_homing || eff_pending || (op && surely_moving)) {
            ensure!(link_stop, fail("SR-31", "link lost while moving or homing without a soft stop"));
        }
        if link_stop {
            inc(&mut self.stats.link_stops);
            ensure!(
                sense.link_lost && (eff_homing || eff_pending || (op && !surely_still)),
                fail("SR-31", "a link-loss stop without a lost link, or of an arm at rest")
            );
            // (A stop to home whose ramp ends in the same tick latches at once.)
            ensure!(
                matches!(st, State::Stopping | State::Fault) || (prev == State::Stopping && st == State::SoftEstop),
                fail("SR-31", "a link-loss stop did not start the ramp")
            );
            if eff_homing {
                ensure!(
                    out.status.homing == HomingStatus::Failed,
                    fail("SR-31", "homing interrupted by a lost link not reported failed (H3)")
                );
            }
        }
        // SR-7: the ramp never increases or reverses, steps at most vmax/N,
        // reaches zero in exactly N ticks and latches SoftEstop, or, after
        // `<HOME>` while moving (`HomingAfterStop`), starts homing.
        if st == State::Stopping && prev != State::Stopping {
            ensure!(
                timeout_stop || link_stop || (after_stop && prev == State::Operational),
                fail("SR-7", "Stopping entered without a soft stop or HomingAfterStop event")
            );
            ensure!(
                prev == State::Operational || link_stop,
                fail("SR-7", "Stopping entered from a state other than Operational")
            );
            // From Homing, or from a homing run that started and stopped
            // for a lost link within one tick (its `HomingStarted` is in
            // the same tick's events).
            self.stopping_from_homing = prev != State::Operational || homing_started;
        }
        if st == State::Stopping || (prev == State::Stopping && matches!(st, State::SoftEstop | State::Homing)) {
            if prev != State::Stopping {
                self.stopping_ticks = 0;
            }
            self.stopping_ticks = self.stopping_ticks.saturating_add(1);
            for (i, (a, b)) in out.act.velocity.iter().zip(self.prev_out.iter()).enumerate() {
                let (a, b) = (*a, *b);
                ensure!(a.abs() <= b.abs(), fail("SR-7", "soft-stop speed increased").on(i).got(f(a)).bound(f(b)));
                ensure!(
                    a == S::ZERO || (a > S::ZERO) == (b > S::ZERO),
                    fail("SR-7", "soft stop reversed").on(i).got(f(a)).bound(f(b))
                );
            }
            let over = first_step_over(&out.act.velocity, &self.prev_out, 1.001, &self.stop_step);
            if let Some((i, step, bound)) = over {
                return Err(fail("SR-7", "soft stop decelerates more than vmax/N in a tick")
                    .on(i)
                    .got(step)
                    .bound(bound));
            }
            match st {
                State::Stopping => ensure!(
                    self.stopping_ticks < self.stop_ticks,
                    fail("SR-7", "still Stopping after N ticks")
                        .got(f64::from(self.stopping_ticks))
                        .bound(f64::from(self.stop_ticks))
                ),
                State::Homing => {
                    ensure!(
                        self.pending_home && all_zero && homing_started,
                        fail("SR-7", "Stopping left for Homing without a pending HOME, zero output and HomingStarted")
                    );
                    ensure!(
                        self.stopping_ticks == self.stop_ticks,
                        fail("SR-7", "the stop before homing did not take exactly N ticks")
                            .got(f64::from(self.stopping_ticks))
                            .bound(f64::from(self.stop_ticks))
                    );
                }
                _ => {
                    ensure!(all_zero && ev_stopped, fail("SR-7", "ramp end without zero output and Stopped"))
                }
            }
        }
        if prev == State::Stopping
            && !matches!(st, State::Stopping | State::SoftEstop | State::Fault)
            && !(st == State::Homing && self.pending_home)
        {
            return Err(fail("SR-7", "left Stopping other than to SoftEstop, Fault, or Homing after a HOME"));
        }
        if ev_stopped {
            // The ramp can end in the tick a fault is detected: the fault
            // then takes the arm to Fault instead of SoftEstop (found by a
            // differential run, session 2).
            let faulted_now = st == State::Fault && n_faults > 0;
            ensure!(
                (st == State::SoftEstop || faulted_now) && prev == State::Stopping,
                fail("SR-7", "Stopped outside the end of a ramp")
            );
            // The ramp's ticks, from the SoftEstop event (k = 1) to the zero
            // (k = N). (The fault tick is not counted above when the fault wins.)
            let took = self.stopping_ticks.saturating_add(u32::from(faulted_now));
            ensure!(
                took == self.stop_ticks,
                fail("SR-7", "the ramp did not take exactly N ticks")
                    .got(f64::from(self.stopping_ticks))
                    .bound(f64::from(self.stop_ticks))
            );
        }
        if after_stop {
            inc(&mut self.stats.homes_after_stop);
            ensure!(
                prev == State::Operational && home_sent && accepted && matches!(st, State::Stopping | State::Fault),
                fail("SR-7", "HomingAfterStop other than for a HOME accepted while moving")
            );
            ensure!(!surely_still, fail("SR-7", "HOME stopped an arm at rest first (it must home at once)"));
        }
        if home_sent && accepted && prev == State::Operational && surely_moving && !link_stop {
            ensure!(after_stop, fail("SR-7", "HOME while moving started homing without a stop first"));
        }
        self.pending_home = match st {
            State::Stopping => (self.pending_home || after_stop) && !link_stop,
            _ => false,
        };
        let _ = stop_event;

        // SR-8: the timeout is armed only by an accepted stream sample (a
        // go-to completes without one), and disarmed by homing and enable.
        if out.status.timeout_armed && !self.prev_armed {
            ensure!(motion_accepted, fail("SR-8", "timeout armed without an accepted motion command"));
        }
        if homing_started || after_stop {
            ensure!(!out.status.timeout_armed, fail("SR-8", "timeout armed after homing started or was requested"));
        }
        if let (Some(t), State::Operational) = (accepted_target, st) {
            let want = t.kind == MotionKind::Stream;
            ensure!(
                out.status.timeout_armed == want,
                fail(
                    "SR-8",
                    if want {
                        "an accepted stream sample did not arm the timeout"
                    } else {
                        "an accepted go-to armed the timeout"
                    }
                )
            );
        }
        self.since_accept = if motion_accepted { Some(0) } else { self.since_accept.map(|t| t.saturating_add(1)) };

        // SR-9: a speed estimate above the runaway threshold is a fault.
        for (i, (v, j)) in out.status.velocity.iter().zip(cfg_joints(&self.cfg)).enumerate() {
            if v.abs() > S::from_f32(j.runaway_velocity) {
                ensure!(
                    st == State::Fault,
                    fail("SR-9", "estimate above the runaway threshold without a fault")
                        .on(i)
                        .got(f(*v))
                        .bound(f64::from(j.runaway_velocity))
                );
            }
        }

        // SR-10: a pressed switch outside homing is a fault; during homing,
        // on a homed axis at rest.
        let pressed = sense.limits & ALL;
        if pressed != 0 {
            ensure!(
                !matches!(st, State::Operational | State::Stopping | State::SoftEstop),
                fail("SR-10", "a switch pressed without a fault").got(f64::from(pressed))
            );
        }
        if let (State::Homing, Some(ph)) = (st, phases) {
            for (i, p) in ph.iter().enumerate() {
                let still_homed = out.status.homed & bit(i) != 0 && !p.is_moving();
                ensure!(
                    !(pressed & bit(i) != 0 && still_homed),
                    fail("SR-10", "switch pressed on a homed axis at rest during homing").on(i)
                );
            }
        }

        // SR-11: more than `encoder_invalid_limit` invalid samples in a row
        // (outside Boot) is a fault, and that joint must be homed again.
        let limit = self.cfg.encoder_invalid_limit;
        for (i, (streak, e)) in self.lost_streak.iter_mut().zip(sense.encoders.iter()).enumerate() {
            *streak = if is_count(e) { 0 } else { streak.saturating_add(1) };
            if *streak > limit && prev != State::Boot {
                ensure!(
                    st == State::Fault,
                    fail("SR-11", "encoder invalid too long without a fault")
                        .on(i)
                        .got(f64::from(*streak))
                        .bound(f64::from(limit))
                );
                self.must_rehome |= bit(i);
            }
        }
        for e in out.events.iter() {
            if let Event::HomingStarted { mask } = e {
                self.must_rehome &= !mask;
            }
        }
        if st != State::Fault {
            ensure!(
                out.status.homed & self.must_rehome == 0,
                fail("SR-11", "a joint counted as homed after losing its encoder")
                    .got(f64::from(out.status.homed & self.must_rehome))
            );
        }

        // SR-13, SR-16: during homing, an axis moves only in a moving phase,
        // and only after every axis of the earlier groups is homed and still.
        if st == State::Homing {
            for (i, (v, deps)) in out.act.velocity.iter().zip(SEED_DEPENDENCIES.iter()).enumerate() {
                let deps = *deps;
                let moving = *v != S::ZERO;
                let phase_moving = phases.and_then(|p| p.get(i)).is_some_and(|p| p.is_moving());
                if moving && phases.is_some() {
                    ensure!(phase_moving, fail("SR-16", "axis moves in a homing phase that does not move").on(i));
                }
                if moving || phase_moving {
                    ensure!(
                        out.status.homed & deps == deps,
                        fail("SR-13", "axis moves in homing with earlier joints unhomed")
                            .on(i)
                            .got(f64::from(deps & !out.status.homed))
                    );
                    if let Some(ph) = phases {
                        for (d, p) in ph.iter().enumerate() {
                            ensure!(
                                deps & bit(d) == 0 || !p.is_moving(),
                                fail("SR-13", "axis moves while an earlier axis is still homing").on(i).got(d as f64)
                            );
                        }
                    }
                }
            }
        } else if let Some(ph) = phases {
            ensure!(ph.iter().all(|p| !p.is_moving()), fail("SR-16", "a homing phase moves outside Homing"));
        }
        // SR-13: per-joint homing is refused while its dependencies are unhomed.
        if let (Some(Sent::HomeJoint(j)), true) = (sent, accepted) {
            let Some(deps) = SEED_DEPENDENCIES.get(usize::from(*j)) else {
                return Err(fail("SR-13", "HomeJoint of a joint that does not exist accepted").got(f64::from(*j)));
            };
            // `homed` before the tick: sensing does not change it.
            ensure!(
                self.prev_homed & deps == *deps,
                fail("SR-13", "HomeJoint accepted with its dependencies unhomed").on(usize::from(*j))
            );
        }

        // SR-14: a homing run on a clean plant zeroes every homed axis at its
        // true angle.
        if let Some(p) = plant.filter(|p| p.clean_homing) {
            for e in out.events.iter() {
                if let Event::HomingDone { mask } = e {
                    for (i, (x, q)) in out.status.position.iter().zip(p.q.iter()).enumerate() {
                        if mask & bit(i) != 0 && out.status.homed & bit(i) != 0 {
                            let err = f(*x) - q;
                            // The estimate may still lag the release move by
                            // a few mrad (alpha-beta transient); a zero taken
                            // from anything but the reading at the switch is
                            // off by far more.
                            ensure!(
                                err.abs() < 2e-2,
                                fail("SR-14", "homed off the true angle").on(i).got(err).bound(2e-2)
                            );
                        }
                    }
                }
            }
        }

        // SR-15: motion is accepted only in Operational. SR-17: accepted
        // targets are finite and within the limits, and a clearly valid
        // target in Operational is accepted (or, a stream sample, refused
        // as a jump: SR-30). SR-30: a stream sample is accepted only within
        // one segment's travel of the set-point or of the previous target,
        // and refused as a jump only beyond it.
        if matches!(rejected, Some((_, Reject::Internal))) {
            return Err(fail("SR-15", "a request refused for an internal limit (Reject::Internal)"));
        }
        if let Some(Sent::Motion(t)) = sent {
            if motion_accepted {
                inc(&mut self.stats.accepted);
                ensure!(prev == State::Operational, fail("SR-15", "motion accepted outside Operational"));
            }
            if let Some(t) = t {
                let verdict = validity(&self.cfg, t);
                let reason = rejected.map(|r| r.1);
                // (axis, distance, bound) of each axis, when the previous
                // target is known.
                let jump = |i: usize| -> Option<(f64, (f64, f64))> {
                    let (j, p) = (self.cfg.joints.get(i)?, f(*t.position.get(i)?));
                    let from_sp = (p - f(*self.prev_setpoint.get(i)?)).abs();
                    let from_last = (p - f(*old_target?.get(i)?)).abs();
                    Some((from_sp.min(from_last), max_jump(&self.cfg, j)))
                };
                let stream = t.kind == MotionKind::Stream;
                if motion_accepted {
                    ensure!(verdict != Validity::Invalid, fail("SR-17", "invalid target accepted"));
                    if !stream {
                        inc(&mut self.stats.goto_accepted);
                    }
                    for i in 0..AXES {
                        if let (true, Some((d, (_, b)))) = (stream, jump(i)) {
                            ensure!(
                                d <= b + JUMP_SLACK,
                                fail("SR-30", "stream sample beyond a segment's travel accepted").on(i).got(d).bound(b)
                            );
                        }
                    }
                } else if let Some(Reject::TargetJump { axis }) = reason {
                    inc(&mut self.stats.target_jumps);
                    let i = usize::from(axis);
                    ensure!(
                        stream && prev == State::Operational && verdict != Validity::Invalid,
                        fail("SR-30", "TargetJump for a go-to, an invalid target, or outside Operational").on(i)
                    );
                    if let Some((d, (b, _))) = jump(i) {
                        ensure!(
                            d >= b - JUMP_SLACK,
                            fail("SR-30", "stream sample within a segment's travel refused as a jump")
                                .on(i)
                                .got(d)
                                .bound(b)
                        );
                    }
                } else if prev == State::Operational && verdict == Validity::Valid {
                    return Err(fail("SR-17", "valid target rejected in Operational"));
                }
            }
        }

        // SR-18: in Operational the set-point moves at most vmax/tick_hz per tick.
        if st == State::Operational && prev == State::Operational {
            let over = first_step_over(&out.status.setpoint, &self.prev_setpoint, 1.001, &self.vel_per_tick);
            if let Some((i, step, bound)) = over {
                return Err(fail("SR-18", "set-point stepped more than vmax/tick_hz").on(i).got(step).bound(bound));
            }
        }

        // SR-27: set-points are acceleration-limited, never pass a target
        // they approach, and stay inside the joint limits (or between
        // them and where Operational was entered).
        self.check_setpoints(out, prev, old_target, target_now, accepted_target.is_some(), &fail)?;

        // SR-19: in Operational and Stopping every (homed) axis is within its
        // limits plus the margin; Stopping after a lost link in homing has
        // the aborted run's joints unhomed.
        if matches!(st, State::Operational | State::Stopping) {
            ensure!(
                out.status.homed == ALL || (st == State::Stopping && self.stopping_from_homing),
                fail("SR-19", "Operational or Stopping with a joint unhomed")
            );
            let m = self.cfg.position_margin;
            for (i, (x, j)) in out.status.position.iter().zip(cfg_joints(&self.cfg)).enumerate() {
                if out.status.homed & bit(i) == 0 {
                    continue;
                }
                let (lo, hi) = (j.limit_min - m, j.limit_max + m);
                ensure!(
                    *x >= S::from_f32(lo) && *x <= S::from_f32(hi),
                    fail("SR-19", "axis outside its limits plus margin without a fault")
                        .on(i)
                        .got(f(*x))
                        .bound(f64::from(if f(*x) < 0.0 { lo } else { hi }))
                );
            }
        }
        // SR-19, with the plant's facts: after a resync inside the limits
        // with nothing injected since, every homed joint stays within its
        // limits plus `ArmConfig::overrun_bound` (soft-stop overrun plus the
        // following error), measured at its true angle (plus 2 mrad for
        // the encoder's quantisation and the estimate's lag).
        if let Some(p) = plant {
            let resync =
                enabled.is_some() || homing_started || out.events.iter().any(|e| matches!(e, Event::HomingDone { .. }));
            if resync {
                self.dirty = false;
                self.inside_at_resync =
                    out.status.position.iter().zip(cfg_joints(&self.cfg)).enumerate().all(|(i, (x, j))| {
                        out.status.homed & bit(i) == 0
                            || (f(*x) >= f64::from(j.limit_min) && f(*x) <= f64::from(j.limit_max))
                    });
            }
            self.dirty |= p.disturbed;
            if matches!(st, State::Operational | State::Stopping) && !self.dirty && self.inside_at_resync {
                for (i, (q, j)) in p.q.iter().zip(cfg_joints(&self.cfg)).enumerate() {
                    if out.status.homed & bit(i) == 0 {
                        continue;
                    }
                    let ob = f64::from(self.cfg.overrun_bound(j)) + 2e-3;
                    let (lo, hi) = (f64::from(j.limit_min) - ob, f64::from(j.limit_max) + ob);
                    ensure!(
                        *q >= lo && *q <= hi,
                        fail("SR-19", "joint beyond its limits plus the overrun bound on a clean plant")
                            .on(i)
                            .got(*q)
                            .bound(if *q < 0.0 { lo } else { hi })
                    );
                }
            }
        }

        // SR-28: following error. With the plant's facts: a
        // FollowingError fault only after something was injected since the
        // set-points were resynchronised; and a joint whose motor is stalled
        // or reversed, with its set-point farther than the bound (plus
        // `FE_LIVENESS_SLACK`) from its true angle for longer than the
        // bound's time (plus slack) in Operational, has faulted by then.
        if let Some(p) = plant {
            if let (true, Some(FaultReason::FollowingError { axis })) = (n_faults > 0, fault_event) {
                ensure!(
                    self.dirty,
                    fail("SR-28", "following-error fault with nothing injected since the last resync")
                        .on(usize::from(axis))
                );
            }
            let fe = f64::from(self.cfg.following_error) + FE_LIVENESS_SLACK.0;
            let limit = ms_to_ticks(self.cfg.following_error_ms, self.cfg.tick_hz).saturating_add(FE_LIVENESS_SLACK.1);
            for (i, ((n, sp), q)) in self.fe_over.iter_mut().zip(out.status.setpoint.iter()).zip(p.q.iter()).enumerate()
            {
                let broken = p.broken_motor & bit(i) != 0;
                let over = st == State::Operational && prev == State::Operational && broken && (f(*sp) - q).abs() > fe;
                *n = if over { n.saturating_add(1) } else { 0 };
                ensure!(
                    *n <= limit,
                    fail("SR-28", "a stalled or reversed joint off its set-point without a fault")
                        .on(i)
                        .got(f64::from(*n))
                        .bound(f64::from(limit))
                );
            }
        }
        // SR-28: homing travel. The fast seek moves at most
        // `homing.max_travel` from where it began, every other phase at most
        // `JointConfig::homing_phase_travel()`; beyond, the kernel has
        // faulted (HomingTravel) by that tick.
        match (st, phases) {
            (State::Homing, Some(ph)) => {
                let travel = self.fast_seek_travel.iter().zip(self.phase_travel.iter());
                for (i, (((p, last), origin), (x, (fast, other)))) in ph
                    .iter()
                    .zip(self.home_phase.iter())
                    .zip(self.home_origin.iter_mut())
                    .zip(out.status.position.iter().zip(travel))
                    .enumerate()
                {
                    if *p != *last || prev != State::Homing {
                        *origin = f(*x);
                    } else if p.is_moving() {
                        let bound = if *p == Phase::FastSeek { *fast } else { *other };
                        let d = (f(*x) - *origin).abs();
                        ensure!(
                            d <= bound * 1.0001 + 1e-5,
                            fail("SR-28", "homing phase travelled beyond its bound without a fault")
                                .on(i)
                                .got(d)
                                .bound(bound)
                        );
                    }
                }
                self.home_phase = *ph;
            }
            _ => self.home_phase = [Phase::Idle; AXES],
        }

        // SR-25: in Operational and Homing the output changes by at most
        // max_acceleration / tick_hz per tick; in Homing a stop to zero at
        // the axis's switch may be immediate (a stop on a fault is the
        // Fault state's, SR-4). Its first tick may add the holding speed
        // (`HOLD_SPEED`) of an arm at rest in Operational.
        if st == State::Operational {
            let over = first_step_over(&out.act.velocity, &self.prev_out, 1.0001, &self.acc_per_tick);
            if let Some((i, dv, bound)) = over {
                return Err(fail("SR-25", "output stepped more than max_acceleration/tick_hz")
                    .on(i)
                    .got(dv)
                    .bound(bound));
            }
        }
        if st == State::Homing {
            for (i, ((a, b), dv)) in
                out.act.velocity.iter().zip(self.prev_out.iter()).zip(self.acc_per_tick.iter()).enumerate()
            {
                let (step, bound) = ((f(*a) - f(*b)).abs(), *dv);
                let at_switch = *a == S::ZERO && sense.limits & bit(i) != 0;
                // Homing starts from rest, and rest allows a holding output.
                let from_rest = if prev == State::Homing { 0.0 } else { HOLD_SPEED };
                ensure!(
                    step <= bound * 1.0001 + 1e-6 + from_rest || at_switch,
                    fail("SR-25", "homing output stepped more than max_acceleration/tick_hz")
                        .on(i)
                        .got(step)
                        .bound(bound)
                );
            }
        }
        Ok(())
    }

    /// SR-27: set-points in Operational (the set-point velocity is the
    /// difference of consecutive set-points times `tick_hz`, computed here):
    ///
    /// - its change per tick is at most `dv = max_acceleration / tick_hz`
    ///   plus the landing allowance `max(dv / 256, 1e-4)` rad/s, plus the
    ///   rounding of the set-points themselves: 4 units in the last place
    ///   of the larger set-point (f32; at least one I8F24 LSB) times
    ///   `tick_hz` (1.9e-3 rad/s at |x| = 6.3, 1000 Hz; 2.4e-4 at |x| < 1);
    /// - it never crosses the target it moves toward in a tick, and once at
    ///   its (unchanged) target it stays there; given a target inside its
    ///   braking distance ahead (below), it goes at most the braking
    ///   distance from the speed limit (`vmax^2 / 2a' + 2 vmax / tick_hz`
    ///   from where it was) until the next target;
    /// - it stays inside the joint limits, or between them and the
    ///   set-point where Operational was entered (1e-5 rad plus rounding).
    ///
    /// Not judged: the tick Operational is entered (the set-points are
    /// resynchronised to the estimates, at rest: the next tick's change is
    /// judged from zero). For an axis given a target inside its braking
    /// distance in its direction of motion (from its measured set-point
    /// velocity `v`: closer than `v^2 / 2a' + 2 |v| / tick_hz` with
    /// `a' = PROFILE_DECEL_MIN * max_acceleration`) "never past the target"
    /// cannot hold together with the acceleration bound: the acceleration
    /// bound is kept, the passing is bounded as above, until its set-point
    /// has rested at its target for `vmax / dv + 2` ticks; each such target
    /// is counted in [`Stats::infeasible_retargets`].
    fn check_setpoints(
        &mut self,
        out: &TickOutput<S>,
        prev: State,
        old_target: Option<[S; AXES]>,
        target_now: Option<[S; AXES]>,
        retargeted: bool,
        fail: &dyn Fn(&'static str, &'static str) -> Violation,
    ) -> Checked {
        let sp = out.status.setpoint;
        if out.status.state != State::Operational {
            self.sp_vel = None;
            self.prev_sp_static = None;
            self.target = None;
            self.infeasible = 0;
            return Ok(());
        }
        if prev != State::Operational {
            // Entered with the set-points resynchronised: at rest, each
            // its own target.
            self.sp_vel = Some([0.0; AXES]);
            self.prev_sp_static = Some(true);
            self.target = Some(sp);
            self.anchor = sp.map(f);
            self.infeasible = 0;
            self.rest_ticks = [0; AXES];
            self.reach = [None; AXES];
            return Ok(());
        }
        let hz = f64::from(self.cfg.tick_hz);
        let prev_vel = self.sp_vel;
        let mut vel = [0.0f64; AXES];
        let mut still = true;
        let axes = vel
            .iter_mut()
            .zip(sp.iter().zip(self.prev_setpoint.iter()))
            .zip(self.cfg.joints.iter().zip(self.anchor.iter().zip(self.acc_per_tick.iter())))
            .zip(self.rest_ticks.iter_mut().zip(self.reach.iter_mut()));
        for (i, (((v, (a, b)), (j, (anchor, dv))), (rest, reach))) in axes.enumerate() {
            let (a, b) = (*a, *b);
            let (fa, fb) = (f(a), f(b));
            *v = (fa - fb) * hz;
            if a == b {
                *rest = rest.saturating_add(1);
            } else {
                *rest = 0;
                still = false;
            }
            let amax = f64::from(j.max_acceleration);
            let dv = *dv;
            let ulp = ulp_f32(fa.abs().max(fb.abs())).max(FX_LSB);
            let tol = 1e-5 + 2.0 * ulp;
            let pv = prev_vel.and_then(|p| p.get(i).copied());
            let t_new = target_now.and_then(|t| t.get(i).copied());
            let t_old = old_target.and_then(|t| t.get(i).copied());
            let changed = retargeted && t_new != t_old;
            // A target inside the braking distance, ahead: the set-point
            // may overshoot it, by at most the braking distance.
            if changed {
                *reach = None;
            }
            if let (true, Some(pv), Some(t)) = (changed, pv, t_new) {
                let d = f(t) - fb;
                let a_min = amax * PROFILE_DECEL_MIN;
                let brake = |v: f64| v * v / (2.0 * a_min) + 2.0 * v.abs() / hz;
                if pv * d > 0.0 && d.abs() < brake(pv) {
                    // Bounded by the braking distance from vmax: the
                    // profile's own velocity can exceed the measured one
                    // (a set-point held at a target keeps its velocity),
                    // and a tighter bound from the measured velocity was
                    // exceeded by 0.04 mrad in a replay not yet explained.
                    let v = f64::from(j.max_velocity);
                    inc(&mut self.stats.infeasible_retargets);
                    self.infeasible |= bit(i);
                    let dir = if pv > 0.0 { 1.0 } else { -1.0 };
                    *reach = Some((fb + dir * brake(v), dir));
                }
            }
            if let Some((r, dir)) = *reach {
                ensure_ok((fa - r) * dir <= tol, || {
                    fail("SR-27", "set-point overshot a target inside its braking distance by more than it")
                        .on(i)
                        .got(fa)
                        .bound(r)
                })?;
            }
            if let Some(pv) = pv {
                let bound = dv + (dv / 256.0).max(1e-4) + 4.0 * ulp * hz;
                let change = (*v - pv).abs();
                ensure_ok(change <= bound, || {
                    fail("SR-27", "set-point velocity changed more than max_acceleration/tick_hz")
                        .on(i)
                        .got(change)
                        .bound(bound)
                })?;
            }
            let lo = f64::from(j.limit_min).min(*anchor) - tol;
            let hi = f64::from(j.limit_max).max(*anchor) + tol;
            ensure_ok(fa >= lo && fa <= hi, || {
                fail("SR-27", "set-point outside the joint limits").on(i).got(fa).bound(if fa < lo { lo } else { hi })
            })?;
            if let Some(t) = t_new {
                let ft = f(t);
                let (pa, pb) = (fb - ft, fa - ft);
                let crossed = (pa > 0.0 && pb < -tol) || (pa < 0.0 && pb > tol);
                let left = b == t && a != t && !changed;
                ensure_ok(!(crossed || left) || self.infeasible & bit(i) != 0, || {
                    fail("SR-27", "set-point passed the target it approached").on(i).got(fa).bound(ft)
                })?;
                if a == t && f64::from(*rest) > f64::from(j.max_velocity) / dv + 2.0 {
                    self.infeasible &= !bit(i);
                    *reach = None;
                }
            }
        }
        self.sp_vel = Some(vel);
        self.prev_sp_static = Some(still);
        self.target = target_now;
        Ok(())
    }

    /// SR-2: every output finite and within the joint's max velocity; the
    /// step rate within the step generator's range and the joint's max
    /// velocity in steps, with the velocity's sign.
    fn check_outputs(&self, out: &TickOutput<S>, fail: &dyn Fn(&'static str, &'static str) -> Violation) -> Checked {
        let cfg = &self.cfg;
        let joints = cfg_joints(cfg).zip(self.rate_max.iter());
        for (i, ((j, rmax), (v, r))) in joints.zip(out.act.velocity.iter().zip(out.act.step_rate.iter())).enumerate() {
            let (v, r, rmax) = (*v, *r, *rmax);
            let vmax = f64::from(j.max_velocity);
            if !(v.is_finite() && v.abs() <= S::from_f32(j.max_velocity)) {
                return Err(fail("SR-2", "output not finite or above max velocity").on(i).got(f(v)).bound(vmax));
            }
            let rate = f64::from(r).abs();
            if r.unsigned_abs() > cfg.max_step_rate {
                return Err(fail("SR-2", "step rate above the step generator's limit")
                    .on(i)
                    .got(rate)
                    .bound(f64::from(cfg.max_step_rate)));
            }
            if rate > rmax {
                return Err(fail("SR-2", "step rate above the joint's max velocity").on(i).got(rate).bound(rmax));
            }
            let vf = v.to_f32();
            let signed_ok = if vf == 0.0 { r == 0 } else { r == 0 || (vf > 0.0) == (r > 0) };
            if !signed_ok {
                return Err(fail("SR-2", "step rate against the velocity's sign").on(i).got(f64::from(r)));
            }
        }
        Ok(())
    }
}

/// The first axis whose value moved between two ticks by more than its
/// per-tick bound `limit[axis]` (times `rel`, plus 1e-6 of slack; a NaN
/// step is over): (axis, step, bound).
fn first_step_over<S: Scalar>(
    now: &[S; AXES],
    before: &[S; AXES],
    rel: f64,
    limit: &[f64; AXES],
) -> Option<(usize, f64, f64)> {
    for (i, ((a, b), bound)) in now.iter().zip(before.iter()).zip(limit.iter()).enumerate() {
        let step = (f(*a) - f(*b)).abs();
        let bound = *bound;
        let within = step <= bound * rel + 1e-6;
        if !within {
            return Some((i, step, bound));
        }
    }
    None
}

/// `Err(v())` unless `ok` (the violation is built only when it is one).
#[inline(always)]
fn ensure_ok(ok: bool, v: impl FnOnce() -> Violation) -> Checked {
    if ok {
        Ok(())
    } else {
        Err(v())
    }
}

/// One LSB of the fixed-point variant (I8F24).
const FX_LSB: f64 = 1.0 / 16_777_216.0;

/// The spacing of `f32` values at magnitude `m`.
fn ulp_f32(m: f64) -> f64 {
    let x = m.abs() as f32;
    f64::from(x.next_up() - x)
}

/// SR-30's slack (rad) on the jump distance: rounding of the kernel's
/// distances and of its bound (f32 at |x| < 16: 2e-6; I8F24: 6e-8), with
/// a wide margin.
pub const JUMP_SLACK: f64 = 1e-4;

/// SR-30: how far a stream sample may be from the set-point (or the
/// previous target): one longest segment at the speed limit, the braking
/// distance from it, and the configured tolerance (rad), as a band: the
/// set-points brake at `max_acceleration` at most and at
/// [`PROFILE_DECEL_MIN`] of it at least (the kernel may use a share of the
/// output's limit), so the kernel's bound lies in `(low, high)`: a sample
/// farther than `high` must be refused, one nearer than `low` accepted.
pub fn max_jump(cfg: &ArmConfig, j: &kernel::config::JointConfig) -> (f64, f64) {
    let vmax = f64::from(j.max_velocity);
    let a = f64::from(j.max_acceleration);
    let base = vmax * f64::from(cfg.segment_max_ms) / 1000.0 + f64::from(cfg.target_jump_tolerance);
    (base + vmax * vmax / (2.0 * a), base + vmax * vmax / (2.0 * a * PROFILE_DECEL_MIN))
}

fn cfg_joints(cfg: &ArmConfig) -> core::slice::Iter<'_, kernel::config::JointConfig> {
    cfg.joints.iter()
}

#[cfg(test)]
mod tests;
