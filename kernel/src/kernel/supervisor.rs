//! The supervisor: the state machine ([`Mode`], shown to the outside as
//! [`State`]) and the fault checks.
//!
//! Every change of mode is made by one function, [`Kernel::transition`],
//! from one of the [`Edge`]s below; nothing else in the crate assigns the
//! mode. What each state refuses is stated here too ([`Kernel::mode_refusal`],
//! [`Kernel::homing_refusal`], [`Kernel::enable_refusal`]), so the whole
//! machine can be audited in this file:
//!
//! | edge | from | to | caller |
//! |---|---|---|---|
//! | `Ready` | Boot | Unhomed | [`Kernel::boot`]: every encoder read once |
//! | `Timeout` | Operational | Stopping (k = 0, from the last outputs) | [`Kernel::supervise`]: command timeout while moving |
//! | `LinkLost` | Operational, Homing, Stopping | Stopping (a homing run fails; a pending home is dropped) | [`Kernel::link_lost`] |
//! | `StopToHome` | Operational | Stopping, then homing | `start_homing` while the arm moves |
//! | `RampTick` | Stopping | Stopping (k + 1), or SoftEstop at k = N | [`Kernel::supervise`]: each ramp tick |
//! | `StartHoming` | Unhomed, Operational, Stopping at k = N with a pending home | Homing | homing sequencer |
//! | `HomingDone` | Homing | Operational if every joint is homed, else Unhomed | `finish_homing` (homing sequencer) |
//! | `Enable` | Fault, SoftEstop | Operational if every joint is homed, else Unhomed | `enable` (command intake) |
//! | `Fault` | any but Fault | Fault | [`Kernel::enter_fault`] |

use super::{bit, Kernel, ALL};
use crate::config::{AXES, COUNTS_PER_REV};
use crate::ramp;
use crate::scalar::Scalar;
use crate::types::{EncoderSample, Event, Events, Fault, FaultReason, HomingStatus, Reject, Sense, State, StopCause};

/// The supervisor's mode: [`State`] plus the soft-stop ramp's progress.
#[derive(Clone, Copy, Debug, PartialEq, Hash)]
pub(super) enum Mode<S> {
    Boot,
    Unhomed,
    Homing,
    Operational,
    /// The soft-stop ramp at tick `k` from outputs `v0`; `then_home`: the
    /// joints to home when it ends (0: latch SoftEstop); `track`: the joints
    /// keep following their braking set-points inside the ramp (entered
    /// from Operational; from Homing the set-points mean nothing).
    Stopping {
        k: u32,
        v0: [S; AXES],
        then_home: u8,
        track: bool,
    },
    SoftEstop,
    Fault,
}

/// An edge of the state machine: the reason for a change of mode (the
/// table in the module documentation gives each one's source and target).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Edge {
    /// Boot -> Unhomed.
    Ready,
    /// Operational -> Stopping.
    Timeout,
    /// Operational, Homing, Stopping -> Stopping (latching).
    LinkLost,
    /// Operational -> Stopping, then homing of the joints in the mask.
    StopToHome(u8),
    /// Stopping -> Stopping (one more ramp tick) or SoftEstop.
    RampTick,
    /// Unhomed, Operational, or the end of a ramp with a pending home ->
    /// Homing.
    StartHoming,
    /// Homing -> Operational or Unhomed.
    HomingDone,
    /// Fault, SoftEstop -> Operational or Unhomed.
    Enable,
    /// Any -> Fault.
    Fault,
}

impl<S: Scalar> Kernel<S> {
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

