//! The per-tick safety monitor: every requirement of `SAFETY.md` that can be
//! judged from one tick's inputs and outputs (plus a little history) is
//! checked here, at every tick of every property test.
//!
//! The monitor is an *independent* oracle: it derives its limits from the
//! configuration and from the requirements' text, not from the kernel's
//! derived parameters. In particular the homing order is written down here
//! (J6; then J5, J4; then J1, J2, J3) rather than read from
//! `kernel::config::HOMING_GROUPS`, so a change to the kernel's order is
//! caught, not mirrored.
#![allow(clippy::needless_range_loop)] // six axes: indices read best

use kernel::config::{ms_to_ticks, ArmConfig, AXES, COUNTS_PER_REV};
use kernel::homing::Phase;
use kernel::{
    EncoderSample, Event, Fault, FaultReason, MotionTarget, Reject, RequestKind, Scalar, Sense, State, TickOutput,
};

/// Ticks of rest with nothing injected after which the estimates have
/// settled (the observer's time constant is about 1/alpha = 10 ticks).
pub const QUIET_TICKS: u32 = 300;

/// A sample the kernel accepts as a reading: a count of the 12-bit encoder.
fn is_count(e: &EncoderSample) -> bool {
    matches!(*e, EncoderSample::Count(c) if i32::from(c) < COUNTS_PER_REV)
}

/// Joints that must be homed (and have finished homing) before joint `i`
/// may move during homing: SR-13, the seed's order J6; J5, J4; J1, J2, J3.
pub const SEED_DEPENDENCIES: [u8; AXES] = [0b11_1000, 0b11_1000, 0b11_1000, 0b10_0000, 0b10_0000, 0];

/// A request as the monitor sees it (the capability itself is not `Clone`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sent<S> {
    /// A motion target.
    Motion(MotionTarget<S>),
    /// `Request::Home`.
    Home,
    /// `Request::HomeJoint`.
    HomeJoint(u8),
    /// `Request::Enable`.
    Enable,
}

impl<S> Sent<S> {
    fn kind(&self) -> RequestKind {
        match self {
            Sent::Motion(_) => RequestKind::Motion,
            Sent::Home => RequestKind::Home,
            Sent::HomeJoint(j) => RequestKind::HomeJoint(*j),
            Sent::Enable => RequestKind::Enable,
        }
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
    pub faults: [u64; 9],
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
}

impl Stats {
    /// Adds `o` into `self`.
    pub fn merge(&mut self, o: &Stats) {
        self.ticks += o.ticks;
        for (a, b) in self.state_ticks.iter_mut().zip(o.state_ticks.iter()) {
            *a += b;
        }
        for (a, b) in self.faults.iter_mut().zip(o.faults.iter()) {
            *a += b;
        }
        self.accepted += o.accepted;
        self.rejected += o.rejected;
        self.enabled += o.enabled;
        self.enable_refused += o.enable_refused;
        self.soft_stops += o.soft_stops;
        self.stopped += o.stopped;
        self.homing_done += o.homing_done;
        self.moving_ticks += o.moving_ticks;
        self.quiet_enables += o.quiet_enables;
    }
}

/// Names of the fault kinds counted in [`Stats::faults`].
pub const FAULT_KINDS: [&str; 9] = [
    "EncoderLost",
    "EncoderJump",
    "EncoderNotReady",
    "Runaway",
    "LimitSwitch",
    "PositionLimit",
    "Numeric",
    "HomingTimeout",
    "Hardware",
];

/// Index of a fault reason in [`FAULT_KINDS`].
pub fn fault_kind(r: &kernel::FaultReason) -> usize {
    use kernel::FaultReason::*;
    match r {
        EncoderLost { .. } => 0,
        EncoderJump { .. } => 1,
        EncoderNotReady { .. } => 2,
        Runaway { .. } => 3,
        LimitSwitch { .. } => 4,
        PositionLimit { .. } => 5,
        Numeric { .. } => 6,
        HomingTimeout { .. } => 7,
        Hardware(_) => 8,
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

/// Extra facts about the plant that some checks need.
#[derive(Clone, Copy, Debug)]
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
}

macro_rules! ensure {
    ($cond:expr, $($arg:tt)+) => {
        {
            let ok: bool = $cond;
            if !ok {
                return Err(format!($($arg)+));
            }
        }
    };
}

/// The monitor's memory between ticks.
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
    /// Coverage counters.
    pub stats: Stats,
}

impl<S: Scalar> Monitor<S> {
    /// A monitor for a kernel that has just been created with `cfg`.
    pub fn new(cfg: &ArmConfig) -> Self {
        Monitor {
            cfg: *cfg,
            timeout_ticks: ms_to_ticks(cfg.command_timeout_ms, cfg.tick_hz),
            stop_ticks: ms_to_ticks(cfg.soft_stop_ms, cfg.tick_hz).max(1),
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
            stats: Stats::default(),
        }
    }

