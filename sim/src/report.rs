//! Scenario reports: the per-scenario text file and the summary table.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use kernel::config::AXES;

use crate::encoder::DecodeStats;
use crate::trace::Sample;

/// Tracking error statistics of one joint.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct JointError {
    /// Samples.
    pub n: u64,
    sum_sq: f64,
    max: f64,
}

impl JointError {
    /// Adds one error sample (rad).
    pub fn add(&mut self, e: f64) {
        self.n += 1;
        self.sum_sq += e * e;
        self.max = self.max.max(e.abs());
    }
    /// RMS (mrad).
    pub fn rms_mrad(&self) -> f64 {
        if self.n == 0 {
            0.0
        } else {
            (self.sum_sq / self.n as f64).sqrt() * 1000.0
        }
    }
    /// Max (mrad).
    pub fn max_mrad(&self) -> f64 {
        self.max * 1000.0
    }
}

/// Everything a scenario run measured.
#[derive(Clone, Debug)]
pub struct Report {
    /// Scenario name.
    pub name: String,
    /// Scenario description.
    pub description: String,
    /// Expectations do not decide the exit code.
    pub informational: bool,
    /// Encoder decode mode used.
    pub decode: String,
    /// Simulated time (ms).
    pub duration_ms: u64,
    /// First H2 (ms).
    pub homed_at: Option<u64>,
    /// Tracking error (set-point vs true joint angle) while following.
    pub tracking: [JointError; AXES],
    /// Tracking error against the host's continuous reference (includes the
    /// one-segment interpolation delay).
    pub tracking_ref: [JointError; AXES],
    /// Largest commanded acceleration per joint in every state, the fault
    /// tick and homing's switch stops excepted (rad/s^2).
    pub max_accel: [f64; AXES],
    /// (last command of a burst, ms to standstill).
    pub stops: Vec<(u64, Option<u64>)>,
    /// Goal error of the last burst (rad).
    pub goal_error: Option<f64>,
    /// Faults (ms, reason).
    pub faults: Vec<(u64, String)>,
    /// Requests the kernel refused, by reason.
    pub refusals: BTreeMap<String, u64>,
    /// Lines/frames the protocol rejected or dropped, by reason.
    pub wire: BTreeMap<String, u64>,
    /// All rejections (wire, sequence, queue, kernel).
    pub rejected_total: u64,
    /// Protocol counters.
    pub protocol: protocol::receiver::Counters,
    /// Safety violations (first 50): (ms, what).
    pub violations: Vec<(u64, String)>,
    /// Number of safety violations.
    pub violation_count: u64,
    /// (expectation, held, detail).
    pub expectations: Vec<(String, bool, String)>,
    /// Encoder decode statistics per joint.
    pub decode_stats: [DecodeStats; AXES],
    /// Lines sent by the firmware.
    pub lines_sent: u64,
    /// Bytes received by the firmware.
    pub bytes_in: u64,
    /// Motion commands accepted by the kernel.
    pub commands_accepted: u64,
    /// Accepted motion targets (ms, positions).
    pub targets: Vec<(u64, [f32; AXES])>,
    /// Lines sent (ms, line), for the log.
    pub lines: Vec<(u64, String)>,
    /// The per-tick trace.
    pub trace: Vec<Sample>,
    /// Where the plot was written.
    pub plot: Option<PathBuf>,
}

impl Report {
    /// Every safety requirement held at every tick.
    pub fn safe(&self) -> bool {
        self.violation_count == 0
    }
    /// Every expectation held.
    pub fn expectations_held(&self) -> bool {
        self.expectations.iter().all(|e| e.1)
    }
    /// This scenario makes the run fail.
    pub fn failed(&self) -> bool {
        !self.safe() || (!self.informational && !self.expectations_held())
    }
    /// Worst standstill time after a burst (ms), if every burst stopped.
    pub fn worst_stop(&self) -> Option<Option<u64>> {
        self.stops.iter().map(|s| s.1).max_by_key(|d| d.unwrap_or(u64::MAX))
    }

