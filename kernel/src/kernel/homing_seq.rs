//! Homing sequencer glue: which joints a run homes and in what order (the
//! groups of [`HOMING_GROUPS`], J6; J5, J4; J1, J2, J3), stepping each
//! active axis's [`crate::homing::AxisHoming`], capturing the zero, and
//! ending the run. The per-axis homing phases themselves are in
//! [`crate::homing`]; the mode changes go through `Kernel::transition`
//! (`Edge::StartHoming`, `Edge::HomingDone`) in the supervisor.

use super::supervisor::Edge;
use super::{bit, Kernel};
use crate::config::{AXES, HOMING_GROUPS};
use crate::homing::Phase;
use crate::scalar::Scalar;
use crate::types::{Event, FaultReason, HomingStatus, Reject, State};

impl<S: Scalar> Kernel<S> {
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

    /// A host's request to home the joints in `mask`: from Unhomed or an
    /// Operational arm at rest it starts at once; from a moving arm a
    /// controlled stop (the soft-stop ramp) comes first and homing starts
    /// when it ends; refused in every other state (a latch needs
    /// `<ENABLE>`).
    pub(super) fn start_homing(&mut self, mask: u8) -> Result<(), Reject> {
        if let Some(r) = self.homing_refusal() {
            return Err(r);
        }
        if self.state() == State::Operational && self.moving() {
            self.transition(Edge::StopToHome(mask));
            self.armed = false;
            self.since_cmd = 0;
            return Ok(());
        }
        self.begin_homing(mask);
        Ok(())
    }

    /// Starts the run (the mode allows it: checked by the caller).
    pub(super) fn begin_homing(&mut self, mask: u8) {
        let was_homed = self.homed;
        self.homed &= !mask;
        for (i, (ax, p)) in self.axes.iter_mut().zip(self.p.axes.iter()).enumerate() {
            ax.homing.reset(mask & bit(i) != 0);
            // A joint homed before this run knows where its switch is: its
            // fast seek may travel only to the switch plus the margin (the
            // configured bound, range + switch distance, is for a joint
            // that may start anywhere).
            if was_homed & bit(i) != 0 {
                let to_switch = p.switch_position.minus(ax.obs.x).abs().plus(p.rehome_margin);
                ax.homing.limit_travel(to_switch);
            }
        }
        self.resync();
        self.run_mask = mask;
        self.run_group = 0;
        self.home_wait = self.p.home_wait_ticks;
        self.transition(Edge::StartHoming);
        self.homing_status = HomingStatus::InProgress;
        self.armed = false;
        self.since_cmd = 0;
    }

    /// Homing: sequence the groups, step the active axes.
    pub(super) fn home_step(
        &mut self,
        limits: u8,
        out: &mut [S; AXES],
        fault: &mut Option<FaultReason>,
    ) -> Option<Event> {
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
            ax.homing.start(ax.obs.x);
            let s = ax.homing.step(limits & bit(i) != 0, ax.obs.x, &p.homing);
            if let Some(phase) = s.timed_out {
                fault.get_or_insert(FaultReason::HomingTimeout { axis: i as u8, phase });
            }
            if let Some(phase) = s.too_far {
                fault.get_or_insert(FaultReason::HomingTravel { axis: i as u8, phase });
            }
            if s.capture_zero {
                // Zero from the real reading plus the configured offset; the
                // estimate moves with it, so the residual is unchanged.
                let raw = S::from_counts(ax.unwrap.total().saturating_mul(p.enc_sign), p.k_count);
                let zero = p.switch_position.minus(raw);
                let d = zero.minus(ax.zero);
                ax.obs.shift(d);
                ax.path = ax.path.plus(d);
                ax.homing.shift(d);
                ax.zero = zero;
                self.homed |= bit(i);
            }
            *o = s.velocity;
        }
        None
    }

    /// Ends the run: Operational if every joint is now homed (H2), else
    /// Unhomed (a per-joint run with others unhomed: H0); the choice is made
    /// by the transition (`Edge::HomingDone`), the status follows it.
    fn finish_homing(&mut self) -> Event {
        let mask = self.run_mask;
        for ax in self.axes.iter_mut() {
            ax.homing.reset(false);
        }
        self.resync();
        self.homing_status = match self.transition(Edge::HomingDone) {
            State::Operational => HomingStatus::Complete,
            _ => HomingStatus::NotRequested,
        };
        self.run_mask = 0;
        Event::HomingDone { mask }
    }
}
