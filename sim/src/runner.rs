//! Runs a [`Scenario`] through the composition root, checks the safety
//! requirements at every tick, evaluates the expectations and builds the
//! [`Report`].
//!
//! A [`Run`] goes through its phases once per tick ([`Run::tick`]: the
//! scripted actions, the streams' frames, the root's step, the trace and
//! its statistics, the events, the safety check, the line log) and once at
//! the end ([`Run::finish`]: the stops, the goal error, the expectations,
//! the report).

use std::collections::BTreeMap;

use firmware::root::HostConfig;
use kernel::config::{Validated, AXES};
use kernel::{Event, FaultReason, HomingStatus, RequestKind, State};
use monitor::{Monitor, Sent};

use crate::client::{driver_view, DriverView};
use crate::encoder::Line;
use crate::plant::PlantOptions;
use crate::report::{JointError, Report};
use crate::root::{Root, Step};
use crate::scenario::{Action, Anchor, Expect, Scenario, When};
use crate::stream::{Hosts, Stream};
use crate::trace::{accel_step, from_t, Sample, STILL_SPEED};

/// Options for a run.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Run the main loop as the Serial1 build does (feedback budget of
    /// `HostConfig::SERIAL1`) instead of USB.
    pub serial1: bool,
}

/// Short text of a fault reason, for the report.
pub fn fault_text(r: &FaultReason) -> String {
    match *r {
        FaultReason::EncoderLost { axis } => format!("encoder lost J{}", axis + 1),
        FaultReason::EncoderJump { axis, delta } => format!("encoder jump J{} ({delta} counts)", axis + 1),
        FaultReason::EncoderNotReady { axis } => format!("encoder not ready J{}", axis + 1),
        FaultReason::Runaway { axis } => format!("runaway J{}", axis + 1),
        FaultReason::LimitSwitch { axis } => format!("limit switch J{}", axis + 1),
        FaultReason::PositionLimit { axis } => format!("position limit J{}", axis + 1),
        FaultReason::Numeric { axis } => format!("numeric J{}", axis + 1),
        FaultReason::HomingTimeout { axis, phase } => format!("homing timeout J{} in {phase:?}", axis + 1),
        FaultReason::HomingTravel { axis, phase } => format!("homing travel J{} in {phase:?}", axis + 1),
        FaultReason::FollowingError { axis } => format!("following error J{}", axis + 1),
        FaultReason::Hardware(h) => format!("hardware {h:?}"),
    }
}

fn fault_matches(kind: &str, joint: Option<usize>, r: &FaultReason) -> bool {
    let (k, axis) = match *r {
        FaultReason::EncoderLost { axis } | FaultReason::EncoderJump { axis, .. } => ("encoder", Some(axis)),
        FaultReason::EncoderNotReady { axis } => ("encoder-not-ready", Some(axis)),
        FaultReason::Runaway { axis } => ("runaway", Some(axis)),
        FaultReason::LimitSwitch { axis } => ("limit-switch", Some(axis)),
        FaultReason::PositionLimit { axis } => ("position-limit", Some(axis)),
        FaultReason::Numeric { axis } => ("numeric", Some(axis)),
        FaultReason::HomingTimeout { axis, .. } => ("homing-timeout", Some(axis)),
        FaultReason::HomingTravel { axis, .. } => ("homing-travel", Some(axis)),
        FaultReason::FollowingError { axis } => ("following-error", Some(axis)),
        FaultReason::Hardware(_) => ("hardware", None),
    };
    (kind == "any" || kind == k) && joint.is_none_or(|j| axis == Some(j as u8))
}

/// The simulator's per-tick safety check: the project's one safety monitor
/// (`monitor`, written from SAFETY.md) on what the kernel sensed, was sent
/// and returned; the output's acceleration in every state (Operational,
/// Stopping and Homing alike; only the tick a fault zeroes the outputs and
/// homing's stop at a switch are exempt, see
/// [`accel_step`]); plus the wire checks only the simulator can make (no
/// `nan`/`inf`, printable bytes, every `<` line readable by its client).
#[derive(Clone, Debug)]
pub struct TickChecker {
    monitor: Monitor<f32>,
    /// A switch closed most of a window is seen (SR-10).
    switches: monitor::interactions::SwitchWatch,
    /// No frame dropped while the tick runs on time (SR-26).
    frames: monitor::interactions::FrameWatch,
    /// Largest velocity change per tick of each joint (rad/s), 1 % slack.
    dv_max: [f64; AXES],
    prev: Option<Sample>,
}

impl TickChecker {
    /// A checker for a kernel on `cfg`, created with it.
    pub fn new(cfg: &Validated) -> Self {
        let c = cfg.config();
        let dv_max = c.joints.map(|j| f64::from(j.max_acceleration) / f64::from(c.tick_hz) * 1.01 + 1e-6);
        TickChecker {
            monitor: Monitor::new(c),
            switches: monitor::interactions::SwitchWatch::new(),
            frames: monitor::interactions::FrameWatch::new(),
            dv_max,
            prev: None,
        }
    }