    /// **The** mode change: the only assignment of the mode in the crate.
    /// Returns the new state. Callers check the mode before they fire an
    /// edge (the refusals below); an edge fired from a state it does not
    /// leave keeps the mode (never reached; total rather than panicking).
    pub(super) fn transition(&mut self, edge: Edge) -> State {
        let next = match (edge, self.mode) {
            (Edge::Ready, Mode::Boot) => Mode::Unhomed,
            (Edge::Timeout, Mode::Operational) => Mode::Stopping { k: 0, v0: self.last_out, then_home: 0, track: true },
            (Edge::LinkLost, Mode::Operational) => {
                Mode::Stopping { k: 0, v0: self.last_out, then_home: 0, track: true }
            }
            (Edge::LinkLost, Mode::Homing) => Mode::Stopping { k: 0, v0: self.last_out, then_home: 0, track: false },
            (Edge::LinkLost, Mode::Stopping { k, v0, track, .. }) => Mode::Stopping { k, v0, then_home: 0, track },
            (Edge::StopToHome(mask), Mode::Operational) => {
                Mode::Stopping { k: 0, v0: self.last_out, then_home: mask, track: true }
            }
            (Edge::RampTick, Mode::Stopping { k, v0, then_home, track }) => {
                let k = k.saturating_add(1);
                if k >= self.p.stop_ticks && then_home == 0 {
                    Mode::SoftEstop
                } else {
                    Mode::Stopping { k: k.min(self.p.stop_ticks), v0, then_home, track }
                }
            }
            (Edge::StartHoming, Mode::Unhomed | Mode::Operational) => Mode::Homing,
            (Edge::StartHoming, Mode::Stopping { k, then_home, .. }) if then_home != 0 && k >= self.p.stop_ticks => {
                Mode::Homing
            }
            (Edge::HomingDone, Mode::Homing) | (Edge::Enable, Mode::Fault | Mode::SoftEstop) => {
                if self.homed == ALL {
                    Mode::Operational
                } else {
                    Mode::Unhomed
                }
            }
            (Edge::Fault, _) => Mode::Fault,
            (_, unchanged) => unchanged,
        };
        self.mode = next;
        self.state()
    }

    /// Why a motion command is refused in the current state (SR-15).
    pub(super) fn mode_refusal(&self) -> Option<Reject> {
        match self.mode {
            Mode::Boot => Some(Reject::Booting),
            Mode::Unhomed => Some(Reject::NotHomed),
            Mode::Homing => Some(Reject::Homing),
            Mode::Operational => None,
            Mode::Stopping { .. } => Some(Reject::Stopping),
            Mode::SoftEstop | Mode::Fault => Some(Reject::Latched),
        }
    }

    /// Why a host's homing request cannot start in the current state
    /// (`Edge::StartHoming`, or `Edge::StopToHome` while moving). Only
    /// `<ENABLE>` clears a latch: homing from SoftEstop or Fault is refused.
    pub(super) fn homing_refusal(&self) -> Option<Reject> {
        match self.mode {
            Mode::Boot => Some(Reject::Booting),
            Mode::Homing => Some(Reject::Homing),
            Mode::Stopping { .. } => Some(Reject::Stopping),
            Mode::SoftEstop | Mode::Fault => Some(Reject::Latched),
            Mode::Unhomed | Mode::Operational => None,
        }
    }

    /// The host link is gone: a moving arm soft-stops at once (latching); a
    /// homing run fails (H3) and stops; a pending home after a stop is
    /// dropped. An arm at rest holds.
    pub(super) fn link_lost(&mut self, events: &mut Events) {
        let stop = match self.mode {
            Mode::Operational => self.moving(),
            Mode::Homing => {
                self.abort_homing_run();
                true
            }
            Mode::Stopping { then_home, .. } => then_home != 0,
            _ => false,
        };
        if stop {
            self.transition(Edge::LinkLost);
            self.armed = false;
            events.push(Event::SoftEstop { cause: StopCause::LinkLost });
        }
    }

    /// A homing run ends without finishing: its joints are not homed, H3.
    pub(super) fn abort_homing_run(&mut self) {
        self.home_queued = false;
        self.homing_status = HomingStatus::Failed;
        self.homed &= !self.run_mask;
        for ax in self.axes.iter_mut() {
            ax.homing.reset(false);
        }
        self.run_mask = 0;
    }

