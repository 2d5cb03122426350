//! The tick: sense -> estimate -> supervise -> act, for all six axes.
//!
//! This file holds the [`Kernel`] itself and its one entry point,
//! [`Kernel::tick_into`] (which [`Kernel::tick`] wraps, adding the
//! status), which runs the steps in a fixed order. The steps live
//! in submodules along the kernel's seams:
//!
//! - [`params`]: every constant, derived once from the configuration
//!   (`Params`, `AxisParams`, [`TargetLimits`]);
//! - [`axis`]: the per-axis pipeline: sense, estimate, control (`Axis`);
//! - [`intake`]: command intake: one request per tick, validated, applied;
//! - [`homing_seq`]: the homing sequencer glue: groups, zero capture, end
//!   of a run;
//! - [`supervisor`]: the state machine and the fault checks, with every
//!   change of mode in one function, `Kernel::transition`;
//! - [`invariant`]: the state invariant every reachable state satisfies,
//!   and (feature `proof-states`) kernels built in any state satisfying it.

mod axis;
mod homing_seq;
mod intake;
mod invariant;
mod params;
mod supervisor;

use self::axis::Axis;
#[cfg(feature = "proof-states")]
pub use self::invariant::{AxisSpec, SpecMode, StateSpec};
use self::params::Params;
pub use self::params::TargetLimits;
use self::supervisor::Mode;
use crate::config::{Validated, AXES};
use crate::homing::Phase;
use crate::scalar::Scalar;
use crate::types::*;

/// Bit of axis `i` (0..=5) in a joint mask.
#[inline(always)]
pub(crate) const fn bit(i: usize) -> u8 {
    1u8.wrapping_shl(i as u32)
}

const ALL: u8 = 0b11_1111;

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
    /// Ticks left to rest before a homing run moves (the settle time).
    home_wait: u32,
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

impl<S: Scalar> Kernel<S> {
    /// A kernel in [`State::Boot`], and the one [`Authority`] that can mint
    /// enable capabilities for it. Only a configuration that passed
    /// [`crate::config::check`] can be given ([`Validated`]; for the PAROL6,
    /// [`crate::config::PAROL6_VALIDATED`]).
    ///
    /// Each call draws a fresh identity: the [`Authority`] of one kernel
    /// mints capabilities that every other kernel refuses
    /// ([`Reject::ForeignCapability`]).
    pub fn new(config: &Validated) -> (Self, Authority) {
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
            home_wait: 0,
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

    /// The latched fault, if any.
    pub fn fault(&self) -> Option<Fault> {
        self.fault
    }

    /// True while any set-point moves, or any output is above the holding
    /// speed (a joint holding its set-point keeps a few mrad/s of
    /// correction; `config::HOLD_SPEED`).
    pub fn moving(&self) -> bool {
        let hold = self.p.hold_speed;
        self.axes.iter().any(|a| !a.interp.at_rest()) || self.last_out.iter().any(|v| v.abs() > hold)
    }

    /// True when every set-point is at rest on its last accepted target:
    /// what was asked has arrived (the command timeout then holds, SR-29).
    pub fn setpoints_at_rest(&self) -> bool {
        self.axes.iter().all(|a| a.interp.at_rest())
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

    /// One control tick: sense, estimate, handle at most one request,
    /// supervise, and return the checked outputs for every axis, the
    /// status and the events. [`Kernel::tick_into`] with caller-owned
    /// storage and [`Kernel::status`].
    pub fn tick(&mut self, sense: &Sense, request: Option<Request<S>>) -> TickOutput<S> {
        let mut act = Actuation::zero();
        let mut events = Events::new();
        self.tick_into(sense, request, &mut act, &mut events);
        TickOutput { act, status: self.status(sense.limits), events }
    }

    /// One control tick, writing the checked outputs of every axis into
    /// `act` and this tick's events into `events` (cleared first). Every
    /// output is computed and checked before any is written. The status is
    /// built only on request ([`Kernel::status`]), when telemetry is due.
    pub fn tick_into(
        &mut self,
        sense: &Sense,
        request: Option<Request<S>>,
        act: &mut Actuation<S>,
        events: &mut Events,
    ) {
        self.tick = self.tick.wrapping_add(1);
        let cap = self.p.seg_max;
        self.since_target = self.since_target.map(|t| t.saturating_add(1).min(cap));
        events.clear();
        let mut fault: Option<FaultReason> = sense.hardware_fault.map(FaultReason::Hardware);
        let limits = sense.limits & ALL;

        // 1-2. Sense and estimate (axis.rs); leave Boot once every encoder
        // has been read (supervisor.rs).
        self.sense_and_estimate(sense, &mut fault);
        self.boot(&mut fault, events);

        // Requests are handled after estimation, so they see this tick's
        // measurements, and before supervision, so their effect is checked
        // (intake.rs).
        self.intake(request, sense, fault, events);

        // A lost host link stops a moving arm at once (supervisor.rs).
        if sense.link_lost {
            self.link_lost(events);
        }

        // 3. Supervise: candidate outputs for every axis, then the checks
        // (supervisor.rs).
        let mut out = self.supervise(limits, &mut fault, events);

        // Latch the first fault; every output is zero in the same tick.
        self.latch(fault, &mut out, events);

        // 4. Act: every output was computed and checked above.
        self.last_out = out;
        act.velocity = out;
        for ((r, v), p) in act.step_rate.iter_mut().zip(out.iter()).zip(self.p.axes.iter()) {
            *r = v.to_rate(p.k_rate);
        }
    }

    /// The status to report, given the limit switches sensed this tick.
    pub fn status(&self, limits: u8) -> Status<S> {
        Status {
            state: self.state(),
            homing: self.homing_status,
            fault: self.fault,
            position: self.axes.map(|a| a.obs.x),
            velocity: self.axes.map(|a| a.obs.v),
            setpoint: self.axes.map(|a| a.interp.setpoint()),
            limits: limits & ALL,
            homed: self.homed,
            timeout_armed: self.armed,
            tick: self.tick,
        }
    }

    /// Joint `axis`'s set-point profile (what its interpolator runs), or
    /// `None` for no such joint.
    pub fn profile(&self, axis: usize) -> Option<crate::interp::Profile<S>> {
        self.p.axes.get(axis).map(|a| a.profile)
    }

    /// Set-points to the measured positions, timeout disarmed, no history.
    /// Also called on entering Homing and Fault, where nothing reads them, so
    /// no stale set-point or interval survives a mode change.
    fn resync(&mut self) {
        for ax in self.axes.iter_mut() {
            ax.resync();
        }
        self.armed = false;
        self.since_cmd = 0;
        self.since_target = None;
    }
}

/// Hashes the state that determines the kernel's future behaviour, for model
/// checkers: everything but the constant parameters, the tick counter and
/// the fault's timestamp (both only label reports; no decision reads them),
/// and the run record of a homing axis in `Idle` or `Done`, which nothing
/// reads there (`AxisHoming`'s `Hash`).
/// Available when the scalar is hashable (the fixed-point variant).
impl<S: Scalar + core::hash::Hash> core::hash::Hash for Kernel<S> {
    fn hash<H: core::hash::Hasher>(&self, h: &mut H) {
        self.axes.hash(h);
        self.mode.hash(h);
        self.fault.map(|f| f.reason).hash(h);
        self.homing_status.hash(h);
        self.run_mask.hash(h);
        self.run_group.hash(h);
        self.home_wait.hash(h);
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
