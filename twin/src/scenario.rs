//! Simulator scenarios (`sim/scenarios/*.scn`, the language of
//! `sim/README.md`, parsed by the simulator's own parser) run on the twin:
//! the shipped image instead of the simulator's host build of the root.
//!
//! Supported actions: `send`, `stream driver|configurator RATE DUR cosine
//! ...|jog ...` and `goto` (the simulator's own line formatting,
//! `sim::client`, and its stream shapes, from the pose of the last driver
//! feedback line as the simulator does), `cable pull|plug` (bytes sent while
//! pulled are lost), `switch N press|release|auto`, `encoder N ok|low|high`
//! (low and high both as a cut line: the twin's plant has no stuck-high),
//! and the time anchors `homed`, `fault`, `estop`, `enabled` (taken from the
//! image's event lines on Serial1: `HOMING_DONE`, `FAULT`, `STOPPED` after
//! `SOFT_ESTOP`, `ENABLED`). Glitches, runaway, lost steps and noise are reported as
//! skipped; a scenario that needs one is not comparable. Bytes go over the
//! modelled 115 200 baud line, so a command reaches the image later than in
//! the simulator (which hands them over at once): ~7 ms for a driver line.

use kernel::config::AXES;
use sim::client::driver_view;
use sim::scenario::{Action, Anchor, Expect, Scenario};
use sim::stream::{Hosts, Stream};

use crate::{Plant, Twin, MS};

/// What a scenario run on the twin produced.
#[derive(Clone, Debug, Default)]
pub struct Outcome {
    /// Serial1 lines that are not feedback (events, banner), with the time
    /// (ms) their first byte left the UART.
    pub events: Vec<(u64, String)>,
    /// Occurrences of each anchor (ms), indexed like `Anchor::index`.
    pub anchors: [Vec<u64>; Anchor::ALL.len()],
    /// Simulated duration (ms).
    pub end_ms: u64,
    /// Joint angles at the end (rad).
    pub q: [f64; 6],
    /// Actions the twin cannot perform.
    pub skipped: Vec<String>,
    /// Wall-clock seconds.
    pub wall_s: f64,
    /// Instructions of each PIT handler call (the whole tick interrupt).
    pub pit_instructions: Vec<u64>,
    /// The PIT handler's instructions by function, largest first.
    pub pit_profile: Vec<(String, u64)>,
}

/// The anchor an event line marks. The simulator's `estop` anchor is the
/// tick the state becomes `SoftEstop`, at the end of the stopping ramp: the
/// `STOPPED` line after a `SOFT_ESTOP` (not the `SOFT_ESTOP` line itself,
/// which starts the ramp).
fn anchor_of(line: &str, estop_pending: &mut bool) -> Option<Anchor> {
    if line.starts_with("HOMING_DONE") {
        Some(Anchor::Homed)
    } else if line.starts_with("FAULT") {
        *estop_pending = false;
        Some(Anchor::Fault)
    } else if line.starts_with("SOFT_ESTOP") {
        *estop_pending = true;
        None
    } else if line.starts_with("STOPPED") && std::mem::take(estop_pending) {
        Some(Anchor::Estop)
    } else if line.starts_with("ENABLED") {
        Some(Anchor::Enabled)
    } else {
        None
    }
}

/// The simulator's start pose and switch positions for `sc`.
pub fn plant_for(sc: &Scenario) -> Plant {
    let cfg = &kernel::config::PAROL6;
    let mut opts = sim::plant::PlantOptions::new(cfg);
    if let Some(p) = sc.pose {
        opts.start = p;
    }
    let mut plant = Plant::new(cfg, opts.start);
    for &(j, a) in &sc.switch_at {
        if let Some(joint) = plant.joints.get_mut(j) {
            joint.switch_at = a;
        }
    }
    plant
}

