//! What the monitor saw over a run ([`Stats`]), for coverage reports.

use kernel::{Event, FaultReason, Reject, Scalar, State, TickOutput};

use crate::{Monitor, PlantFacts};

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

pub(crate) fn inc(x: &mut u64) {
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

impl<S: Scalar> Monitor<S> {
    /// Counts the tick's state, events and motion.
    pub(crate) fn count(&mut self, out: &TickOutput<S>, plant: Option<&PlantFacts>) {
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
        if plant.is_some_and(|p| p.broken_motor != 0) {
            inc(&mut self.stats.broken_motor_ticks);
        }
    }
}