    /// Checks one step (call for every step, in order); returns the
    /// violations.
    pub fn check(&mut self, step: &Step) -> Vec<String> {
        let driver_reads: Vec<bool> = step.lines.iter().map(|l| driver_view(l).is_some()).collect();
        self.check_read(step, &driver_reads)
    }

    /// [`TickChecker::check`], given whether the driver reads each of the
    /// step's lines (`driver_view(line).is_some()`, which the runner has
    /// computed already).
    fn check_read(&mut self, step: &Step, driver_reads: &[bool]) -> Vec<String> {
        let mut bad = Vec::new();
        let sent = step.request.map(|k| match (k, step.target) {
            (RequestKind::Motion, Some(t)) => Sent::Motion(Some(t)),
            (k, _) => Sent::from_kind(k),
        });
        if let Err(v) = self.monitor.check(&step.sense, sent.as_ref(), &step.out, Some(&step.phases), None) {
            bad.push(v.to_string());
        }
        let (tick, state) = (step.out.status.tick, step.out.status.state);
        if let Err(v) = self.switches.check(step.raw_closed, step.sense.limits, tick, state) {
            bad.push(v.to_string());
        }
        if let Err(v) = self.frames.check(step.queue_refused, step.overrun, tick, state) {
            bad.push(v.to_string());
        }
        let now = Sample {
            t: step.t_ms,
            state: step.out.status.state,
            q: [0.0; AXES],
            est: step.out.status.position,
            sp: step.out.status.setpoint,
            v: step.out.act.velocity,
            still: false,
            accepted: false,
            request_ok: false,
            reference: [f32::NAN; AXES],
        };
        if let Some(prev) = &self.prev {
            for (i, lim) in self.dv_max.iter().enumerate() {
                if let Some(dv) = accel_step(prev, &now, i) {
                    if dv > *lim {
                        bad.push(format!(
                            "acceleration: J{} output changed by {dv:.4} rad/s in one tick (limit {lim:.4}), {:?} -> {:?}",
                            i + 1,
                            prev.state,
                            now.state
                        ));
                    }
                }
            }
        }
        self.prev = Some(now);
        for (l, &reads) in step.lines.iter().zip(driver_reads) {
            // One pass over the bytes: "nan" or "inf" in any letter case
            // (ASCII: the line is UTF-8, whose multi-byte sequences hold no
            // ASCII letter), and bytes other than printable ASCII and `\n`.
            let (mut nan_inf, mut printable) = (false, true);
            let mut last3 = [0u8; 3];
            for &b in l.as_bytes() {
                last3 = [last3[1], last3[2], b.to_ascii_lowercase()];
                nan_inf |= &last3 == b"nan" || &last3 == b"inf";
                printable &= b == b'\n' || (0x20..0x7f).contains(&b);
            }
            if nan_inf {
                bad.push(format!("line contains nan/inf: {}", l.trim_end()));
            }
            if !printable {
                bad.push(format!("line with non-printable bytes: {l:?}"));
            }
            let t = l.trim_start();
            if t.starts_with('<') && !reads && !crate::client::configurator_matches(l) {
                bad.push(format!("feedback line neither client can read: {}", l.trim_end()));
            }
            if l.starts_with('<') && !reads {
                bad.push(format!("a line starting with `<` that the driver would take and reject: {}", l.trim_end()));
            }
        }
        bad
    }
}

/// The wire's rejection lines, grouped by reason in the report.
const WIRE_KEYS: [&str; 4] = ["REJECT", "STALE_CMD", "QUEUE_FULL", "SEQ_RESYNC"];

/// The report's grouping of a rejection line: `REJECT ...` and
/// `QUEUE_FULL ...` without the running count, `STALE_CMD` and
/// `SEQ_RESYNC` by their `reason=`.
fn wire_reason(key: &str, l: &str) -> String {
    let reason_field = || l.split("reason=").nth(1).and_then(|r| r.split(' ').next()).unwrap_or("");
    match key {
        "STALE_CMD" | "SEQ_RESYNC" => format!("{key} {}", reason_field()),
        _ => l.split(" count=").next().unwrap_or(l).trim_end().to_string(),
    }
}

/// What the whole run measured that the expectations read, besides the
/// trace: computed once by [`Run::finish`].
struct Totals {
    /// (last command of a burst, ms to standstill).
    stops: Vec<(u64, Option<u64>)>,
    /// Goal error of the last burst (rad).
    goal: Option<f64>,
    /// All rejections (wire, sequence, queue, kernel).
    rejected_total: u64,
}

