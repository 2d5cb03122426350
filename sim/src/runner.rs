//! Runs a [`Scenario`] through the composition root, checks the safety
//! requirements at every tick, evaluates the expectations and builds the
//! [`Report`].

use std::collections::BTreeMap;

use firmware::root::HostConfig;
use kernel::config::{Validated, AXES};
use kernel::{Event, FaultReason, HomingStatus, RequestKind, State};
use monitor::{Monitor, Sent};

use crate::client::{configurator_line, driver_line, driver_view};
use crate::plant::PlantOptions;
use crate::report::{JointError, Report};
use crate::root::{Root, Step};
use crate::scenario::{Action, Anchor, Client, Expect, Motion, Scenario, When};

/// Options for a run.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Run the main loop as the Serial1 build does (feedback budget of
    /// `HostConfig::SERIAL1`) instead of USB.
    pub serial1: bool,
}

/// One recorded tick (what the plots and the report need).
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    /// Time (ms).
    pub t: u64,
    /// Kernel state.
    pub state: State,
    /// True joint angles (rad).
    pub q: [f32; AXES],
    /// Kernel's estimate (rad).
    pub est: [f32; AXES],
    /// Kernel's set-point (rad).
    pub sp: [f32; AXES],
    /// Commanded velocity (rad/s).
    pub v: [f32; AXES],
    /// Every commanded speed below [`STILL_SPEED`] (standstill or holding).
    pub still: bool,
    /// A motion command was accepted this tick.
    pub accepted: bool,
    /// Some request (motion, home, enable) was accepted this tick.
    pub request_ok: bool,
    /// The active stream's continuous reference (rad), NaN when none.
    pub reference: [f32; AXES],
}

struct Stream {
    client: Client,
    start: u64,
    end: u64,
    period: f64,
    next: f64,
    motion: Motion,
    p0: [f64; AXES],
    finished: bool,
}

/// The stream's continuous reference pose at `t` (the jog's final pose after its end).
fn stream_pose(s: &Stream, t: u64) -> [f64; AXES] {
    s.motion.sample(&s.p0, s.start, s.end, t).0
}

struct Hosts {
    driver_seq: u32,
    config_seq: u32,
    cable: bool,
}

impl Hosts {
    fn frame(&mut self, client: Client, p: &[f64; AXES], v: &[f64; AXES]) -> String {
        match client {
            Client::Driver => {
                let l = driver_line(self.driver_seq, p, v);
                self.driver_seq = self.driver_seq.wrapping_add(1);
                l
            }
            Client::Configurator => {
                let l = configurator_line(self.config_seq, p, v);
                self.config_seq = self.config_seq.wrapping_add(1);
                l
            }
        }
    }
}

/// Standstill: every commanded speed below this (rad/s). A joint holding its
/// target is servoed: its encoder noise makes the command dither by a few
/// mrad/s, which is not motion.
pub const STILL_SPEED: f32 = 0.01;

