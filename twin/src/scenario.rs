//! Simulator scenarios (`sim/scenarios/*.scn`, the language of
//! `sim/README.md`, parsed by the simulator's own parser) run on the twin:
//! the shipped image instead of the simulator's host build of the root.
//!
//! Supported actions: `send`, `switch N press|release|auto`, `encoder N
//! ok|low|high` (low and high both as a cut line: the twin's plant has no
//! stuck-high), and the time anchors `homed`, `fault`, `estop`, `enabled`
//! (taken from the image's event lines on Serial1: `HOMING_DONE`, `FAULT`,
//! `SOFT_ESTOP`, `ENABLED`). Everything else (streams, go-to, cable,
//! glitches, runaway, lost steps, noise) is reported as skipped; a scenario
//! that needs one is not comparable.

use sim::scenario::{Action, Anchor, Scenario};

use crate::{Plant, Twin, MS};

/// What a scenario run on the twin produced.
#[derive(Clone, Debug, Default)]
pub struct Outcome {
    /// Serial1 lines that are not feedback (events, banner), with the time
    /// (ms) their first byte left the UART.
    pub events: Vec<(u64, String)>,
    /// Occurrences of each anchor (ms), indexed like `Anchor::index`.
    pub anchors: [Vec<u64>; 4],
    /// Simulated duration (ms).
    pub end_ms: u64,
    /// Joint angles at the end (rad).
    pub q: [f64; 6],
    /// Actions the twin cannot perform.
    pub skipped: Vec<String>,
    /// Wall-clock seconds.
    pub wall_s: f64,
}

fn anchor_of(line: &str) -> Option<Anchor> {
    if line.starts_with("HOMING_DONE") {
        Some(Anchor::Homed)
    } else if line.starts_with("FAULT") {
        Some(Anchor::Fault)
    } else if line.starts_with("SOFT_ESTOP") {
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
            let b = t.board_mut();
            match action {
                Action::Send(bytes) => b.serial_send(bytes),
                Action::Switch(j, force) => b.plant.joints[*j].force_switch = *force,
                Action::Encoder(j, l) => b.plant.joints[*j].encoder_cut = !matches!(l, sim::encoder::Line::Ok),
                other => out.skipped.push(format!("{when} {other:?}")),
            }
        }
        ms += 1;
        t.run_until(ms * MS).map_err(|f| f.to_string())?;
        let tx = &t.board().uart.tx_out;
        for &(done, byte) in &tx[consumed..] {
            if byte == b'\n' {
                let l = std::mem::take(&mut line);
                let at = line_t.take().unwrap_or(done) / MS;
                if !l.starts_with('<') && !l.starts_with(' ') {
                    if let Some(a) = anchor_of(&l) {
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
    Ok(out)
}