/// One scenario in progress: the root, the hosts and everything measured so
/// far. [`run`] drives it; a caller that needs its own loop calls
/// [`Run::tick`] until [`Run::done`] and then [`Run::finish`].
#[derive(Debug)]
pub struct Run<'a> {
    cfg: &'a Validated,
    sc: &'a Scenario,
    serial1: bool,
    root: Root,
    hosts: Hosts,
    /// The cable is plugged: the hosts' bytes reach the firmware.
    cable: bool,
    fired: Vec<bool>,
    streams: Vec<Stream>,
    /// Occurrences of each anchor (ms), indexed like `Anchor::index`.
    occ: [Vec<u64>; Anchor::ALL.len()],
    trace: Vec<Sample>,
    /// Tracking: set-point vs true position while following a stream
    /// (Operational, a motion accepted within the last 50 ms).
    err: [JointError; AXES],
    err_ref: [JointError; AXES],
    last_acc: Option<u64>,
    burst_len: u32,
    /// Largest commanded acceleration per joint in every state (rad/s^2),
    /// except where no limit applies (`accel_step`).
    accel: [f64; AXES],
    /// Times of accepted motion commands.
    acc: Vec<u64>,
    /// Times of accepted requests.
    req_ok: Vec<u64>,
    violations: Vec<(u64, String)>,
    violation_count: u64,
    faults: Vec<(u64, String)>,
    fault_reasons: Vec<FaultReason>,
    refusals: BTreeMap<String, u64>,
    wire: BTreeMap<String, u64>,
    all_lines: Vec<(u64, String)>,
    last_driver_view: Option<DriverView>,
    targets: Vec<(u64, [f32; AXES])>,
    lines_sent: u64,
    bytes_in: u64,
    checker: TickChecker,
    prev_status: Option<kernel::Status<f32>>,
    /// The next tick's time (ms).
    t: u64,
}

/// Runs one scenario; `progress` is called with the fraction done.
pub fn run(cfg: &Validated, sc: &Scenario, opts: &RunOptions, progress: &mut dyn FnMut(f64)) -> Report {
    let mut r = Run::new(cfg, sc, opts);
    loop {
        let end = r.end();
        if r.t >= end {
            break;
        }
        if r.t.is_multiple_of(500) {
            progress(r.t as f64 / end.max(1) as f64);
        }
        r.tick();
    }
    progress(1.0);
    r.finish()
}

impl<'a> Run<'a> {
    /// The root on the scenario's plant (start pose, noise, switches, step
    /// rate, seed) and the main loop `opts` asks for, at time 0.
    pub fn new(cfg: &'a Validated, sc: &'a Scenario, opts: &RunOptions) -> Self {
        let mut popts = PlantOptions::new(cfg.config());
        if let Some(p) = sc.pose {
            popts.start = p;
        }
        if let Some(n) = sc.noise {
            popts.noise_counts = n;
        }
        for &(j, a) in &sc.switch_at {
            popts.switch_at[j] = a;
        }
        if let Some(r) = sc.max_step_rate {
            popts.max_step_rate = r;
        }
        popts.seed = sc.seed;
        let host = if opts.serial1 { HostConfig::SERIAL1 } else { HostConfig::USB };
        Run {
            cfg,
            sc,
            serial1: opts.serial1,
            root: Root::new(cfg, popts, host),
            hosts: Hosts::default(),
            cable: true,
            fired: vec![false; sc.actions.len()],
            streams: Vec::new(),
            occ: Default::default(),
            trace: Vec::new(),
            err: [JointError::default(); AXES],
            err_ref: [JointError::default(); AXES],
            last_acc: None,
            burst_len: 0,
            accel: [0.0; AXES],
            acc: Vec::new(),
            req_ok: Vec::new(),
            violations: Vec::new(),
            violation_count: 0,
            faults: Vec::new(),
            fault_reasons: Vec::new(),
            refusals: BTreeMap::new(),
            wire: BTreeMap::new(),
            all_lines: Vec::new(),
            last_driver_view: None,
            targets: Vec::new(),
            lines_sent: 0,
            bytes_in: 0,
            checker: TickChecker::new(cfg),
            prev_status: None,
            t: 0,
        }
    }

    /// The time (ms) the run ends: the scenario's `end` once it has
    /// happened, at most its `max`.
    pub fn end(&self) -> u64 {
        self.sc.end.resolve(&self.occ).unwrap_or(self.sc.max_ms).min(self.sc.max_ms)
    }

    /// The run has reached its end.
    pub fn done(&self) -> bool {
        self.t >= self.end()
    }

    /// One tick: the actions and frames due, the root's step, and what it
    /// tells.
    pub fn tick(&mut self) {
        let mut input = self.actions();
        let reference = self.stream_frames(&mut input);
        self.bytes_in += input.len() as u64;
        let step = self.root.step(&input);
        self.record(&step, reference);
        self.note_events(&step);
        let views: Vec<Option<DriverView>> = step.lines.iter().map(|l| driver_view(l)).collect();
        self.check(&step, &views);
        self.prev_status = Some(step.out.status);
        self.log_lines(step.lines, views);
        self.t += 1;
    }

    /// The pose a new stream starts from: the last driver feedback, or the
    /// kernel's estimate before any.
    fn pose_now(&self) -> [f64; AXES] {
        match &self.last_driver_view {
            Some(v) => v.position,
            None => self.trace.last().map(|s| s.est.map(f64::from)).unwrap_or([0.0; AXES]),
        }
    }