    /// The full text report.
    pub fn text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "scenario: {}", self.name);
        let _ = writeln!(s, "what: {}", self.description);
        let _ =
            writeln!(s, "encoder decode: {}; simulated time {:.1} s", self.decode, self.duration_ms as f64 / 1000.0);
        let _ = writeln!(
            s,
            "homing complete (H2): {}",
            self.homed_at.map(|t| format!("{:.3} s", t as f64 / 1000.0)).unwrap_or("never".into())
        );
        let _ = writeln!(s, "\ntracking error (kernel set-point vs true joint angle, while following a stream):");
        if self.tracking[0].n == 0 {
            let _ = writeln!(s, "  (no stream followed)");
        } else {
            let _ = writeln!(s, "  joint   RMS mrad   max mrad   samples   | vs host reference: RMS mrad   max mrad");
            for (i, (e, r)) in self.tracking.iter().zip(self.tracking_ref.iter()).enumerate() {
                let _ = writeln!(
                    s,
                    "  J{}    {:>8.3}   {:>8.3}   {:>7}   |                    {:>8.3}   {:>8.3}",
                    i + 1,
                    e.rms_mrad(),
                    e.max_mrad(),
                    e.n,
                    r.rms_mrad(),
                    r.max_mrad()
                );
            }
            let _ = writeln!(
                s,
                "  (the host reference is the stream's continuous trajectory at the same instant; the difference \
                 includes the interpolator's one-segment delay, by design)"
            );
        }
        let acc: Vec<String> = self.max_accel.iter().enumerate().map(|(i, a)| format!("J{} {a:.0}", i + 1)).collect();
        let _ = writeln!(
            s,
            "largest commanded acceleration, every state (rad/s^2, velocity change per tick x tick rate; fault ticks and homing's stops at a switch excluded): {}",
            acc.join(", ")
        );
        let _ = writeln!(s, "\nlast command to standstill (every commanded speed below 0.01 rad/s):");
        if self.stops.is_empty() {
            let _ = writeln!(s, "  (no command burst)");
        }
        for (a, d) in &self.stops {
            let d = d.map(|d| format!("{d} ms")).unwrap_or("never".into());
            let _ = writeln!(s, "  last command at {a} ms -> standstill after {d}");
        }
        if let Some(g) = self.goal_error {
            let _ = writeln!(s, "goal error of the last burst: {g:.4} rad");
        }
        let _ = writeln!(s, "\nfaults raised:");
        if self.faults.is_empty() {
            let _ = writeln!(s, "  none");
        }
        for (t, f) in &self.faults {
            let _ = writeln!(s, "  {t} ms: {f}");
        }
        let _ = writeln!(s, "\nframes rejected or dropped by the protocol (by reason):");
        if self.wire.is_empty() {
            let _ = writeln!(s, "  none");
        }
        for (r, n) in &self.wire {
            let _ = writeln!(s, "  {n:>6}  {r}");
        }
        let _ = writeln!(s, "requests refused by the kernel (by reason):");
        if self.refusals.is_empty() {
            let _ = writeln!(s, "  none");
        }
        for (r, n) in &self.refusals {
            let _ = writeln!(s, "  {n:>6}  {r}");
        }
        let c = &self.protocol;
        let _ = writeln!(
            s,
            "protocol counters: lines {} accepted {} rejected {} (too long {}, non-printable {}), duplicates {}, \
             behind {}, gap resyncs {}, jump resyncs {}, resets {}",
            c.framer.lines,
            c.accepted,
            c.rejected,
            c.framer.too_long,
            c.framer.non_printable,
            c.seq.duplicates,
            c.seq.behind,
            c.seq.gap_resyncs,
            c.seq.jump_resyncs,
            c.seq.resets
        );
        let _ = writeln!(
            s,
            "traffic: {} bytes in, {} lines out, {} motion commands accepted by the kernel",
            self.bytes_in, self.lines_sent, self.commands_accepted
        );
        let _ = writeln!(s, "\nencoder samples lost (per joint, by decode reason):");
        for (i, d) in self.decode_stats.iter().enumerate() {
            let parts: Vec<String> = DecodeStats::NAMES
                .iter()
                .zip(d.lost.iter())
                .filter(|(_, n)| **n > 0)
                .map(|(k, n)| format!("{k} {n}"))
                .collect();
            let _ = writeln!(s, "  J{}: ok {}, lost {} [{}]", i + 1, d.ok, d.lost_total(), parts.join(", "));
        }
        let _ = writeln!(
            s,
            "\nsafety requirements at every tick: {}",
            if self.safe() { "HELD".to_string() } else { format!("VIOLATED {} time(s)", self.violation_count) }
        );
        let _ = writeln!(
            s,
            "  (outputs finite and within max velocity and step-rate limits; zero in BOOT/UNHOMED/SOFT_ESTOP/FAULT; \
             homing order; soft-stop speed never increasing; fault tick zeroes all axes; no nan/inf and only \
             printable lines; every '<' line readable by a client)"
        );
        for (t, v) in &self.violations {
            let _ = writeln!(s, "  {t} ms: {v}");
        }
        let _ = writeln!(
            s,
            "\nexpectations{}:",
            if self.informational { " (informational: they do not decide the exit code)" } else { "" }
        );
        for (e, ok, d) in &self.expectations {
            let _ = writeln!(s, "  [{}] {e}: {d}", if *ok { "ok" } else { "FAIL" });
        }
        if let Some(p) = &self.plot {
            let _ = writeln!(s, "\nplot: {}", p.display());
        }
        s
    }

    /// Writes `<dir>/<name>.txt` and `<dir>/<name>.log` (every line sent);
    /// the text names [`Report::plot`] when the caller has written one.
    pub fn write(&self, dir: &Path) -> Result<()> {
        std::fs::create_dir_all(dir).with_context(|| format!("creating report directory {}", dir.display()))?;
        let txt = dir.join(format!("{}.txt", self.name));
        std::fs::write(&txt, self.text()).with_context(|| format!("writing {}", txt.display()))?;
        let mut log = String::with_capacity(self.lines.iter().map(|(_, l)| l.len() + 9).sum());
        for (t, l) in &self.lines {
            // `{t:>7} {l}`
            let digits = t.checked_ilog10().unwrap_or(0) as usize + 1;
            log.extend(std::iter::repeat_n(' ', 7usize.saturating_sub(digits)));
            let _ = write!(log, "{t}");
            log.push(' ');
            log.push_str(l);
            if !l.ends_with('\n') {
                log.push('\n');
            }
        }
        let lp = dir.join(format!("{}.log", self.name));
        std::fs::write(&lp, log).with_context(|| format!("writing {}", lp.display()))?;
        Ok(())
    }
}