/// The change of joint `i`'s commanded velocity from `a` to `b` (rad/s per
/// tick), or `None` where no acceleration limit applies: the tick a fault
/// zeroes every output, and homing's stop at a switch (an axis's output
/// becoming exactly zero in Homing; decision 3 lets that stop be
/// instantaneous).
pub fn accel_step(a: &Sample, b: &Sample, i: usize) -> Option<f64> {
    if b.state == State::Fault && a.state != State::Fault {
        return None;
    }
    if b.state == State::Homing && b.v[i] == 0.0 {
        return None;
    }
    Some((f64::from(b.v[i]) - f64::from(a.v[i])).abs())
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
/// and returned; the output's acceleration in every state (decisions 1 and
/// 3 of issue 12: Operational, Stopping and Homing alike; only the tick a
/// fault zeroes the outputs and homing's stop at a switch are exempt, see
/// [`accel_step`]); plus the wire checks only the simulator can make (no
/// `nan`/`inf`, printable bytes, every `<` line readable by its client).
#[derive(Clone, Debug)]
pub struct TickChecker {
    monitor: Monitor<f32>,
    /// Largest velocity change per tick of each joint (rad/s), 1 % slack.
    dv_max: [f64; AXES],
    prev: Option<Sample>,
}

impl TickChecker {
    /// A checker for a kernel on `cfg`, created with it.
    pub fn new(cfg: &Validated) -> Self {
        let c = cfg.config();
        let dv_max = c.joints.map(|j| f64::from(j.max_acceleration) / f64::from(c.tick_hz) * 1.01 + 1e-6);
        TickChecker { monitor: Monitor::new(c), dv_max, prev: None }
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

/// The samples from time `at` on (the trace's times increase strictly: one
/// sample per tick).
fn from_t(trace: &[Sample], at: u64) -> &[Sample] {
    &trace[trace.partition_point(|s| s.t < at)..]
}

/// Runs one scenario; `progress` is called with the fraction done.
pub fn run(cfg: &Validated, sc: &Scenario, opts: &RunOptions, progress: &mut dyn FnMut(f64)) -> Report {
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
    let mut root = Root::new(cfg, popts, host);
    let mut hosts = Hosts { driver_seq: 0, config_seq: 0, cable: true };
    let mut fired = vec![false; sc.actions.len()];
    let mut streams: Vec<Stream> = Vec::new();
    let mut occ: [Vec<u64>; 4] = Default::default();
    let mut trace: Vec<Sample> = Vec::new();
    // Tracking: set-point vs true position while following a stream
    // (Operational, a motion accepted within the last 50 ms).
    let mut err = [JointError::default(); AXES];
    let mut err_ref = [JointError::default(); AXES];
    let mut last_acc: Option<u64> = None;
    let mut burst_len = 0u32;
    // Largest commanded acceleration per joint in every state (rad/s^2),
    // except where no limit applies (`accel_step`).
    let mut accel = [0.0f64; AXES];
    // Times of accepted motion commands and of accepted requests.
    let mut acc: Vec<u64> = Vec::new();
    let mut req_ok: Vec<u64> = Vec::new();
    let mut violations: Vec<(u64, String)> = Vec::new();
    let mut violation_count = 0u64;
    let mut faults: Vec<(u64, String)> = Vec::new();
    let mut fault_reasons: Vec<FaultReason> = Vec::new();
    let mut refusals: BTreeMap<String, u64> = BTreeMap::new();
    let mut wire: BTreeMap<String, u64> = BTreeMap::new();
    let mut all_lines: Vec<(u64, String)> = Vec::new();
    let mut last_driver_view = None;
    let mut targets: Vec<(u64, [f32; AXES])> = Vec::new();
    let mut lines_sent = 0u64;
    let mut bytes_in = 0u64;
    let mut checker = TickChecker::new(cfg);
    let mut prev_status: Option<kernel::Status<f32>> = None;
    let mut t: u64 = 0;
    loop {
        let end = sc.end.resolve(&occ).unwrap_or(sc.max_ms).min(sc.max_ms);
        if t >= end {
            break;
        }
        if t.is_multiple_of(500) {
            progress(t as f64 / end.max(1) as f64);
        }
        let mut input: Vec<u8> = Vec::new();
        // Scripted actions due now.
        for (k, (when, action)) in sc.actions.iter().enumerate() {
            if fired[k] || when.resolve(&occ).is_none_or(|at| at > t) {
                continue;
            }
            fired[k] = true;
            let pose_now = || -> [f64; AXES] {
                match &last_driver_view {
                    Some(v) => {
                        let v: &crate::client::DriverView = v;
                        v.position
                    }
                    None => trace.last().map(|s: &Sample| s.est.map(f64::from)).unwrap_or([0.0; AXES]),
                }
            };
            match action {
                Action::Send(b) => {
                    if hosts.cable {
                        input.extend_from_slice(b);
                    }
                }
                Action::Stream { client, rate_hz, duration_ms, motion } => streams.push(Stream {
                    client: *client,
                    start: t,
                    end: t + duration_ms,
                    period: 1000.0 / rate_hz,
                    next: t as f64,
                    motion: *motion,
                    p0: pose_now(),
                    finished: false,
                }),
                Action::Goto { client, pose } => {
                    let l = hosts.frame(*client, pose, &[0.0; AXES]);
                    if hosts.cable {
                        input.extend_from_slice(l.as_bytes());
                    }
                }
                Action::Cable(c) => {
                    hosts.cable = *c;
                    // Over USB the host sees the port close when the cable
                    // goes (and the firmware's main loop tells the kernel the
                    // link is lost); a UART cannot tell.
                    if !opts.serial1 {
                        root.port.open = *c;
                    }
                }
                Action::Glitch { joint, offset, frames } => root.board.plant.glitch(*joint, *offset, *frames),
                Action::Encoder(j, line) => root.board.plant.set_line(*j, *line),
                Action::Switch(j, f) => root.board.plant.force_switch(*j, *f),
                Action::Runaway(j, v) => root.board.plant.set_disturbance(*j, *v),
                Action::LostSteps(j, f) => root.board.plant.set_lost_steps(*j, *f),
                Action::CableSilent => hosts.cable = false,
                Action::ReverseDir(j, on) => root.board.plant.set_dir_inverted(*j, *on),
                Action::Noise(n) => root.board.plant.set_noise(*n),
            }
        }
        // Streams.
        let mut reference = [f32::NAN; AXES];
        for s in streams.iter().filter(|s| !s.finished) {
            reference = stream_pose(s, t).map(|x| x as f32);
        }
        for s in streams.iter_mut().filter(|s| !s.finished) {
            if (t as f64) + 1e-9 < s.next {
                continue;
            }
            s.next += s.period;
            let (p, v) = s.motion.sample(&s.p0, s.start, s.end, t);
            let last = t >= s.end;
            let l = hosts.frame(s.client, &p, &v);
            if hosts.cable {
                input.extend_from_slice(l.as_bytes());
            }
            s.finished = last;
        }
        bytes_in += input.len() as u64;
        let step = root.step(&input);
        // Record.
        let out = &step.out;
        let q = root.board.plant.q();
        let accepted = step.request == Some(RequestKind::Motion)
            && !out.events.iter().any(|e| matches!(e, Event::Rejected { request: RequestKind::Motion, .. }));
        if accepted {
            if let Some(tg) = step.target {
                targets.push((t, tg.position));
            }
        }
        trace.push(Sample {
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
        // The run's statistics, from this sample (and the one before), while
        // it is at hand.
        if let [.., w0, s] = trace.as_slice() {
            for (i, a) in accel.iter_mut().enumerate() {
                if let Some(dv) = accel_step(w0, s, i) {
                    *a = a.max(dv * f64::from(cfg.config().tick_hz));
                }
            }
        }
        if let Some(s) = trace.last() {
            if s.accepted {
                burst_len = if last_acc.is_some_and(|a| s.t - a <= 100) { burst_len + 1 } else { 1 };
                last_acc = Some(s.t);
                acc.push(s.t);
            }
            if s.request_ok {
                req_ok.push(s.t);
            }
            let following = s.state == State::Operational && last_acc.is_some_and(|a| s.t - a <= 50) && burst_len >= 2;
            if following {
                for i in 0..AXES {
                    err[i].add(f64::from(s.sp[i]) - f64::from(s.q[i]));
                    if s.reference[i].is_finite() {
                        err_ref[i].add(f64::from(s.reference[i]) - f64::from(s.q[i]));
                    }
                }
            }
        }
        for e in out.events.iter() {
            match e {
                Event::Fault(r) => {
                    faults.push((t, fault_text(r)));
                    fault_reasons.push(*r);
                }
                Event::Rejected { request, reason } => {
                    *refusals.entry(format!("{request:?}: {reason:?}")).or_default() += 1;
                }
                Event::Enabled(_) => occ[Anchor::Enabled.index()].push(t),
                _ => {}
            }
        }
        let ps = prev_status;
        if out.status.homing == HomingStatus::Complete && ps.is_none_or(|p| p.homing != HomingStatus::Complete) {
            occ[Anchor::Homed.index()].push(t);
        }
        for (st, a) in [(State::SoftEstop, Anchor::Estop), (State::Fault, Anchor::Fault)] {
            if out.status.state == st && ps.is_none_or(|p| p.state != st) {
                occ[a.index()].push(t);
            }
        }
        let views: Vec<Option<crate::client::DriverView>> = step.lines.iter().map(|l| driver_view(l)).collect();
        let driver_reads: Vec<bool> = views.iter().map(Option::is_some).collect();
        let bad = checker.check_read(&step, &driver_reads);
        for b in bad {
            violation_count += 1;
            if violations.len() < 50 {
                violations.push((t, b));
            }
        }
        prev_status = Some(step.out.status);
        for (l, view) in step.lines.into_iter().zip(views) {
            lines_sent += 1;
            for key in ["REJECT", "STALE_CMD", "QUEUE_FULL", "SEQ_RESYNC"] {
                if l.starts_with(key) {
                    // Group by reason: drop the running count.
                    let reason = l.split(" count=").next().unwrap_or(&l).trim_end().to_string();
                    let reason = if key == "STALE_CMD" {
                        format!(
                            "STALE_CMD {}",
                            l.split("reason=").nth(1).and_then(|r| r.split(' ').next()).unwrap_or("")
                        )
                    } else if key == "SEQ_RESYNC" {
                        format!(
                            "SEQ_RESYNC {}",
                            l.split("reason=").nth(1).and_then(|r| r.split(' ').next()).unwrap_or("")
                        )
                    } else {
                        reason
                    };
                    *wire.entry(reason).or_default() += 1;
                }
            }
            if let Some(v) = view {
                last_driver_view = Some(v);
            }
            if all_lines.len() < 200_000 {
                all_lines.push((t, l));
            }
        }
        t += 1;
    }
    progress(1.0);

    // (The tracking errors, the largest accelerations and the accepted
    // requests' times were accumulated tick by tick, above.)
    let mut stops: Vec<(u64, Option<u64>)> = Vec::new();
    for (k, &a) in acc.iter().enumerate() {
        let next = acc.get(k + 1).copied();
        if next.is_some_and(|n| n - a <= 100) {
            continue;
        }
        let until = req_ok.iter().copied().find(|&r| r > a).unwrap_or(t);
        let mut still_from: Option<u64> = None;
        for s in from_t(&trace, a.saturating_add(1)).iter().take_while(|s| s.t < until) {
            if s.still {
                still_from.get_or_insert(s.t);
            } else {
                still_from = None;
            }
        }
        stops.push((a, still_from.map(|s| s - a)));
    }
    // Goal error of the last burst: its last target vs the true position
    // when the outputs stopped (or at the end).
    let goal = stops.last().and_then(|&(a, dt)| {
        let tg = targets.iter().rev().find(|(ta, _)| *ta == a)?.1;
        let at = a + dt.unwrap_or(0);
        let s = from_t(&trace, at).first().or(trace.last())?;
        Some((0..AXES).map(|i| (f64::from(tg[i]) - f64::from(s.q[i])).abs()).fold(0.0, f64::max))
    });

    let counters = root.counters();
    let rejected_total = u64::from(counters.rejected)
        + u64::from(counters.seq.duplicates)
        + u64::from(counters.seq.behind)
        + u64::from(root.queue_refused())
        + refusals.values().sum::<u64>();

    // Expectations.
    let state_at = |at: u64| from_t(&trace, at).first().map(|s| s.state);
    let mut expectations = Vec::new();
    let cfgc = cfg.config();
    let window = |w: &When| w.resolve(&occ);
    for outer in &sc.expects {
        let (pending, e) = match outer {
            Expect::Pending(inner) => (true, inner.as_ref()),
            e => (false, e),
        };
        let (ok, detail) = match e {
            Expect::NoFault => (faults.is_empty(), format!("{} fault(s)", faults.len())),
            Expect::Fault(kind, j) => {
                let hit = fault_reasons.iter().any(|r| fault_matches(kind, *j, r));
                (
                    hit,
                    if faults.is_empty() {
                        "no fault".into()
                    } else {
                        faults.iter().map(|f| f.1.clone()).collect::<Vec<_>>().join("; ")
                    },
                )
            }
            Expect::State(w, name) => match w.resolve(&occ) {
                None => (false, format!("{w} never happened")),
                Some(at) => {
                    let at = at.min(t.saturating_sub(1));
                    let st = state_at(at).map(protocol::report::state_name).unwrap_or("none");
                    (st == name, format!("{st} at {at} ms"))
                }
            },
            Expect::HomedBy(w) => {
                let h = occ[Anchor::Homed.index()].first().copied();
                match (h, w.resolve(&occ)) {
                    (Some(h), Some(by)) => (h <= by, format!("H2 at {h} ms")),
                    (None, _) => (false, "never homed".into()),
                    (Some(h), None) => (false, format!("H2 at {h} ms, {w} never happened")),
                }
            }
            Expect::StopWithin(ms) => {
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
            Expect::GoalWithin(r) => match goal {
                Some(g) => (g < *r, format!("{g:.4} rad")),
                None => (false, "no goal".into()),
            },
            Expect::RejectedAtLeast(n) => (rejected_total >= *n, format!("{rejected_total} rejected")),
            Expect::Line(text) => {
                let hit = all_lines.iter().find(|(_, l)| l.contains(text.as_str()));
                (hit.is_some(), hit.map(|(t, l)| format!("at {t} ms: {}", l.trim_end())).unwrap_or("not found".into()))
            }
            Expect::NoLine(text) => {
                let hit = all_lines.iter().find(|(_, l)| l.contains(text.as_str()));
                (hit.is_none(), hit.map(|(t, l)| format!("at {t} ms: {}", l.trim_end())).unwrap_or("none".into()))
            }
            Expect::MovingAfter(w) => match w.resolve(&occ) {
                None => (false, format!("{w} never happened")),
                Some(at) => {
                    let m = from_t(&trace, at.saturating_add(1)).iter().find(|s| !s.still);
                    (m.is_some(), m.map(|s| format!("moving at {} ms", s.t)).unwrap_or("never moved".into()))
                }
            },
            Expect::FaultWithin(w, ms, kind, j) => match window(w) {
                None => (false, format!("{w} never happened")),
                Some(at) => {
                    let hit = faults
                        .iter()
                        .zip(fault_reasons.iter())
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
            Expect::LineWithin(w, ms, text) => match window(w) {
                None => (false, format!("{w} never happened")),
                Some(at) => {
                    let hit = all_lines.iter().find(|(t, l)| *t >= at && *t <= at + ms && l.contains(text.as_str()));
                    match hit {
                        Some((t, l)) => (true, format!("at {t} ms ({} ms after {at} ms): {}", t - at, l.trim_end())),
                        None => {
                            let later = all_lines.iter().find(|(t, l)| *t >= at && l.contains(text.as_str()));
                            (false, later.map(|(t, _)| format!("first at {t} ms")).unwrap_or("not found".into()))
                        }
                    }
                }
            },
            Expect::LineSequence(texts) => {
                let mut from = 0usize;
                let mut found = Vec::new();
                for text in texts {
                    match all_lines.iter().enumerate().skip(from).find(|(_, (_, l))| l.contains(text.as_str())) {
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
            Expect::ExcursionBelow(j, w, bound) => match window(w) {
                None => (false, format!("{w} never happened")),
                Some(at) => match from_t(&trace, at).first() {
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
            Expect::StillBetween(a, b) => match (window(a), window(b)) {
                (Some(a), Some(b)) => {
                    let m = from_t(&trace, a).iter().take_while(|s| s.t <= b).find(|s| !s.still);
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
            Expect::AtTargetWithin(w, bound) => match window(w) {
                None => (false, format!("{w} never happened")),
                Some(at) => {
                    let tg = targets.iter().rev().find(|(ta, _)| *ta <= at);
                    let s = from_t(&trace, at.min(t.saturating_sub(1))).first();
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
            Expect::AccelWithinLimits(a, b) => match (window(a), window(b)) {
                (Some(a), Some(b)) => {
                    let mut worst: Option<(f64, usize, u64)> = None;
                    let mut bad: Option<(f64, usize, u64)> = None;
                    // (Only the windows ending in (a, b]: from the sample
                    // before the first after `a` to the last up to `b`.)
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
                    let show =
                        |x: (f64, usize, u64)| format!("{:.0} % of J{}'s limit at {} ms", x.0 * 100.0, x.1 + 1, x.2);
                    match (bad, worst) {
                        (Some(x), _) => (false, format!("first over: {}", show(x))),
                        (None, Some(x)) => (true, format!("largest {}", show(x))),
                        (None, None) => (false, "empty window".into()),
                    }
                }
                _ => (false, format!("{a} or {b} never happened")),
            },
            Expect::Pending(_) => (false, "`pending` does not nest".into()),
        };
        if pending {
            let verdict =
                if ok { "now HOLDS: remove `pending`" } else { "fails, as the reported kernel defect predicts" };
            expectations.push((outer.to_string(), true, format!("{verdict}; {detail}")));
        } else {
            expectations.push((e.to_string(), ok, detail));
        }
    }

    Report {
        name: sc.name.clone(),
        description: sc.description.clone(),
        // A USB scenario on the Serial1 main loop: a UART cannot tell a
        // pulled cable, so what it expects of the link loss cannot hold.
        informational: sc.informational || (sc.usb_only && opts.serial1),
        decode: if opts.serial1 {
            "frame capture (shipped decoder), Serial1 host"
        } else {
            "frame capture (shipped decoder), USB host"
        }
        .to_string(),
        duration_ms: t,
        homed_at: occ[Anchor::Homed.index()].first().copied(),
        tracking: err,
        tracking_ref: err_ref,
        max_accel: accel,
        stops,
        goal_error: goal,
        faults,
        refusals,
        wire,
        rejected_total,
        protocol: counters,
        violations,
        violation_count,
        expectations,
        decode_stats: root.decode_stats(),
        lines_sent,
        bytes_in,
        commands_accepted: acc.len() as u64,
        targets,
        lines: all_lines,
        trace,
        plot: None,
    }
}