    /// Checks one tick. `phases` are the kernel's homing phases after the
    /// tick. Returns a description of the first violated requirement.
    pub fn check(
        &mut self,
        sense: &Sense,
        sent: Option<&Sent<S>>,
        out: &TickOutput<S>,
        phases: [Phase; AXES],
        plant: &PlantFacts,
    ) -> Result<(), String> {
        let r = self.check_inner(sense, sent, out, phases, plant);
        // Memory for the next tick.
        self.prev_out = out.act.velocity;
        self.prev_state = out.status.state;
        self.prev_armed = out.status.timeout_armed;
        self.prev_setpoint = out.status.setpoint;
        self.prev_homed = out.status.homed;
        r
    }

    #[allow(clippy::too_many_lines)]
    fn check_inner(
        &mut self,
        sense: &Sense,
        sent: Option<&Sent<S>>,
        out: &TickOutput<S>,
        phases: [Phase; AXES],
        plant: &PlantFacts,
    ) -> Result<(), String> {
        let st = out.status.state;
        let prev = self.prev_state;
        let ev: Vec<Event> = out.events.iter().copied().collect();
        let cfg = self.cfg;
        let hz = cfg.tick_hz as f32;

        // Statistics.
        self.stats.ticks += 1;
        self.stats.state_ticks[state_index(st)] += 1;
        for e in &ev {
            match e {
                Event::Rejected { reason: Reject::CauseActive(_), .. } => {
                    self.stats.rejected += 1;
                    self.stats.enable_refused += 1;
                }
                Event::Rejected { .. } => self.stats.rejected += 1,
                Event::Fault(r) => self.stats.faults[fault_kind(r)] += 1,
                Event::Enabled(_) => self.stats.enabled += 1,
                Event::SoftEstop { .. } => self.stats.soft_stops += 1,
                Event::Stopped => self.stats.stopped += 1,
                Event::HomingDone { .. } => self.stats.homing_done += 1,
                _ => {}
            }
        }
        if st == State::Operational && out.act.velocity.iter().any(|v| *v != S::ZERO) {
            self.stats.moving_ticks += 1;
        }
        ensure!(out.events.dropped() == 0, "events dropped: {:?}", out.events);

        // What happened to this tick's request.
        let rejected_kind = ev.iter().find_map(|e| match e {
            Event::Rejected { request, reason } => Some((*request, *reason)),
            _ => None,
        });
        if let Some((k, _)) = rejected_kind {
            ensure!(sent.map(|s| s.kind()) == Some(k), "rejection of {k:?} without that request");
        }
        let accepted = sent.is_some() && rejected_kind.is_none();
        let fault_events: Vec<_> =
            ev.iter().filter_map(|e| if let Event::Fault(r) = e { Some(*r) } else { None }).collect();
        let all_zero = out.act.velocity.iter().all(|v| *v == S::ZERO) && out.act.step_rate.iter().all(|r| *r == 0);

        // SR-2: every output finite and within the joint's max velocity; the
        // step rate within the step generator's range, with the velocity's sign.
        for i in 0..AXES {
            let j = &cfg.joints[i];
            let v = out.act.velocity[i];
            ensure!(
                v.is_finite() && v.abs() <= S::from_f32(j.max_velocity),
                "SR-2: axis {i} output {v:?} not finite or above {}",
                j.max_velocity
            );
            let r = out.act.step_rate[i];
            ensure!(r.unsigned_abs() <= cfg.max_step_rate, "SR-2: axis {i} step rate {r}");
            let vf = v.to_f32();
            ensure!(
                if vf == 0.0 { r == 0 } else { r == 0 || (vf > 0.0) == (r > 0) },
                "SR-2: axis {i} velocity {vf} with step rate {r}"
            );
        }

        // SR-1, SR-4: zero output in Boot, Unhomed, SoftEstop, Fault, and in
        // the tick a fault is raised (for every axis).
        if matches!(st, State::Boot | State::Unhomed | State::SoftEstop | State::Fault) || !fault_events.is_empty() {
            ensure!(all_zero, "SR-1/SR-4: state {st:?} (events {ev:?}) with outputs {:?}", out.act);
        }

        // SR-1: leaving Boot, each estimate is the encoder's actual reading.
        if ev.contains(&Event::Ready) {
            ensure!(prev == State::Boot, "Ready outside Boot");
            if plant.clean_since_start {
                for i in 0..AXES {
                    let j = &cfg.joints[i];
                    let EncoderSample::Count(c) = sense.encoders[i] else {
                        return Err(format!("SR-1: Ready with encoder {i} lost"));
                    };
                    let want = f64::from(c) * j.rad_per_count();
                    let got = f64::from(out.status.position[i].to_f32());
                    ensure!(
                        (got - want).abs() <= 2.0 * j.rad_per_count() + 1e-5,
                        "SR-1: axis {i} starts at {got}, reading says {want}"
                    );
                    ensure!(out.status.velocity[i] == S::ZERO, "SR-1: axis {i} does not start at rest");
                }
            }
        }

        // SR-5: a fault latches with its first reason until an accepted enable.
        ensure!((st == State::Fault) == out.status.fault.is_some(), "SR-5: state {st:?} fault {:?}", out.status.fault);
        ensure!(fault_events.len() <= 1, "SR-5: several faults in one tick: {ev:?}");
        match (prev == State::Fault, st == State::Fault) {
            (false, true) => {
                let f = out.status.fault.ok_or("SR-5: no fault")?;
                ensure!(fault_events == [f.reason], "SR-5: entered Fault {f:?} with events {ev:?}");
                self.latched = Some(f);
            }
            (true, true) => {
                ensure!(fault_events.is_empty(), "SR-5: a second fault event while latched: {ev:?}");
                ensure!(
                    out.status.fault == self.latched,
                    "SR-5: latched fault changed from {:?} to {:?}",
                    self.latched,
                    out.status.fault
                );
            }
            (true, false) => {
                ensure!(
                    matches!(sent, Some(Sent::Enable)) && ev.contains(&Event::Enabled(st)),
                    "SR-5: left Fault for {st:?} without an accepted enable: {ev:?}"
                );
                self.latched = None;
            }
            (false, false) => ensure!(fault_events.is_empty(), "SR-5: fault event {ev:?} but state {st:?}"),
        }

        // SR-5, SR-7: SoftEstop is latched until enable or home.
        if prev == State::SoftEstop && !matches!(st, State::SoftEstop | State::Fault) {
            let ok = match st {
                State::Homing => matches!(sent, Some(Sent::Home | Sent::HomeJoint(_))) && accepted,
                _ => matches!(sent, Some(Sent::Enable)) && ev.contains(&Event::Enabled(st)),
            };
            ensure!(ok, "SR-5: left SoftEstop for {st:?} with {sent:?}, events {ev:?}");
        }

        // SR-6: enable is refused while a cause is present in this tick's
        // sensors or state; after it, set-points are the measured positions
        // and the timeout is disarmed.
        let enabled = ev.iter().find_map(|e| if let Event::Enabled(s) = e { Some(*s) } else { None });
        let sensed_cause =
            sense.hardware_fault.is_some() || sense.limits & 0b11_1111 != 0 || !sense.encoders.iter().all(is_count);
        // SR-6, liveness: a cause named by a refusal is real. After the arm
        // has rested with nothing injected for `QUIET_TICKS` the estimates
        // have settled, so no speed is a cause, and a lost encoder, a switch
        // or a hardware fault must be in this tick's sensors. (A frozen
        // estimate of a lost encoder once blocked enable for good.)
        if let (Some(Sent::Enable), true) = (sent, plant.quiet_ticks >= QUIET_TICKS) {
            if matches!(prev, State::Fault | State::SoftEstop) {
                self.stats.quiet_enables += 1;
            }
            for e in &ev {
                if let Event::Rejected { reason: Reject::CauseActive(c), .. } = e {
                    let real = match *c {
                        FaultReason::Runaway { .. } => false,
                        FaultReason::EncoderLost { axis } => !is_count(&sense.encoders[usize::from(axis)]),
                        FaultReason::LimitSwitch { axis } => sense.limits & (1 << axis) != 0,
                        FaultReason::Hardware(_) => sense.hardware_fault.is_some(),
                        _ => true,
                    };
                    ensure!(
                        real,
                        "SR-6: enable refused for {c:?} after the arm rested {} ticks with nothing injected",
                        plant.quiet_ticks
                    );
                }
            }
        }
        if let Some(Sent::Enable) = sent {
            if matches!(prev, State::Fault | State::SoftEstop) && sensed_cause {
                ensure!(enabled.is_none(), "SR-6: enable accepted with a cause in the sensors: {sense:?}");
            }
            if !matches!(prev, State::Fault | State::SoftEstop) {
                ensure!(enabled.is_none(), "SR-6: enable accepted in {prev:?}");
            }
        }
        if let Some(s) = enabled {
            ensure!(matches!(sent, Some(Sent::Enable)), "SR-6: Enabled without an enable request");
            ensure!(matches!(prev, State::Fault | State::SoftEstop), "SR-6: enabled from {prev:?}");
            ensure!(!sensed_cause, "SR-6: enabled with a cause in the sensors: {sense:?}");
            ensure!(fault_events.is_empty(), "SR-6: enabled and faulted in the same tick: {ev:?}");
            ensure!(s == st && matches!(st, State::Operational | State::Unhomed), "SR-6: enabled into {s:?}/{st:?}");
            ensure!(!out.status.timeout_armed, "SR-6/SR-8: timeout armed after enable");
            for i in 0..AXES {
                ensure!(
                    out.status.setpoint[i] == out.status.position[i],
                    "SR-6: axis {i} set-point {:?} != position {:?} after enable",
                    out.status.setpoint[i],
                    out.status.position[i]
                );
                let j = &cfg.joints[i];
                ensure!(
                    out.status.velocity[i].abs() <= S::from_f32(j.max_velocity),
                    "SR-6: enabled while axis {i} moves at {:?}",
                    out.status.velocity[i]
                );
            }
            if st == State::Operational {
                ensure!(
                    out.status.homed == 0b11_1111,
                    "SR-6: Operational after enable but homed {:#b}",
                    out.status.homed
                );
            }
        }

        // SR-7: the soft E-stop ramp: starts exactly `timeout` ticks after the
        // last accepted command when armed, never increases or reverses,
        // steps at most vmax/N, reaches zero within N ticks and latches.
        let stop_event = ev.iter().any(|e| matches!(e, Event::SoftEstop { .. }));
        let due = prev == State::Operational
            && self.prev_armed
            && self.since_accept.map(|t| t + 1) == Some(self.timeout_ticks)
            && !accepted;
        ensure!(
            stop_event == due,
            "SR-7/SR-8: soft stop event {stop_event} but due {due} (prev {prev:?}, armed {}, {:?} ticks since the last command)",
            self.prev_armed,
            self.since_accept.map(|t| t + 1)
        );
        if st == State::Stopping || (prev == State::Stopping && st == State::SoftEstop) {
            ensure!(matches!(prev, State::Operational | State::Stopping), "SR-7: Stopping entered from {prev:?}");
            if prev == State::Operational {
                ensure!(stop_event, "SR-7: Stopping without a SoftEstop event");
                self.stopping_ticks = 0;
            }
            self.stopping_ticks += 1;
            for i in 0..AXES {
                let (a, b) = (out.act.velocity[i], self.prev_out[i]);
                ensure!(a.abs() <= b.abs(), "SR-7: axis {i} speed increased {b:?} -> {a:?}");
                ensure!(a == S::ZERO || (a > S::ZERO) == (b > S::ZERO), "SR-7: axis {i} reversed {b:?} -> {a:?}");
                let step = (f64::from(b.to_f32()) - f64::from(a.to_f32())).abs();
                let bound = f64::from(cfg.joints[i].max_velocity) / f64::from(self.stop_ticks);
                ensure!(step <= bound * 1.001 + 1e-6, "SR-7: axis {i} decelerates {step} in a tick (> {bound})");
            }
            if st == State::Stopping {
                ensure!(
                    self.stopping_ticks < self.stop_ticks,
                    "SR-7: still Stopping after {} ticks",
                    self.stopping_ticks
                );
            } else {
                ensure!(all_zero && ev.contains(&Event::Stopped), "SR-7: ramp end without zero output / Stopped");
            }
        }
        if prev == State::Stopping && !matches!(st, State::Stopping | State::SoftEstop | State::Fault) {
            return Err(format!("SR-7: left Stopping for {st:?}"));
        }
        if ev.contains(&Event::Stopped) {
            // The ramp can end in the tick a fault is detected: the fault
            // then takes the arm to Fault instead of SoftEstop (found by a
            // differential run, session 2).
            let faulted_now = st == State::Fault && ev.iter().any(|e| matches!(e, Event::Fault(_)));
            ensure!(
                (st == State::SoftEstop || faulted_now) && prev == State::Stopping,
                "SR-7: Stopped in {prev:?} -> {st:?}"
            );
            // The ramp's ticks, from the SoftEstop event (k = 1) to the zero (k = N).
            // (The fault tick is not counted above when the fault wins.)
            ensure!(
                self.stopping_ticks + u32::from(faulted_now) == self.stop_ticks,
                "SR-7: ramp took {} ticks, N = {}",
                self.stopping_ticks,
                self.stop_ticks
            );
        }

        // SR-8: the timeout is armed only by an accepted motion command, and
        // disarmed by homing and enable.
        let motion_accepted = accepted && matches!(sent, Some(Sent::Motion(_)));
        if out.status.timeout_armed && !self.prev_armed {
            ensure!(motion_accepted, "SR-8: timeout armed without an accepted motion command");
        }
        if ev.iter().any(|e| matches!(e, Event::HomingStarted { .. })) {
            ensure!(!out.status.timeout_armed, "SR-8: timeout armed after homing started");
        }
        self.since_accept = if motion_accepted { Some(0) } else { self.since_accept.map(|t| t.saturating_add(1)) };

        // SR-9: a speed estimate above the runaway threshold is a fault.
        for i in 0..AXES {
            let j = &cfg.joints[i];
            if out.status.velocity[i].abs() > S::from_f32(j.runaway_velocity) {
                ensure!(
                    st == State::Fault,
                    "SR-9: axis {i} estimate {:?} above runaway in {st:?}",
                    out.status.velocity[i]
                );
            }
        }

        // SR-10: a pressed switch outside homing is a fault; during homing,
        // on a homed axis at rest.
        let pressed = sense.limits & 0b11_1111;
        if pressed != 0 {
            ensure!(
                !matches!(st, State::Operational | State::Stopping | State::SoftEstop),
                "SR-10: switches {pressed:#b} pressed in {st:?}"
            );
        }
        if st == State::Homing {
            for i in 0..AXES {
                let still_homed = out.status.homed & (1 << i) != 0 && !phases[i].is_moving();
                ensure!(!(pressed & (1 << i) != 0 && still_homed), "SR-10: switch {i} pressed on a homed axis at rest");
            }
        }

        // SR-11: more than `encoder_invalid_limit` invalid samples in a row
        // (outside Boot) is a fault, and that joint must be homed again.
        for i in 0..AXES {
            let valid = is_count(&sense.encoders[i]);
            self.lost_streak[i] = if valid { 0 } else { self.lost_streak[i] + 1 };
            if self.lost_streak[i] > cfg.encoder_invalid_limit && prev != State::Boot {
                ensure!(st == State::Fault, "SR-11: encoder {i} invalid for {} ticks in {st:?}", self.lost_streak[i]);
                self.must_rehome |= 1 << i;
            }
        }
        for e in &ev {
            if let Event::HomingStarted { mask } = e {
                self.must_rehome &= !mask;
            }
        }
        if !matches!(st, State::Fault) {
            ensure!(
                out.status.homed & self.must_rehome == 0,
                "SR-11: joints {:#b} counted as homed after losing their encoder",
                out.status.homed & self.must_rehome
            );
        }

        // SR-13, SR-16: during homing, an axis moves only in a moving phase,
        // and only after every axis of the earlier groups is homed and still.
        if st == State::Homing {
            for i in 0..AXES {
                let moving = out.act.velocity[i] != S::ZERO;
                if moving {
                    ensure!(phases[i].is_moving(), "SR-16: axis {i} moves in phase {:?}", phases[i]);
                }
                if moving || phases[i].is_moving() {
                    let deps = SEED_DEPENDENCIES[i];
                    ensure!(
                        out.status.homed & deps == deps,
                        "SR-13: axis {i} moves with joints {:#b} unhomed",
                        deps & !out.status.homed
                    );
                    for (d, p) in phases.iter().enumerate() {
                        ensure!(
                            deps & (1 << d) == 0 || !p.is_moving(),
                            "SR-13: axis {i} moves while earlier axis {d} is still homing ({p:?})"
                        );
                    }
                }
            }
        } else {
            ensure!(phases.iter().all(|p| !p.is_moving()), "SR-16: homing phases {phases:?} outside Homing ({st:?})");
        }
        // SR-13: per-joint homing is refused while its dependencies are unhomed.
        if let (Some(Sent::HomeJoint(j)), true) = (sent, accepted) {
            let j = usize::from(*j);
            ensure!(j < AXES, "SR-13: HomeJoint({j}) accepted");
            let deps = SEED_DEPENDENCIES[j];
            // `homed` before the tick: sensing does not change it.
            ensure!(self.prev_homed & deps == deps, "SR-13: HomeJoint({j}) accepted with {deps:#b} not all homed");
        }

        // SR-14: a homing run on a clean plant zeroes every homed axis at its
        // true angle.
        if plant.clean_homing {
            for e in &ev {
                if let Event::HomingDone { mask } = e {
                    for i in 0..AXES {
                        if mask & (1 << i) != 0 && out.status.homed & (1 << i) != 0 {
                            let err = f64::from(out.status.position[i].to_f32()) - plant.q[i];
                            // The estimate may still lag the release move
                            // by a few mrad (alpha-beta transient); a zero
                            // taken from anything but the reading at the
                            // switch is off by far more.
                            ensure!(err.abs() < 2e-2, "SR-14: axis {i} homed {err} rad off its true angle");
                        }
                    }
                }
            }
        }

        // SR-15: motion is accepted only in Operational, and a valid target
        // there is always accepted. SR-17: accepted targets are finite and
        // within the limits.
        if let Some(Sent::Motion(t)) = sent {
            let verdict = validity(&cfg, t);
            if motion_accepted {
                self.stats.accepted += 1;
                ensure!(prev == State::Operational, "SR-15: motion accepted in {prev:?}");
                ensure!(verdict != Validity::Invalid, "SR-17: invalid target accepted: {t:?}");
            } else if prev == State::Operational && verdict == Validity::Valid {
                return Err(format!("SR-17: valid target rejected in Operational: {ev:?}, {t:?}"));
            }
        }

        // SR-18: in Operational the set-point moves at most vmax/tick_hz per tick.
        if st == State::Operational && prev == State::Operational {
            for i in 0..AXES {
                let step =
                    (f64::from(out.status.setpoint[i].to_f32()) - f64::from(self.prev_setpoint[i].to_f32())).abs();
                let bound = f64::from(cfg.joints[i].max_velocity / hz);
                ensure!(step <= bound * 1.001 + 1e-6, "SR-18: axis {i} set-point stepped {step} (> {bound})");
            }
        }

        // SR-19: in Operational and Stopping every (homed) axis is within its
        // limits plus the margin.
        if matches!(st, State::Operational | State::Stopping) {
            ensure!(out.status.homed == 0b11_1111, "{st:?} with homed {:#b}", out.status.homed);
            for i in 0..AXES {
                let j = &cfg.joints[i];
                let x = out.status.position[i];
                ensure!(
                    x >= S::from_f32(j.limit_min - cfg.position_margin)
                        && x <= S::from_f32(j.limit_max + cfg.position_margin),
                    "SR-19: axis {i} at {x:?} outside its limits + margin in {st:?}"
                );
            }
        }

        // SR-25: in Operational the output changes by at most
        // max_acceleration / tick_hz per tick.
        if st == State::Operational {
            for i in 0..AXES {
                let dv = (f64::from(out.act.velocity[i].to_f32()) - f64::from(self.prev_out[i].to_f32())).abs();
                let bound = f64::from(cfg.joints[i].max_acceleration / hz);
                ensure!(
                    dv <= bound * 1.0001 + 1e-6,
                    "SR-25: axis {i} output stepped {dv} rad/s in a tick (> {bound}): {:?} -> {:?}",
                    self.prev_out[i],
                    out.act.velocity[i]
                );
            }
        }
        Ok(())
    }
}

/// The monitor's own verdict on a motion target.
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
    for i in 0..AXES {
        let j = &cfg.joints[i];
        let (p, v) = (t.position[i], t.velocity[i]);
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