/// The summary table's columns: (header, right-aligned, meaning).
pub const COLUMNS: [(&str, bool, &str); 10] = [
    ("scenario", false, "the scenario's name (`sim list` describes each; its report is <name>.txt)"),
    ("sim s", true, "simulated time the scenario ran, seconds"),
    ("H2 s", true, "simulated time homing completed (the firmware's H2 report), seconds; - never homed"),
    ("rms mrad", true, "tracking error, root mean square: kernel set-point vs true joint angle while following a stream, worst joint; - no stream followed"),
    ("max mrad", true, "tracking error, largest, same samples and joint choice as rms"),
    ("stop ms", true, "worst time from a burst's last command to standstill (every commanded speed below 0.01 rad/s); - no burst, never: it did not stop"),
    ("rej", true, "frames and requests rejected, dropped or refused (wire, sequence, queue, kernel)"),
    ("safety", false, "held: every safety requirement of SAFETY.md held at every tick (the monitor, the acceleration and the wire checks); VIOLATED otherwise"),
    ("faults", false, "faults the kernel raised, in order; - none"),
    ("expectations", false, "the scenario's expectations that held / all, ok or FAIL; informational ones do not decide the exit code"),
];

/// The cells of one report's summary row, in [`COLUMNS`] order.
fn row(r: &Report) -> [String; COLUMNS.len()] {
    let rms = r.tracking.iter().map(|e| e.rms_mrad()).fold(0.0, f64::max);
    let max = r.tracking.iter().map(|e| e.max_mrad()).fold(0.0, f64::max);
    let (rms, max) =
        if r.tracking[0].n == 0 { ("-".into(), "-".into()) } else { (format!("{rms:.2}"), format!("{max:.2}")) };
    let stop = match r.worst_stop() {
        None => "-".to_string(),
        Some(None) => "never".to_string(),
        Some(Some(d)) => d.to_string(),
    };
    let mut faults: Vec<String> = r.faults.iter().map(|f| f.1.clone()).collect();
    faults.dedup();
    let faults = if faults.is_empty() { "-".to_string() } else { faults.join("; ") };
    let held = r.expectations.iter().filter(|e| e.1).count();
    let pending = r.expectations.iter().filter(|e| e.0.starts_with("PENDING")).count();
    let exp = format!(
        "{}/{} {}{}{}",
        held,
        r.expectations.len(),
        if r.expectations_held() { "ok" } else { "FAIL" },
        if pending > 0 { format!(" ({pending} pending kernel fix)") } else { String::new() },
        if r.informational { " (informational)" } else { "" }
    );
    [
        r.name.clone(),
        format!("{:.1}", r.duration_ms as f64 / 1000.0),
        r.homed_at.map(|t| format!("{:.1}", t as f64 / 1000.0)).unwrap_or("-".into()),
        rms,
        max,
        stop,
        r.rejected_total.to_string(),
        if r.safe() { "held" } else { "VIOLATED" }.to_string(),
        faults,
        exp,
    ]
}

