//! What the monitor is told about a tick ([`Sent`], [`PlantFacts`]) and
//! what it derives from that once per tick ([`TickFacts`]) for every check.

use kernel::config::AXES;
use kernel::homing::Phase;
use kernel::{
    Event, FaultReason, MotionTarget, Reject, Request, RequestKind, Scalar, Sense, State, StopCause, TickOutput,
};

use crate::violation::{Sr, Violation};
use crate::{f, is_count, Monitor, ALL, HOLD_SPEED};

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

/// One tick as the checks see it: the inputs handed to
/// [`Monitor::check`] and the facts derived from them and from the
/// monitor's memory at the start of the tick, computed once.
pub(crate) struct TickFacts<'a, S> {
    /// The sensors handed to the kernel.
    pub sense: &'a Sense,
    /// The request handed to the kernel.
    pub sent: Option<&'a Sent<S>>,
    /// The kernel's output.
    pub out: &'a TickOutput<S>,
    /// The kernel's homing phases after the tick, when known.
    pub phases: Option<&'a [Phase; AXES]>,
    /// The test plant's facts, when known.
    pub plant: Option<&'a PlantFacts>,
    /// The state after the tick.
    pub st: State,
    /// The state before the tick.
    pub prev: State,
    /// Events of the tick: `Ready`, `HomingAfterStop`, a soft stop for a
    /// lost link, `Holding`, `Stopped`, a soft stop for the command
    /// timeout, `HomingStarted`, `HomingDone`.
    pub ev_ready: bool,
    pub ev_after_stop: bool,
    pub link_stop: bool,
    pub holding: bool,
    pub ev_stopped: bool,
    pub timeout_stop: bool,
    pub homing_started: bool,
    pub homing_done: bool,
    /// The refusal of this tick's request, if it was refused.
    pub rejected: Option<(RequestKind, Reject)>,
    /// A request was sent and not refused.
    pub accepted: bool,
    /// An accepted motion request, and its target when known.
    pub motion_accepted: bool,
    pub accepted_target: Option<MotionTarget<S>>,
    /// `<HOME>` or `<HOMEn>` was sent.
    pub home_sent: bool,
    /// `<ENABLE>` was sent; the state it led to (`Event::Enabled`).
    pub enable_sent: bool,
    pub enabled: Option<State>,
    /// Fault events of the tick, and the first one's reason.
    pub n_faults: u32,
    pub fault_event: Option<FaultReason>,
    /// Every output (velocity and step rate) is zero.
    pub all_zero: bool,
    /// The target the set-points moved toward before this tick, and the
    /// one they move toward in it (this tick's accepted target, else the
    /// last one), when known.
    pub old_target: Option<[S; AXES]>,
    pub target_now: Option<[S; AXES]>,
    /// A cause of SR-6 in this tick's sensors: a hardware fault, a homed
    /// joint's pressed switch (an unhomed joint's is its homing input), an
    /// encoder without a count.
    pub sensed_cause: bool,
    /// SR-7, SR-29, SR-31: moving or at rest, judged from the last tick
    /// (the kernel decides before this tick's outputs): set-points at rest
    /// at their target (unchanged for a tick, equal to it), outputs at or
    /// below the holding speed. Unknown without the target (then neither).
    pub surely_still: bool,
    pub surely_moving: bool,
    /// SR-29: the set-points alone, at rest on their targets or not (what
    /// was asked decides hold or latch, not the outputs' residual).
    pub sp_still: bool,
    pub sp_moving: bool,
    /// SR-30: ticks since the last accepted motion, as before this tick
    /// (`u32::MAX` when none), and the set-points' velocity over the tick
    /// before (rad/s), when known.
    pub gap: u32,
    pub prev_sp_vel: Option<[f64; AXES]>,
}