    /// The scripted actions due now; returns the bytes they send.
    fn actions(&mut self) -> Vec<u8> {
        let mut input = Vec::new();
        let sc = self.sc;
        for (k, (when, action)) in sc.actions.iter().enumerate() {
            if self.fired[k] || when.resolve(&self.occ).is_none_or(|at| at > self.t) {
                continue;
            }
            self.fired[k] = true;
            self.act(action, &mut input);
        }
        input
    }

    /// Performs one action; bytes it sends go to `input`.
    fn act(&mut self, action: &Action, input: &mut Vec<u8>) {
        let plant = &mut self.root.board.plant;
        match action {
            Action::Send(b) => {
                if self.cable {
                    input.extend_from_slice(b);
                }
            }
            Action::Stream { client, rate_hz, duration_ms, motion, burst } => {
                let p0 = self.pose_now();
                self.streams.push(Stream::new(*client, *rate_hz, *duration_ms, *motion, self.t, p0).with_burst(*burst));
            }
            Action::Goto { client, pose } => {
                let l = self.hosts.frame(*client, pose, &[0.0; AXES]);
                if self.cable {
                    input.extend_from_slice(l.as_bytes());
                }
            }
            Action::Cable(c) => {
                self.cable = *c;
                // Over USB the host sees the port close when the cable goes
                // (and the firmware's main loop tells the kernel the link is
                // lost); a UART cannot tell.
                if !self.serial1 {
                    self.root.port.open = *c;
                }
            }
            Action::Glitch { joint, offset, frames } => plant.glitch(*joint, *offset, *frames),
            Action::Encoder(j, line) => {
                plant.set_line(*j, *line);
                if *line == Line::Ok {
                    plant.reverse_encoder(*j, false);
                    plant.freeze_encoder(*j, false);
                }
            }
            Action::EncoderReversed(j) => plant.reverse_encoder(*j, true),
            Action::EncoderFrozen(j) => plant.freeze_encoder(*j, true),
            Action::Switch(j, f) => plant.force_switch(*j, *f),
            Action::Runaway(j, v) => plant.set_disturbance(*j, *v),
            Action::LostSteps(j, f) => plant.set_lost_steps(*j, *f),
            Action::CableSilent => self.cable = false,
            Action::ReverseDir(j, on) => plant.set_dir_inverted(*j, *on),
            Action::Noise(n) => plant.set_noise(*n),
            Action::Overrun => self.root.board.overrun = true,
        }
    }

    /// The streams' frames due now (to `input` while the cable is plugged);
    /// returns the active stream's continuous reference (NaN when none).
    fn stream_frames(&mut self, input: &mut Vec<u8>) -> [f32; AXES] {
        let mut reference = [f32::NAN; AXES];
        for s in self.streams.iter().filter(|s| !s.finished()) {
            reference = s.sample(self.t).0.map(|x| x as f32);
        }
        for l in self.hosts.due(&mut self.streams, self.t) {
            if self.cable {
                input.extend_from_slice(l.as_bytes());
            }
        }
        reference
    }

    /// Appends the tick's sample to the trace and updates the statistics
    /// read from it (accelerations, accepted commands, tracking errors).
    fn record(&mut self, step: &Step, reference: [f32; AXES]) {
        let (t, out) = (self.t, &step.out);
        let q = self.root.board.plant.q();
        let accepted = step.request == Some(RequestKind::Motion)
            && !out.events.iter().any(|e| matches!(e, Event::Rejected { request: RequestKind::Motion, .. }));
        if accepted {
            if let Some(tg) = step.target {
                self.targets.push((t, tg.position));
            }
        }
        self.trace.push(Sample {
            t,
            state: out.status.state,
            q: q.map(|x| x as f32),
            est: out.status.position,
            sp: out.status.setpoint,
            v: out.act.velocity,
            still: out.act.velocity.iter().all(|v| v.abs() < STILL_SPEED),
            accepted,
            request_ok: step.request.is_some() && !out.events.iter().any(|e| matches!(e, Event::Rejected { .. })),
            reference,
        });
        if let [.., w0, s] = self.trace.as_slice() {
            for (i, a) in self.accel.iter_mut().enumerate() {
                if let Some(dv) = accel_step(w0, s, i) {
                    *a = a.max(dv * f64::from(self.cfg.config().tick_hz));
                }
            }
        }
        let Some(s) = self.trace.last() else { return };
        if s.accepted {
            self.burst_len = if self.last_acc.is_some_and(|a| s.t - a <= 100) { self.burst_len + 1 } else { 1 };
            self.last_acc = Some(s.t);
            self.acc.push(s.t);
        }
        if s.request_ok {
            self.req_ok.push(s.t);
        }
        let following =
            s.state == State::Operational && self.last_acc.is_some_and(|a| s.t - a <= 50) && self.burst_len >= 2;
        if following {
            for i in 0..AXES {
                self.err[i].add(f64::from(s.sp[i]) - f64::from(s.q[i]));
                if s.reference[i].is_finite() {
                    self.err_ref[i].add(f64::from(s.reference[i]) - f64::from(s.q[i]));
                }
            }
        }
    }