    /// Why an enable has nothing to do in the current state (`Edge::Enable`
    /// leaves only Fault and SoftEstop); the fault causes are checked after.
    pub(super) fn enable_refusal(&self) -> Option<Reject> {
        match self.mode {
            Mode::Fault | Mode::SoftEstop => None,
            Mode::Stopping { .. } => Some(Reject::Stopping),
            _ => Some(Reject::NothingToClear),
        }
    }

    /// Boot: leave it when every encoder has been read once (and start a
    /// queued `<HOME>`), or fault when that takes longer than the boot
    /// timeout.
    pub(super) fn boot(&mut self, fault: &mut Option<FaultReason>, events: &mut Events) {
        if self.mode == Mode::Boot {
            if self.axes.iter().all(|a| a.ready) {
                self.transition(Edge::Ready);
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
    }

    /// Step 3: candidate outputs for every axis in the current mode
    /// (Operational: follow, or start the soft stop on the command timeout;
    /// Homing: the sequencer; Stopping: the ramp; otherwise zero), then the
    /// checks of every state. Not yet latched.
    ///
    /// The Operational path in every mode: the set-point generator, the
    /// control law and the acceleration clamp ([`Kernel::motion`]) and the
    /// following-error check ([`Kernel::following`]) run for every axis on
    /// every tick; the mode decides which results are kept. So a tick costs
    /// about the same in every mode: the soft stop adds its ramp, homing its
    /// sequencer and a request its intake (`docs/BENCHMARKS.md`, the cost
    /// by state).
    pub(super) fn supervise(&mut self, limits: u8, fault: &mut Option<FaultReason>, events: &mut Events) -> [S; AXES] {
        let mut out = [S::ZERO; AXES];
        let mut homing_event = None;
        let mut follow = false;
        match self.mode {
            Mode::Operational => {
                if self.armed {
                    self.since_cmd = self.since_cmd.saturating_add(1);
                }
                if self.armed && self.since_cmd > self.p.timeout_ticks && !self.setpoints_at_rest() {
                    // Interrupted motion (a set-point still travelling):
                    // ramp down and latch. A set-point at rest on its last
                    // target holds below, whatever the estimate's residual
                    // (the following-error check guards it; SR-29).
                    self.transition(Edge::Timeout);
                    let ms =
                        self.since_cmd.saturating_mul(1000).checked_div(self.p.tick_hz.unsigned_abs()).unwrap_or(0);
                    events.push(Event::SoftEstop { cause: StopCause::CommandTimeout { since_command_ms: ms } });
                } else {
                    if self.armed && self.since_cmd > self.p.timeout_ticks {
                        // Every set-point at rest on its last target: hold,
                        // latch nothing.
                        self.armed = false;
                        self.since_cmd = 0;
                        events.push(Event::Holding);
                    }
                    follow = true;
                }
            }
            Mode::Homing if self.home_wait > 0 => {
                // Rest before the run: the observer settles after a stop
                // (its velocity lags a deceleration by tens of ms), then the
                // commanded paths start from the settled estimates.
                self.home_wait = self.home_wait.saturating_sub(1);
                if self.home_wait == 0 {
                    self.resync();
                }
            }
            Mode::Homing => homing_event = self.home_step(limits, &mut out, fault),
            _ => {}
        }
        // Operational: follow the set-points; Stopping: the ramp (tick
        // k + 1); otherwise computed and not kept.
        let stop = match self.mode {
            Mode::Stopping { k, v0, track, .. } => Some((k.saturating_add(1), v0, track)),
            _ => None,
        };
        self.motion(follow, stop, &mut out, fault);
        if let Mode::Stopping { k, then_home, .. } = self.mode {
            if then_home != 0 && k.saturating_add(1) >= self.p.stop_ticks {
                // The stop before a requested homing is complete.
                self.transition(Edge::RampTick);
                self.begin_homing(then_home);
                events.push(Event::HomingStarted { mask: then_home });
            } else if self.transition(Edge::RampTick) == State::SoftEstop {
                events.push(Event::Stopped);
            }
        }
        if let Some(e) = homing_event {
            events.push(e);
        }
        // Following error in every moving mode (the commanded path is the
        // set-point in Operational, the integral of the commands otherwise).
        // Computed in every mode, kept in these (`None`: not kept).
        let checked = match self.mode {
            Mode::Operational => Some(false),
            // Not during the settle wait: the paths were set to estimates
            // that may still be catching up with the arm (the observer after
            // a push or a stop); the wait ends by resyncing them to the
            // settled estimates (`kernel/tests/homing.rs` shows a push released
            // as HOME arrives moving the estimate past the bound).
            Mode::Homing if self.home_wait > 0 => None,
            Mode::Homing | Mode::Stopping { .. } => Some(true),
            _ => None,
        };
        self.following(checked, fault);
        self.check(limits, &out, fault);
        out
    }

    /// The motion of every axis: its set-point's next step and the control
    /// law's command ([`Axis::control`](super::axis::Axis::control)) and the
    /// Operational output (the command, limited to one tick's change from
    /// the last output), computed for every axis in every mode, and kept
    /// when `follow` (with the commanded path and a numeric fault of the
    /// control law); in the soft stop (`stop = Some((k, v0, track))`: tick
    /// `k` of the ramp from `v0`) the ramp's output, and the set-point's
    /// step and a numeric fault if `track`.
    ///
    /// The soft-stop ramp: the envelope is `v0 * (N - k) / N`, never above
    /// the previous output in magnitude, exactly zero from `k = N` on; inside
    /// it each joint keeps following its set-point, which brakes to its
    /// target (the set-points are acceleration-limited and stop *at* their
    /// targets), so a stop that starts while a set-point is still braking
    /// ends where the set-point ends, not a ramp's length beyond it.
    fn motion(
        &mut self,
        follow: bool,
        stop: Option<(u32, [S; AXES], bool)>,
        out: &mut [S; AXES],
        fault: &mut Option<FaultReason>,
    ) {
        let (k, v0, track) = stop.unwrap_or((1, self.last_out, false));
        let stopping = stop.is_some();
        let scale = self.stop_scale(k);
        let done = k >= self.p.stop_ticks;
        let kp = &self.p;
        let axes =
            self.axes.iter_mut().zip(kp.axes.iter()).zip(out.iter_mut()).zip(v0.iter()).zip(self.last_out.iter());
        for (i, ((((ax, p), o), v), prev)) in axes.enumerate() {
            let (interp, sp, cmd, ok) = ax.control(p, kp);
            // Operational: the acceleration limit, within one tick's change
            // of the last output (which is within +-vmax, so the result is
            // too). The bounds are ordered (`accel_step >= 0`:
            // `config::check`), so no reordering (`clamp_between`'s).
            let followed = cmd.max(prev.minus(p.accel_step)).min(prev.plus(p.accel_step));
            // Computed in every mode: `black_box` keeps the compiler from
            // moving the computation under the conditions below that keep
            // it (the set-point step and the law feed `followed`).
            let (followed, ok) = core::hint::black_box((followed, ok));
            let moves = follow || (stopping && track);
            if moves {
                ax.interp = interp;
                if !ok {
                    fault.get_or_insert(FaultReason::Numeric { axis: i as u8 });
                }
            }
            if follow {
                // The set-point of this tick is where the joint should be
                // now (the commanded path).
                ax.path = sp;
                *o = followed;
            } else if stopping {
                // The ramp: following, the output may fall no faster than
                // the ramp itself (vmax / N per tick; `ramp::stop_output`).
                let braking = if track { Some((cmd, p.stop_step)) } else { None };
                *o = ramp::stop_output(*v, scale, *prev, braking, done);
            }
        }
    }

    /// Checks that apply in every state, and the outputs themselves.
    ///
    /// A joint's switch is its homing input until the joint is homed, in
    /// every state: a homing run that ends early (a lost link, a soft stop)
    /// leaves its joints unhomed, possibly resting on their switches, and
    /// that is no fault (SR-10). Likewise the joint limits apply to homed
    /// joints only (SR-19): an unhomed joint's estimate is relative to an
    /// unknown zero.
    fn check(&self, limits: u8, out: &[S; AXES], fault: &mut Option<FaultReason>) {
        let limit_is_fault = matches!(self.mode, Mode::Operational | Mode::Stopping { .. } | Mode::SoftEstop);
        for (i, ((ax, p), o)) in self.axes.iter().zip(self.p.axes.iter()).zip(out.iter()).enumerate() {
            let axis = i as u8;
            let pressed = limits & bit(i) != 0;
            let homed = self.homed & bit(i) != 0;
            if ax.ready && ax.obs.v.abs() > p.runaway {
                fault.get_or_insert(FaultReason::Runaway { axis });
            }
            // During homing a homed joint moves only while it is re-homed
            // (a moving phase); at rest its switch means something moved it.
            let homed_still = homed && !ax.homing.phase().is_moving();
            if pressed && homed && (limit_is_fault || (self.mode == Mode::Homing && homed_still)) {
                fault.get_or_insert(FaultReason::LimitSwitch { axis });
            }
            let homed_moving = homed && matches!(self.mode, Mode::Operational | Mode::Stopping { .. });
            if homed_moving && (ax.obs.x < p.pos_lo || ax.obs.x > p.pos_hi) {
                fault.get_or_insert(FaultReason::PositionLimit { axis });
            }
            if !(o.is_finite() && o.abs() <= p.vmax) {
                fault.get_or_insert(FaultReason::Numeric { axis });
            }
        }
    }

    /// Latches the tick's first fault (unless one is latched already) and,
    /// in Fault, zeroes every output in the same tick (SR-4).
    pub(super) fn latch(&mut self, fault: Option<FaultReason>, out: &mut [S; AXES], events: &mut Events) {
        if let Some(reason) = fault {
            if self.mode != Mode::Fault {
                self.enter_fault(reason);
                events.push(Event::Fault(reason));
            }
        }
        if self.mode == Mode::Fault {
            *out = [S::ZERO; AXES];
        }
    }

    fn enter_fault(&mut self, reason: FaultReason) {
        if self.mode == Mode::Homing || self.home_queued {
            // Axes of the aborted run are not homed.
            self.abort_homing_run();
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
        self.transition(Edge::Fault);
        self.resync();
    }

    /// The first fault condition present right now, if any.
    pub(super) fn present_cause(&self, sense: &Sense) -> Option<FaultReason> {
        if let Some(h) = sense.hardware_fault {
            return Some(FaultReason::Hardware(h));
        }
        for (i, ((ax, p), s)) in self.axes.iter().zip(self.p.axes.iter()).zip(sense.encoders.iter()).enumerate() {
            let axis = i as u8;
            let valid = matches!(*s, EncoderSample::Count(c) if i32::from(c) < COUNTS_PER_REV);
            if !valid {
                return Some(FaultReason::EncoderLost { axis });
            }
            // A switch is a cause on a homed joint only: an unhomed joint's
            // switch is its homing input, and `<HOME>` moves it off (SR-6,
            // SR-10). A joint whose count was lost is unhomed by the enable.
            let homed = self.homed & bit(i) != 0 && !ax.needs_reinit;
            if homed && sense.limits & bit(i) != 0 {
                return Some(FaultReason::LimitSwitch { axis });
            }
            // An axis whose count was lost has a frozen estimate: enable
            // re-initialises it from the reading at rest, so its stale
            // velocity is no cause (it blocked enable forever otherwise).
            if !ax.needs_reinit && ax.obs.v.abs() > p.vmax {
                return Some(FaultReason::Runaway { axis });
            }
            if homed && (ax.obs.x < p.pos_lo || ax.obs.x > p.pos_hi) {
                return Some(FaultReason::PositionLimit { axis });
            }
        }
        None
    }
}