/// The summary table of a set of runs, every column as wide as its widest
/// cell, and a legend of the columns.
pub fn summary(reports: &[Report]) -> String {
    let rows: Vec<[String; COLUMNS.len()]> = reports.iter().map(row).collect();
    let mut s = table(&rows);
    let _ = writeln!(s, "\ncolumns:");
    let name_w = COLUMNS.iter().map(|c| c.0.len()).max().unwrap_or(0);
    for (name, _, meaning) in COLUMNS {
        let _ = writeln!(s, "  {name:<name_w$}  {meaning}");
    }
    s
}

/// The header and `rows`, each column as wide as its widest cell (header
/// included), two spaces apart; numbers right-aligned.
fn table(rows: &[[String; COLUMNS.len()]]) -> String {
    let width: [usize; COLUMNS.len()] = core::array::from_fn(|c| {
        rows.iter().map(|r| r[c].chars().count()).chain([COLUMNS[c].0.len()]).max().unwrap_or(0)
    });
    let line = |cells: [&str; COLUMNS.len()]| {
        let mut l = String::new();
        for (c, cell) in cells.iter().enumerate() {
            let w = width[c];
            let _ = if c + 1 == COLUMNS.len() {
                write!(l, "{cell}")
            } else if COLUMNS[c].1 {
                write!(l, "{cell:>w$}  ")
            } else {
                write!(l, "{cell:<w$}  ")
            };
        }
        l.trim_end().to_string()
    };
    let mut s = String::new();
    let _ = writeln!(s, "{}", line(COLUMNS.map(|c| c.0)));
    for r in rows {
        let _ = writeln!(s, "{}", line(core::array::from_fn(|c| r[c].as_str())));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::{table, COLUMNS};

    /// Where each column of `line` starts (the character after each run of
    /// two or more spaces).
    fn starts(line: &str) -> Vec<usize> {
        let b: Vec<char> = line.chars().collect();
        let mut v = vec![0];
        for i in 2..b.len() {
            if b[i] != ' ' && b[i - 1] == ' ' && b[i - 2] == ' ' {
                v.push(i);
            }
        }
        v
    }

    #[test]
    fn table_columns_line_up_whatever_the_cell_lengths() {
        let row = |name: &str, faults: &str| -> [String; COLUMNS.len()] {
            core::array::from_fn(|c| match c {
                0 => name.to_string(),
                8 => faults.to_string(),
                1 | 2 => "12.3".to_string(),
                _ => "x".repeat(c),
            })
        };
        let rows = [
            row("short", "-"),
            row("a-scenario-name-longer-than-any-column-width-so-far", "homing travel J1 in FastSeek; runaway J2"),
            row("mid-length-name", "-"),
        ];
        let t = table(&rows);
        let lines: Vec<&str> = t.lines().collect();
        assert_eq!(lines.len(), 4);
        // Every right-aligned column ends where its header ends, every
        // left-aligned one starts where its header starts: with no cell
        // containing two spaces, the column starts of the left-aligned
        // columns after the name agree on every line.
        let header = starts(lines[0]);
        assert_eq!(header.len(), COLUMNS.len(), "{}", lines[0]);
        for l in &lines[1..] {
            let st = starts(l);
            // scenario, safety, faults, expectations are left-aligned
            for c in [0, 7, 8] {
                assert!(st.contains(&header[c]), "column {c} misplaced in\n{}\n{l}", lines[0]);
            }
            assert!(l.ends_with(&"x".repeat(9)), "{l}");
        }
    }
}