    /// The step's kernel events (faults, refusals, enables) and the anchors
    /// its state changes mark.
    fn note_events(&mut self, step: &Step) {
        let (t, out) = (self.t, &step.out);
        for e in out.events.iter() {
            match e {
                Event::Fault(r) => {
                    self.faults.push((t, fault_text(r)));
                    self.fault_reasons.push(*r);
                }
                Event::Rejected { request, reason } => {
                    *self.refusals.entry(format!("{request:?}: {reason:?}")).or_default() += 1;
                }
                Event::Enabled(_) => self.occ[Anchor::Enabled.index()].push(t),
                Event::HomingStarted { .. } => self.occ[Anchor::HomingStarted.index()].push(t),
                Event::SoftEstop { cause } => {
                    self.occ[Anchor::SoftStop.index()].push(t);
                    if *cause == kernel::StopCause::LinkLost {
                        self.occ[Anchor::LinkLost.index()].push(t);
                    }
                }
                Event::Stopped => self.occ[Anchor::Stopped.index()].push(t),
                Event::Holding => self.occ[Anchor::Holding.index()].push(t),
                _ => {}
            }
        }
        let ps = self.prev_status;
        if out.status.homing == HomingStatus::Complete && ps.is_none_or(|p| p.homing != HomingStatus::Complete) {
            self.occ[Anchor::Homed.index()].push(t);
        }
        if out.status.homing == HomingStatus::Failed && ps.is_none_or(|p| p.homing != HomingStatus::Failed) {
            self.occ[Anchor::HomingFailed.index()].push(t);
        }
        for (st, a) in [(State::SoftEstop, Anchor::Estop), (State::Fault, Anchor::Fault)] {
            if out.status.state == st && ps.is_none_or(|p| p.state != st) {
                self.occ[a.index()].push(t);
            }
        }
    }

    /// The per-tick safety check; keeps the first 50 violations.
    fn check(&mut self, step: &Step, views: &[Option<DriverView>]) {
        let driver_reads: Vec<bool> = views.iter().map(Option::is_some).collect();
        for b in self.checker.check_read(step, &driver_reads) {
            self.violation_count += 1;
            if self.violations.len() < 50 {
                self.violations.push((self.t, b));
            }
        }
    }

    /// Counts and logs the lines the firmware sent, groups its rejections
    /// by reason and keeps the last driver feedback.
    fn log_lines(&mut self, lines: Vec<String>, views: Vec<Option<DriverView>>) {
        for (l, view) in lines.into_iter().zip(views) {
            self.lines_sent += 1;
            for key in WIRE_KEYS {
                if l.starts_with(key) {
                    *self.wire.entry(wire_reason(key, &l)).or_default() += 1;
                }
            }
            if let Some(v) = view {
                self.last_driver_view = Some(v);
            }
            if self.all_lines.len() < 200_000 {
                self.all_lines.push((self.t, l));
            }
        }
    }

    /// Each command burst's last command and the ms until every output was
    /// still (before the next accepted request), `None` if never.
    fn stops(&self) -> Vec<(u64, Option<u64>)> {
        let mut stops = Vec::new();
        for (k, &a) in self.acc.iter().enumerate() {
            let next = self.acc.get(k + 1).copied();
            if next.is_some_and(|n| n - a <= 100) {
                continue;
            }
            let until = self.req_ok.iter().copied().find(|&r| r > a).unwrap_or(self.t);
            let mut still_from: Option<u64> = None;
            for s in from_t(&self.trace, a.saturating_add(1)).iter().take_while(|s| s.t < until) {
                if s.still {
                    still_from.get_or_insert(s.t);
                } else {
                    still_from = None;
                }
            }
            stops.push((a, still_from.map(|s| s - a)));
        }
        stops
    }

    /// Goal error of the last burst: its last target vs the true position
    /// when the outputs stopped (or at the end).
    fn goal(&self, stops: &[(u64, Option<u64>)]) -> Option<f64> {
        let &(a, dt) = stops.last()?;
        let tg = self.targets.iter().rev().find(|(ta, _)| *ta == a)?.1;
        let at = a + dt.unwrap_or(0);
        let s = from_t(&self.trace, at).first().or(self.trace.last())?;
        Some((0..AXES).map(|i| (f64::from(tg[i]) - f64::from(s.q[i])).abs()).fold(0.0, f64::max))
    }