/// Run `sc` on the image `elf`, 1 ms at a time, until its `end` (or `max`).
pub fn run(sc: &Scenario, elf: &[u8]) -> Result<Outcome, String> {
    let mut t = Twin::new(elf, plant_for(sc))?;
    let wall = std::time::Instant::now();
    let mut out = Outcome::default();
    let mut fired = vec![false; sc.actions.len()];
    let mut consumed = 0usize; // bytes of tx_out already split into lines
    let mut line = String::new();
    let mut line_t: Option<u64> = None;
    let mut ms = 0u64;
    let mut streams: Vec<Stream> = Vec::new();
    let mut hosts = Hosts::default();
    let mut cable = true;
    let mut last_view: Option<[f64; AXES]> = None;
    let mut estop_pending = false;
    loop {
        let end = sc.end.resolve(&out.anchors);
        if ms >= sc.max_ms || end.is_some_and(|e| ms >= e) {
            break;
        }
        for (k, (when, action)) in sc.actions.iter().enumerate() {
            if fired[k] || when.resolve(&out.anchors).is_none_or(|at| at > ms) {
                continue;
            }
            fired[k] = true;
            let pose_now = last_view.unwrap_or(t.board().plant.q());
            let b = t.board_mut();
            match action {
                Action::Send(bytes) if cable => b.serial_send(bytes),
                Action::Send(_) => {}
                Action::Stream { client, rate_hz, duration_ms, motion, burst } => {
                    streams.push(Stream::new(*client, *rate_hz, *duration_ms, *motion, ms, pose_now).with_burst(*burst))
                }
                Action::Goto { client, pose } => {
                    let l = hosts.frame(*client, pose, &[0.0; AXES]);
                    if cable {
                        b.serial_send(l.as_bytes());
                    }
                }
                Action::Cable(c) => cable = *c,
                Action::Switch(j, force) => b.plant.joints[*j].force_switch = *force,
                Action::Encoder(j, l) => b.plant.joints[*j].encoder_cut = !matches!(l, sim::encoder::Line::Ok),
                other => out.skipped.push(format!("{when} {other:?}")),
            }
        }
        for l in hosts.due(&mut streams, ms) {
            if cable {
                t.board_mut().serial_send(l.as_bytes());
            }
        }
        ms += 1;
        t.run_until(ms * MS).map_err(|f| f.to_string())?;
        let tx = &t.board().uart.tx_out;
        for &(done, byte) in &tx[consumed..] {
            if byte == b'\n' {
                let l = std::mem::take(&mut line);
                let at = line_t.take().unwrap_or(done) / MS;
                if let Some(v) = driver_view(&l) {
                    last_view = Some(v.position);
                } else if !l.starts_with('<') && !l.starts_with(' ') {
                    if let Some(a) = anchor_of(&l, &mut estop_pending) {
                        out.anchors[a.index()].push(at);
                    }
                    out.events.push((at, l));
                }
            } else if byte != b'\r' {
                line_t.get_or_insert(done);
                line.push(char::from(byte));
            }
        }
        consumed = tx.len();
    }
    out.end_ms = ms;
    out.q = t.board().plant.q();
    out.wall_s = wall.elapsed().as_secs_f64();
    out.pit_instructions = t.stats.pit_instructions.clone();
    out.pit_profile = t.pit_profile();
    Ok(out)
}

/// One expectation of a scenario as the twin judges it.
#[derive(Clone, Debug)]
pub struct Check {
    /// The expectation, as the simulator prints it.
    pub what: String,
    /// Held or failed; `None` where the twin cannot observe it (it needs
    /// the simulator's per-tick trace: states, speeds, tracking, targets).
    pub held: Option<bool>,
    /// What was found.
    pub detail: String,
}

/// The fault lines among the events: (ms, reason after `FAULT ` or
/// `HOMING_FAULT `).
fn fault_lines(o: &Outcome) -> Vec<(u64, &str)> {
    o.events
        .iter()
        .filter_map(|(t, l)| l.strip_prefix("FAULT ").or_else(|| l.strip_prefix("HOMING_FAULT ")).map(|r| (*t, r)))
        .collect()
}

/// A fault reason on the wire (`LIMIT_SWITCH J2`) is of the scenario's
/// `kind` (`limit-switch`, `encoder` for lost or jump, `any`) and joint.
fn fault_is(kind: &str, joint: Option<usize>, reason: &str) -> bool {
    let kind_ok = match kind {
        "any" => true,
        "encoder" => reason.starts_with("ENCODER_LOST") || reason.starts_with("ENCODER_JUMP"),
        k => reason.starts_with(&k.to_ascii_uppercase().replace('-', "_")),
    };
    kind_ok && joint.is_none_or(|j| reason.split_whitespace().any(|w| w == format!("J{}", j + 1)))
}