impl<'a, S: Scalar> TickFacts<'a, S> {
    /// The facts of one tick, from its inputs and `mon`'s memory before it.
    pub fn new(
        mon: &Monitor<S>,
        sense: &'a Sense,
        sent: Option<&'a Sent<S>>,
        out: &'a TickOutput<S>,
        phases: Option<&'a [Phase; AXES]>,
        plant: Option<&'a PlantFacts>,
    ) -> Self {
        let mut t = TickFacts {
            sense,
            sent,
            out,
            phases,
            plant,
            st: out.status.state,
            prev: mon.prev_state,
            ev_ready: false,
            ev_after_stop: false,
            link_stop: false,
            holding: false,
            ev_stopped: false,
            timeout_stop: false,
            homing_started: false,
            homing_done: false,
            rejected: None,
            accepted: false,
            motion_accepted: false,
            accepted_target: None,
            home_sent: matches!(sent, Some(Sent::Home | Sent::HomeJoint(_))),
            enable_sent: matches!(sent, Some(Sent::Enable)),
            enabled: None,
            n_faults: 0,
            fault_event: None,
            all_zero: out.act.velocity.iter().all(|v| *v == S::ZERO) && out.act.step_rate.iter().all(|r| *r == 0),
            old_target: mon.target,
            target_now: None,
            sensed_cause: sense.hardware_fault.is_some()
                || sense.limits & out.status.homed & ALL != 0
                || !sense.encoders.iter().all(is_count),
            surely_still: false,
            surely_moving: false,
            sp_still: false,
            sp_moving: false,
            gap: mon.since_accept.map_or(u32::MAX, |n| n.saturating_add(1)),
            prev_sp_vel: mon.sp_vel,
        };
        for e in out.events.iter() {
            match e {
                Event::Ready => t.ev_ready = true,
                Event::HomingAfterStop => t.ev_after_stop = true,
                Event::SoftEstop { cause: StopCause::LinkLost } => t.link_stop = true,
                Event::SoftEstop { cause: StopCause::CommandTimeout { .. } } => t.timeout_stop = true,
                Event::Holding => t.holding = true,
                Event::Stopped => t.ev_stopped = true,
                Event::HomingStarted { .. } => t.homing_started = true,
                Event::HomingDone { .. } => t.homing_done = true,
                Event::Rejected { request, reason } => {
                    t.rejected = t.rejected.or(Some((*request, *reason)));
                }
                Event::Fault(r) => {
                    t.n_faults = t.n_faults.saturating_add(1);
                    t.fault_event = t.fault_event.or(Some(*r));
                }
                Event::Enabled(s) => t.enabled = t.enabled.or(Some(*s)),
                _ => {}
            }
        }
        t.accepted = sent.is_some() && t.rejected.is_none();
        t.motion_accepted = t.accepted && matches!(sent, Some(Sent::Motion(_)));
        t.accepted_target = match sent {
            Some(Sent::Motion(Some(m))) if t.motion_accepted => Some(*m),
            _ => None,
        };
        t.target_now = if t.motion_accepted { t.accepted_target.map(|m| m.position) } else { t.old_target };
        let out_over = mon.prev_out.iter().any(|v| f(*v).abs() > HOLD_SPEED * 1.001);
        let out_under = mon.prev_out.iter().all(|v| f(*v).abs() <= HOLD_SPEED * 0.999);
        let at_target = t.target_now.map(|m| m == mon.prev_setpoint);
        t.sp_still = at_target == Some(true) && mon.prev_sp_static == Some(true);
        t.sp_moving = at_target == Some(false) || mon.prev_sp_static == Some(false);
        t.surely_still = t.sp_still && out_under;
        t.surely_moving = out_over || t.sp_moving;
        t
    }

    /// A violation of `sr` in this tick (no axis, value or bound yet).
    pub fn fail(&self, sr: Sr, what: &'static str) -> Violation {
        Violation { sr, axis: None, what, got: None, bound: None, tick: self.out.status.tick, state: self.st }
    }
}