    /// The end of the run: the stops, the goal error, the expectations and
    /// the report.
    pub fn finish(self) -> Report {
        let stops = self.stops();
        let goal = self.goal(&stops);
        let counters = self.root.counters();
        let rejected_total = u64::from(counters.rejected)
            + u64::from(counters.seq.duplicates)
            + u64::from(counters.seq.behind)
            + u64::from(self.root.queue_refused())
            + self.refusals.values().sum::<u64>();
        let totals = Totals { stops, goal, rejected_total };
        let expectations = self.expectations(&totals);
        let (sc, serial1) = (self.sc, self.serial1);
        Report {
            name: sc.name.clone(),
            description: sc.description.clone(),
            // A USB scenario on the Serial1 main loop: a UART cannot tell a
            // pulled cable, so what it expects of the link loss cannot hold.
            informational: sc.informational || (sc.usb_only && serial1),
            decode: if serial1 {
                "frame capture (shipped decoder), Serial1 host"
            } else {
                "frame capture (shipped decoder), USB host"
            }
            .to_string(),
            duration_ms: self.t,
            homed_at: self.occ[Anchor::Homed.index()].first().copied(),
            tracking: self.err,
            tracking_ref: self.err_ref,
            max_accel: self.accel,
            stops: totals.stops,
            goal_error: totals.goal,
            faults: self.faults,
            refusals: self.refusals,
            wire: self.wire,
            rejected_total,
            protocol: counters,
            violations: self.violations,
            violation_count: self.violation_count,
            expectations,
            decode_stats: self.root.decode_stats(),
            lines_sent: self.lines_sent,
            bytes_in: self.bytes_in,
            commands_accepted: self.acc.len() as u64,
            targets: self.targets,
            lines: self.all_lines,
            trace: self.trace,
            plot: None,
        }
    }

    /// Every expectation of the scenario: (its text, held, detail); a
    /// `pending` one holds either way and says which.
    fn expectations(&self, totals: &Totals) -> Vec<(String, bool, String)> {
        let mut expectations = Vec::new();
        for outer in &self.sc.expects {
            let (pending, e) = match outer {
                Expect::Pending(inner) => (true, inner.as_ref()),
                e => (false, e),
            };
            let (ok, detail) = match self.expect_wire(e, totals) {
                Some(r) => r,
                None => self.expect_motion(e, totals),
            };
            if pending {
                let verdict =
                    if ok { "now HOLDS: remove `pending`" } else { "fails, as the reported kernel defect predicts" };
                expectations.push((outer.to_string(), true, format!("{verdict}; {detail}")));
            } else {
                expectations.push((e.to_string(), ok, detail));
            }
        }
        expectations
    }

    /// The simulated state at `at` (ms).
    fn state_at(&self, at: u64) -> Option<State> {
        from_t(&self.trace, at).first().map(|s| s.state)
    }

    /// When `w` happened (ms), if it did.
    fn window(&self, w: &When) -> Option<u64> {
        w.resolve(&self.occ)
    }

    /// The expectations on faults, states, anchors and the lines on the
    /// wire; `None` for the others ([`Run::expect_motion`]).
    fn expect_wire(&self, e: &Expect, totals: &Totals) -> Option<(bool, String)> {
        let (faults, t) = (&self.faults, self.t);
        let fault_list = || faults.iter().map(|f| f.1.clone()).collect::<Vec<_>>().join("; ");
        let find_line = |text: &str| self.all_lines.iter().find(|(_, l)| l.contains(text));
        Some(match e {
            Expect::NoFault => (faults.is_empty(), format!("{} fault(s)", faults.len())),
            Expect::Fault(kind, j) => {
                let hit = self.fault_reasons.iter().any(|r| fault_matches(kind, *j, r));
                (hit, if faults.is_empty() { "no fault".into() } else { fault_list() })
            }
            Expect::State(w, name) => match self.window(w) {
                None => (false, format!("{w} never happened")),
                Some(at) => {
                    let at = at.min(t.saturating_sub(1));
                    let st = self.state_at(at).map(protocol::report::state_name).unwrap_or("none");
                    (st == name, format!("{st} at {at} ms"))
                }
            },
            Expect::HomedBy(w) => {
                let h = self.occ[Anchor::Homed.index()].first().copied();
                match (h, self.window(w)) {
                    (Some(h), Some(by)) => (h <= by, format!("H2 at {h} ms")),
                    (None, _) => (false, "never homed".into()),
                    (Some(h), None) => (false, format!("H2 at {h} ms, {w} never happened")),
                }
            }
            Expect::RejectedAtLeast(n) => {
                let r = totals.rejected_total;
                (r >= *n, format!("{r} rejected"))
            }
            Expect::Line(text) => {
                let hit = find_line(text);
                (hit.is_some(), hit.map(|(t, l)| format!("at {t} ms: {}", l.trim_end())).unwrap_or("not found".into()))
            }
            Expect::NoLine(text) => {
                let hit = find_line(text);
                (hit.is_none(), hit.map(|(t, l)| format!("at {t} ms: {}", l.trim_end())).unwrap_or("none".into()))
            }
            Expect::FaultWithin(w, ms, kind, j) => match self.window(w) {
                None => (false, format!("{w} never happened")),
                Some(at) => {
                    let hit = faults
                        .iter()
                        .zip(self.fault_reasons.iter())
                        .find(|((ft, _), r)| *ft >= at && *ft <= at + ms && fault_matches(kind, *j, r));
                    match hit {
                        Some(((ft, txt), _)) => (true, format!("{txt} at {ft} ms ({} ms after {at} ms)", ft - at)),
                        None => (
                            false,
                            if faults.is_empty() {
                                "no fault".into()
                            } else {
                                faults.iter().map(|(t, f)| format!("{f} at {t} ms")).collect::<Vec<_>>().join("; ")
                            },
                        ),
                    }
                }
            },
            Expect::LineWithin(w, ms, text) => match self.window(w) {
                None => (false, format!("{w} never happened")),
                Some(at) => {
                    let lines = &self.all_lines;
                    let hit = lines.iter().find(|(t, l)| *t >= at && *t <= at + ms && l.contains(text.as_str()));
                    match hit {
                        Some((t, l)) => (true, format!("at {t} ms ({} ms after {at} ms): {}", t - at, l.trim_end())),
                        None => {
                            let later = lines.iter().find(|(t, l)| *t >= at && l.contains(text.as_str()));
                            (false, later.map(|(t, _)| format!("first at {t} ms")).unwrap_or("not found".into()))
                        }
                    }
                }
            },
            Expect::LineSequence(texts) => self.line_sequence(texts),
            Expect::StopWithin(_)
            | Expect::TrackingRmsBelow(_)
            | Expect::TrackingMaxBelow(_)
            | Expect::GoalWithin(_)
            | Expect::MovingAfter(_)
            | Expect::WrongWayBelow(..)
            | Expect::ExcursionBelow(..)
            | Expect::StillBetween(..)
            | Expect::LineCount(..)
            | Expect::NoLineBetween(..)
            | Expect::AtTargetWithin(..)
            | Expect::AccelWithinLimits(..)
            | Expect::Pending(_) => return None,
        })
    }