/// Judges `sc`'s expectations on the twin's outcome `o`: faults, anchors
/// and the event lines (the lines that are not feedback) are observable;
/// the rest is reported as not checked.
pub fn check(sc: &Scenario, o: &Outcome) -> Vec<Check> {
    let mut out = Vec::new();
    for outer in &sc.expects {
        let (pending, e) = match outer {
            Expect::Pending(inner) => (true, inner.as_ref()),
            e => (false, e),
        };
        let (held, detail) = judge(e, o);
        if pending {
            let verdict = match held {
                Some(true) => "now HOLDS: remove `pending`",
                Some(false) => "fails, as the reported kernel defect predicts",
                None => "not observable on the twin",
            };
            out.push(Check {
                what: outer.to_string(),
                held: held.map(|_| true),
                detail: format!("{verdict}; {detail}"),
            });
        } else {
            out.push(Check { what: e.to_string(), held, detail });
        }
    }
    out
}

fn judge(e: &Expect, o: &Outcome) -> (Option<bool>, String) {
    let faults = fault_lines(o);
    let events = |text: &str| o.events.iter().find(|(_, l)| l.contains(text));
    let listed = || faults.iter().map(|(t, r)| format!("{r} at {t} ms")).collect::<Vec<_>>().join("; ");
    match e {
        Expect::NoFault => (Some(faults.is_empty()), format!("{} fault line(s) {}", faults.len(), listed())),
        Expect::Fault(kind, j) => {
            let hit = faults.iter().any(|(_, r)| fault_is(kind, *j, r));
            (Some(hit), if faults.is_empty() { "no fault line".into() } else { listed() })
        }
        Expect::FaultWithin(w, ms, kind, j) => match w.resolve(&o.anchors) {
            None => (Some(false), format!("{w} never happened")),
            Some(at) => {
                let hit = faults.iter().find(|(t, r)| *t >= at && *t <= at + ms && fault_is(kind, *j, r));
                match hit {
                    Some((t, r)) => (Some(true), format!("{r} at {t} ms ({} ms after {at} ms)", t - at)),
                    None => (Some(false), if faults.is_empty() { "no fault line".into() } else { listed() }),
                }
            }
        },
        Expect::HomedBy(w) => {
            let h = o.anchors[Anchor::Homed.index()].first().copied();
            match (h, w.resolve(&o.anchors)) {
                (Some(h), Some(by)) => (Some(h <= by), format!("HOMING_DONE at {h} ms")),
                (None, _) => (Some(false), "never homed".into()),
                (Some(h), None) => (Some(false), format!("HOMING_DONE at {h} ms, {w} never happened")),
            }
        }
        // Feedback lines (`<...`) are not kept: only event-line texts.
        Expect::Line(text) | Expect::NoLine(text) | Expect::LineWithin(_, _, text) if text.starts_with('<') => {
            (None, "feedback lines are not kept by the twin".into())
        }
        Expect::Line(text) => {
            let hit = events(text);
            (Some(hit.is_some()), hit.map(|(t, l)| format!("at {t} ms: {l}")).unwrap_or("not found".into()))
        }
        Expect::NoLine(text) => {
            let hit = events(text);
            (Some(hit.is_none()), hit.map(|(t, l)| format!("at {t} ms: {l}")).unwrap_or("none".into()))
        }
        Expect::LineWithin(w, ms, text) => match w.resolve(&o.anchors) {
            None => (Some(false), format!("{w} never happened")),
            Some(at) => {
                let hit = o.events.iter().find(|(t, l)| *t >= at && *t <= at + ms && l.contains(text.as_str()));
                match hit {
                    Some((t, l)) => (Some(true), format!("at {t} ms ({} ms after {at} ms): {l}", t - at)),
                    None => (Some(false), "not found in the window".into()),
                }
            }
        },
        Expect::LineSequence(texts) => {
            let mut from = 0usize;
            let mut found = Vec::new();
            for text in texts {
                match o.events.iter().enumerate().skip(from).find(|(_, (_, l))| l.contains(text.as_str())) {
                    Some((k, (t, _))) => {
                        found.push(format!("{text:?} at {t} ms"));
                        from = k + 1;
                    }
                    None => {
                        found.push(format!("{text:?} not found after that"));
                        return (Some(false), found.join(", "));
                    }
                }
            }
            (Some(true), found.join(", "))
        }
        _ => (None, "not observable on the twin (needs the simulator's per-tick trace)".into()),
    }
}
