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
use crate::scenario::{Action, Anchor, Client, Expect, Motion, Scenario};

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
    /// All outputs zero.
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
    let el = (t.min(s.end) - s.start) as f64 / 1000.0;
    match s.motion {
        Motion::Cosine { period_ms, amp } => {
            let w = std::f64::consts::TAU / (period_ms as f64 / 1000.0);
            std::array::from_fn(|i| s.p0[i] + amp[i] * (1.0 - (w * el).cos()) / 2.0)
        }
        Motion::Jog { joint, vel } => {
            let mut p = s.p0;
            p[joint] += vel * el;
            p
        }
    }
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
/// and returned, plus the wire checks only the simulator can make (no
/// `nan`/`inf`, printable bytes, every `<` line readable by its client).
#[derive(Clone, Debug)]
pub struct TickChecker {
    monitor: Monitor<f32>,
}

impl TickChecker {
    /// A checker for a kernel on `cfg`, created with it.
    pub fn new(cfg: &Validated) -> Self {
        TickChecker { monitor: Monitor::new(cfg.config()) }
    }

    /// Checks one step (call for every step, in order); returns the
    /// violations.
    pub fn check(&mut self, step: &Step) -> Vec<String> {
        let mut bad = Vec::new();
        let sent = step.request.map(|k| match (k, step.target) {
            (RequestKind::Motion, Some(t)) => Sent::Motion(Some(t)),
            (k, _) => Sent::from_kind(k),
        });
        if let Err(v) = self.monitor.check(&step.sense, sent.as_ref(), &step.out, Some(&step.phases), None) {
            bad.push(v.to_string());
        }
        for l in &step.lines {
            let low = l.to_ascii_lowercase();
            if low.contains("nan") || low.contains("inf") {
                bad.push(format!("line contains nan/inf: {}", l.trim_end()));
            }
            if !l.bytes().all(|b| b == b'\n' || (0x20..0x7f).contains(&b)) {
                bad.push(format!("line with non-printable bytes: {l:?}"));
            }
            let t = l.trim_start();
            if t.starts_with('<') && driver_view(l).is_none() && !crate::client::configurator_matches(l) {
                bad.push(format!("feedback line neither client can read: {}", l.trim_end()));
            }
            if l.starts_with('<') && driver_view(l).is_none() {
                bad.push(format!("a line starting with `<` that the driver would take and reject: {}", l.trim_end()));
            }
        }
        bad
    }
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
                Action::Cable(c) => hosts.cable = *c,
                Action::Glitch { joint, offset, frames } => root.board.plant.glitch(*joint, *offset, *frames),
                Action::Encoder(j, line) => root.board.plant.set_line(*j, *line),
                Action::Switch(j, f) => root.board.plant.force_switch(*j, *f),
                Action::Runaway(j, v) => root.board.plant.set_disturbance(*j, *v),
                Action::LostSteps(j, f) => root.board.plant.set_lost_steps(*j, *f),
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
            let el = (t.min(s.end) - s.start) as f64 / 1000.0;
            let done = t >= s.end;
            let p = stream_pose(s, t);
            let v = match s.motion {
                Motion::Cosine { period_ms, amp } => {
                    let w = std::f64::consts::TAU / (period_ms as f64 / 1000.0);
                    std::array::from_fn(|i| amp[i] * w * (w * el).sin() / 2.0)
                }
                Motion::Jog { joint, vel } => {
                    let mut v = [0.0; AXES];
                    if !done {
                        v[joint] = vel;
                    }
                    v
                }
            };
            let last = done;
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
            still: out.act.step_rate.iter().all(|r| *r == 0),
            accepted,
            request_ok: step.request.is_some() && !out.events.iter().any(|e| matches!(e, Event::Rejected { .. })),
            reference,
        });
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
        for l in &step.lines {
            lines_sent += 1;
            for key in ["REJECT", "STALE_CMD", "QUEUE_FULL", "SEQ_RESYNC"] {
                if l.starts_with(key) {
                    // Group by reason: drop the running count.
                    let reason = l.split(" count=").next().unwrap_or(l).trim_end().to_string();
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
            if let Some(v) = driver_view(l) {
                last_driver_view = Some(v);
            }
            if all_lines.len() < 200_000 {
                all_lines.push((t, l.clone()));
            }
        }
        prev_status = Some(step.out.status);
        let bad = checker.check(&step);
        for b in bad {
            violation_count += 1;
            if violations.len() < 50 {
                violations.push((t, b));
            }
        }
        t += 1;
    }
    progress(1.0);

    // Tracking: set-point vs true position while following a stream
    // (Operational, a motion accepted within the last 50 ms).
    let mut err = [JointError::default(); AXES];
    let mut err_ref = [JointError::default(); AXES];
    // Largest commanded acceleration per joint while Operational (rad/s^2).
    let mut accel = [0.0f64; AXES];
    for w in trace.windows(2) {
        if w[1].state == State::Operational {
            for (i, a) in accel.iter_mut().enumerate() {
                let dv = (f64::from(w[1].v[i]) - f64::from(w[0].v[i])).abs() * f64::from(cfg.config().tick_hz);
                *a = a.max(dv);
            }
        }
    }
    let mut last_acc: Option<u64> = None;
    let mut burst_len = 0u32;
    for s in &trace {
        if s.accepted {
            burst_len = if last_acc.is_some_and(|a| s.t - a <= 100) { burst_len + 1 } else { 1 };
            last_acc = Some(s.t);
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
    // Stop episodes: the last accepted motion before a gap of > 100 ms, to
    // the first tick from which every output stays zero until the next one.
    // (A later accepted request of any kind - HOME, ENABLE - also ends the window.)
    let acc: Vec<u64> = trace.iter().filter(|s| s.accepted).map(|s| s.t).collect();
    let req_ok: Vec<u64> = trace.iter().filter(|s| s.request_ok).map(|s| s.t).collect();
    let mut stops: Vec<(u64, Option<u64>)> = Vec::new();
    for (k, &a) in acc.iter().enumerate() {
        let next = acc.get(k + 1).copied();
        if next.is_some_and(|n| n - a <= 100) {
            continue;
        }
        let until = req_ok.iter().copied().find(|&r| r > a).unwrap_or(t);
        let mut still_from: Option<u64> = None;
        for s in trace.iter().filter(|s| s.t > a && s.t < until) {
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
        let s = trace.iter().find(|s| s.t >= at).or(trace.last())?;
        Some((0..AXES).map(|i| (f64::from(tg[i]) - f64::from(s.q[i])).abs()).fold(0.0, f64::max))
    });

    let counters = root.counters();
    let rejected_total = u64::from(counters.rejected)
        + u64::from(counters.seq.duplicates)
        + u64::from(counters.seq.behind)
        + u64::from(root.queue_refused())
        + refusals.values().sum::<u64>();

    // Expectations.
    let state_at = |at: u64| trace.iter().find(|s| s.t >= at).map(|s| s.state);
    let mut expectations = Vec::new();
    for e in &sc.expects {
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
                    let m = trace.iter().find(|s| s.t > at && !s.still);
                    (m.is_some(), m.map(|s| format!("moving at {} ms", s.t)).unwrap_or("never moved".into()))
                }
            },
        };
        expectations.push((e.to_string(), ok, detail));
    }

    Report {
        name: sc.name.clone(),
        description: sc.description.clone(),
        informational: sc.informational,
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
        lines: all_lines,
        trace,
        plot: None,
    }
}