    /// `expect lines "A" "B" ...`: each text in a line after the previous
    /// one's.
    fn line_sequence(&self, texts: &[String]) -> (bool, String) {
        let mut from = 0usize;
        let mut found = Vec::new();
        for text in texts {
            match self.all_lines.iter().enumerate().skip(from).find(|(_, (_, l))| l.contains(text.as_str())) {
                Some((k, (t, _))) => {
                    found.push(format!("{text:?} at {t} ms"));
                    from = k + 1;
                }
                None => {
                    found.push(format!("{text:?} not found after that"));
                    break;
                }
            }
        }
        (found.len() == texts.len() && !found.iter().any(|f| f.ends_with("after that")), found.join(", "))
    }

    /// The expectations on the motion: stops, tracking, goal, the trace.
    fn expect_motion(&self, e: &Expect, totals: &Totals) -> (bool, String) {
        let (trace, err) = (&self.trace, &self.err);
        match e {
            Expect::StopWithin(ms) => {
                let stops = &totals.stops;
                let worst = stops.iter().map(|s| s.1).max_by_key(|d| d.unwrap_or(u64::MAX));
                match worst {
                    None => (false, "no command burst".into()),
                    Some(None) => (false, "outputs never stopped after a burst".into()),
                    Some(Some(d)) => (d <= *ms, format!("worst {d} ms over {} stop(s)", stops.len())),
                }
            }
            Expect::TrackingRmsBelow(m) => {
                let w = err.iter().map(|e| e.rms_mrad()).fold(0.0, f64::max);
                (err[0].n > 0 && w < *m, format!("worst RMS {w:.2} mrad"))
            }
            Expect::TrackingMaxBelow(m) => {
                let w = err.iter().map(|e| e.max_mrad()).fold(0.0, f64::max);
                (err[0].n > 0 && w < *m, format!("worst max {w:.2} mrad"))
            }
            Expect::GoalWithin(r) => match totals.goal {
                Some(g) => (g < *r, format!("{g:.4} rad")),
                None => (false, "no goal".into()),
            },
            Expect::MovingAfter(w) => match self.window(w) {
                None => (false, format!("{w} never happened")),
                Some(at) => {
                    let m = from_t(trace, at.saturating_add(1)).iter().find(|s| !s.still);
                    (m.is_some(), m.map(|s| format!("moving at {} ms", s.t)).unwrap_or("never moved".into()))
                }
            },
            Expect::WrongWayBelow(j, bound) => {
                let mut wrong = 0.0f64;
                let mut worst_at = None;
                for w in trace.windows(2) {
                    let dq = f64::from(w[1].q[*j]) - f64::from(w[0].q[*j]);
                    let v = f64::from(w[1].v[*j]);
                    if dq * v < 0.0 {
                        wrong += dq.abs();
                        worst_at = Some(w[1].t);
                    }
                }
                let last = worst_at.map(|t| format!(", last at {t} ms")).unwrap_or_default();
                (wrong < *bound, format!("{wrong:.4} rad against the command{last}"))
            }
            Expect::ExcursionBelow(j, w, bound) => match self.window(w) {
                None => (false, format!("{w} never happened")),
                Some(at) => match from_t(trace, at).first() {
                    None => (false, "no sample".into()),
                    Some(s0) => {
                        let q0 = f64::from(s0.q[*j]);
                        let (d, t) = trace
                            .iter()
                            .filter(|s| s.t >= at)
                            .map(|s| ((f64::from(s.q[*j]) - q0).abs(), s.t))
                            .fold((0.0, at), |a, b| if b.0 > a.0 { b } else { a });
                        (d < *bound, format!("largest {d:.4} rad (at {t} ms) from {q0:.4} rad at {at} ms"))
                    }
                },
            },
            Expect::LineCount(n, text) => {
                let got = self.all_lines.iter().filter(|(_, l)| l.contains(text.as_str())).count();
                (got == *n, format!("{got} line(s)"))
            }
            Expect::NoLineBetween(a, b, text) => match (self.window(a), self.window(b)) {
                (Some(a), Some(b)) => {
                    let hit = self.all_lines.iter().find(|(t, l)| *t >= a && *t <= b && l.contains(text.as_str()));
                    (
                        hit.is_none(),
                        hit.map(|(t, l)| format!("at {t} ms: {}", l.trim_end()))
                            .unwrap_or(format!("none from {a} to {b} ms")),
                    )
                }
                _ => (false, format!("{a} or {b} never happened")),
            },
            Expect::StillBetween(a, b, joint) => match (self.window(a), self.window(b)) {
                (Some(a), Some(b)) => {
                    let still = |s: &&Sample| match joint {
                        Some(j) => s.v.get(*j).is_some_and(|v| v.abs() < STILL_SPEED),
                        None => s.still,
                    };
                    let m = from_t(trace, a).iter().take_while(|s| s.t <= b).find(|s| !still(s));
                    (
                        m.is_none(),
                        m.map(|s| {
                            let (i, v) =
                                s.v.iter()
                                    .enumerate()
                                    .fold((0, 0.0f32), |m, (i, v)| if v.abs() > m.1.abs() { (i, *v) } else { m });
                            format!("moving at {} ms (J{} {v:.3} rad/s)", s.t, i + 1)
                        })
                        .unwrap_or(format!("still from {a} to {b} ms")),
                    )
                }
                _ => (false, format!("{a} or {b} never happened")),
            },
            Expect::AtTargetWithin(w, bound) => match self.window(w) {
                None => (false, format!("{w} never happened")),
                Some(at) => {
                    let tg = self.targets.iter().rev().find(|(ta, _)| *ta <= at);
                    let s = from_t(trace, at.min(self.t.saturating_sub(1))).first();
                    match (tg, s) {
                        (Some((ta, tg)), Some(s)) => {
                            let (i, d) = (0..AXES)
                                .map(|i| (i, (f64::from(tg[i]) - f64::from(s.q[i])).abs()))
                                .fold((0, 0.0), |m, x| if x.1 > m.1 { x } else { m });
                            (
                                d < *bound,
                                format!("worst J{} {d:.4} rad at {} ms (target accepted at {ta} ms)", i + 1, s.t),
                            )
                        }
                        _ => (false, "no target accepted by then".into()),
                    }
                }
            },
            Expect::AccelWithinLimits(a, b) => match (self.window(a), self.window(b)) {
                (Some(a), Some(b)) => self.accel_within_limits(a, b),
                _ => (false, format!("{a} or {b} never happened")),
            },
            Expect::Pending(_) => (false, "`pending` does not nest".into()),
            Expect::NoFault
            | Expect::Fault(..)
            | Expect::State(..)
            | Expect::HomedBy(_)
            | Expect::RejectedAtLeast(_)
            | Expect::Line(_)
            | Expect::NoLine(_)
            | Expect::FaultWithin(..)
            | Expect::LineWithin(..)
            | Expect::LineSequence(_) => (false, format!("{e} is not a motion expectation")),
        }
    }

    /// `expect accel-within-limits A B`: every commanded velocity change in
    /// (a, b] within its joint's limit (1 % slack).
    fn accel_within_limits(&self, a: u64, b: u64) -> (bool, String) {
        let (trace, cfgc) = (&self.trace, self.cfg.config());
        let mut worst: Option<(f64, usize, u64)> = None;
        let mut bad: Option<(f64, usize, u64)> = None;
        // (Only the windows ending in (a, b]: from the sample before the
        // first after `a` to the last up to `b`.)
        let lo = trace.partition_point(|s| s.t <= a).max(1) - 1;
        let hi = trace.partition_point(|s| s.t <= b).max(lo);
        for w in trace[lo..hi].windows(2).filter(|w| w[1].t > a && w[1].t <= b) {
            for i in 0..AXES {
                let Some(dv) = accel_step(&w[0], &w[1], i) else { continue };
                let lim = f64::from(cfgc.joints[i].max_acceleration) / f64::from(cfgc.tick_hz);
                let ratio = dv / lim;
                if worst.is_none_or(|x| ratio > x.0) {
                    worst = Some((ratio, i, w[1].t));
                }
                if ratio > 1.01 && bad.is_none() {
                    bad = Some((ratio, i, w[1].t));
                }
            }
        }
        let show = |x: (f64, usize, u64)| format!("{:.0} % of J{}'s limit at {} ms", x.0 * 100.0, x.1 + 1, x.2);
        match (bad, worst) {
            (Some(x), _) => (false, format!("first over: {}", show(x))),
            (None, Some(x)) => (true, format!("largest {}", show(x))),
            (None, None) => (false, "empty window".into()),
        }
    }
}
