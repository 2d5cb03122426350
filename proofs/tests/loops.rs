//! Every loop of the code the kernel harnesses run, with its bound: a scan
//! of `kernel/src` and the monitor's checks, `monitor/src` but its test
//! plant and tests (test modules excluded).
//!
//! The shim counts the iterations of loops it compiles (the harnesses and
//! their helpers), not those of the crates under test: Kani unwinds those
//! too, so their bound must be known. This test finds every `for`, `while`
//! and `loop`, and every iterator or array method that loops (`all`, `any`,
//! `position`, `find`, `fold`, `count`, `sum`, `contains`, array `map`,
//! `from_fn`), classifies each by the collection it runs over (six axes,
//! three homing groups, the tick's events, ...) and fails on one it cannot
//! classify: a new loop must state its bound here. The largest bound, plus
//! one, must equal `proofs::setup::KERNEL_UNWIND`, which every harness that
//! runs a tick declares to the shim.
//!
//! What the scan does not see: loops inside `core` behind other calls
//! (`f32::next_down`, formatting), inside the `fixed` crate's arithmetic,
//! and inside derived impls (`Hash`, `PartialEq` on arrays: used by the
//! model check only). Kani unwinds those as well; none depends on a
//! runtime length.

use std::path::{Path, PathBuf};

/// Collections a loop may run over, recognised by an identifier in its
/// header (for `for`/`while`) or receiver (for methods), and their length.
const DOMAINS: &[(&str, u32, &str)] = &[
    ("axes", 6, "per axis ([_; AXES])"),
    ("AXES", 6, "per axis"),
    ("encoders", 6, "per axis"),
    ("joints", 6, "per axis"),
    ("cfg_joints", 6, "per axis"),
    ("position", 6, "per axis"),
    ("velocity", 6, "per axis"),
    ("setpoint", 6, "per axis"),
    ("prev_setpoint", 6, "per axis"),
    ("sp", 6, "per axis (set-points)"),
    ("out", 6, "per axis"),
    ("last_out", 6, "per axis"),
    ("prev_out", 6, "per axis"),
    ("step_rate", 6, "per axis"),
    ("v0", 6, "per axis"),
    ("lo", 6, "per axis"),
    ("ph", 6, "per axis (homing phases)"),
    ("lost_streak", 6, "per axis"),
    ("now", 6, "per axis"),
    ("SEED_DEPENDENCIES", 6, "per axis"),
    ("HOMING_GROUPS", 3, "homing groups"),
    ("events", 4, "events of one tick (MAX_EVENTS)"),
    ("list", 4, "events of one tick (MAX_EVENTS)"),
    ("intervals", 4, "target intervals"),
    ("state_ticks", 7, "per supervisor state"),
    ("faults", 11, "per fault kind"),
    ("timeout_stop", 3, "the three outcomes of a command timeout (stop, hold, link stop)"),
    ("raw", 6, "the switch window (monitor::interactions::SWITCH_WINDOW samples)"),
    ("mask", 6, "the switch window (monitor::interactions::SWITCH_WINDOW samples)"),
];

/// Receivers whose `.map(` is `Option::map` / `Result::map`: not a loop.
const NOT_LOOPS: &[&str] = &[
    "since_target",
    "since_accept",
    "hardware_fault",
    "fault",
    "count",
    "get(",
    "delta",
    "reason",
    "ok()",
    "plant",
    "sent",
    "anchor",
    "accepted_target",
    "target_now",
    "rejected",
];

/// Loops with a bound outside `KERNEL_UNWIND`, each with its status (none:
/// `Params::new`'s 65-entry reciprocal table is gone, a segment's 1/n is a
/// division per accepted target).
const PENDING: &[(&str, &str, u32, &str)] = &[];

/// Functions no harness calls (their loops are listed, not counted).
const OFF_PATH: &[(&str, &str, &str)] = &[
    ("monitor/src/stats.rs", "merge", "Stats::merge: summaries of proptest runs, never called by Monitor::check"),
    (
        "kernel/src/scalar.rs",
        "decimal_text",
        "the parser's text fallback (at most 11 digits): never called by Kernel::tick; the wire harnesses' unwind (101) covers it",
    ),
    (
        "kernel/src/scalar.rs",
        "nz",
        "the const block after `nz`: a compile-time check of FX_DECIMAL (const evaluation, no harness runs it)",
    ),
];

const METHODS: &[&str] =
    &[".all(", ".any(", ".position(", ".find(", ".fold(", ".count()", ".sum()", ".contains(", ".map(", "from_fn("];

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("workspace root").to_path_buf()
}

fn files() -> Vec<PathBuf> {
    let mut v = Vec::new();
    for dir in ["kernel/src", "kernel/src/kernel"] {
        for e in std::fs::read_dir(root().join(dir)).expect("kernel sources") {
            let p = e.expect("entry").path();
            if p.extension().is_some_and(|x| x == "rs") {
                v.push(p);
            }
        }
    }
    for e in std::fs::read_dir(root().join("monitor/src")).expect("monitor sources") {
        let p = e.expect("entry").path();
        let checks = !p.ends_with("plant.rs") && !p.ends_with("tests.rs");
        if checks && p.extension().is_some_and(|x| x == "rs") {
            v.push(p);
        }
    }
    v.sort();
    v
}

/// The file's code without its test module; string literals and comments
/// blanked (line numbers kept).
fn code(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    for line in text.lines() {
        if line.trim_start().starts_with("#[cfg(test)]") {
            break;
        }
        let mut l = String::new();
        let (mut in_str, mut esc) = (false, false);
        let b: Vec<char> = line.chars().collect();
        let mut i = 0;
        while i < b.len() {
            let c = b[i];
            if in_str {
                if esc {
                    esc = false;
                } else if c == '\\' {
                    esc = true;
                } else if c == '"' {
                    in_str = false;
                    l.push('"');
                    i += 1;
                    continue;
                }
                l.push(' ');
            } else if c == '"' {
                in_str = true;
                l.push('"');
            } else if c == '/' && b.get(i + 1) == Some(&'/') {
                break;
            } else {
                l.push(c);
            }
            i += 1;
        }
        out.push(l);
    }
    out
}

/// The receiver of a method call ending at `end`: the trailing path and
/// call chain (`self.axes.iter().enumerate()`), parentheses balanced.
fn receiver(line: &str, end: usize) -> &str {
    let b = line.as_bytes();
    let mut depth = 0i32;
    let mut i = end;
    while i > 0 {
        let c = b[i - 1];
        match c {
            b')' | b']' => depth += 1,
            b'(' | b'[' if depth > 0 => depth -= 1,
            b'(' | b'[' => break,
            _ if depth > 0 => {}
            _ if c.is_ascii_alphanumeric() || c == b'_' || c == b'.' || c == b':' => {}
            _ => break,
        }
        i -= 1;
    }
    &line[i..end]
}

fn word_at(s: &str, i: usize, w: &str) -> bool {
    let b = s.as_bytes();
    let before = i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_');
    let j = i + w.len();
    let after = j >= b.len() || !(b[j].is_ascii_alphanumeric() || b[j] == b'_');
    before && after
}

fn words(s: &str, w: &str) -> Vec<usize> {
    s.match_indices(w).map(|(i, _)| i).filter(|&i| word_at(s, i, w)).collect()
}

/// The smallest domain named in `text` (a zip runs as long as its shortest).
fn classify(text: &str) -> Option<(u32, &'static str)> {
    DOMAINS
        .iter()
        .filter(|(w, _, _)| !words(text, w).is_empty())
        .map(|(_, n, what)| (*n, *what))
        .min_by_key(|(n, _)| *n)
}

#[derive(Debug)]
struct Found {
    at: String,
    bound: u32,
    what: String,
    text: String,
}

fn scan() -> (Vec<Found>, Vec<String>, Vec<Found>) {
    let (mut found, mut unknown, mut pending) = (Vec::new(), Vec::new(), Vec::new());
    for f in files() {
        let rel = f.strip_prefix(root()).expect("under root").display().to_string();
        let lines = code(&std::fs::read_to_string(&f).expect("read"));
        let mut current_fn = String::new();
        for (n, line) in lines.iter().enumerate() {
            let at = format!("{rel}:{}", n + 1);
            if let Some(i) = words(line, "fn").first() {
                current_fn = line[i + 2..]
                    .trim_start()
                    .split(|c: char| !(c.is_alphanumeric() || c == '_'))
                    .next()
                    .unwrap_or("")
                    .to_string();
            }
            if let Some(o) = OFF_PATH.iter().find(|o| rel == o.0 && current_fn == o.1) {
                if ["for", "while", "loop"].iter().any(|k| !words(line, k).is_empty()) {
                    println!("OFF PATH {at}: {}", o.2);
                }
                continue;
            }
            // Keyword loops: the header runs to the body's opening brace.
            for kw in ["for", "while", "loop"] {
                for i in words(line, kw) {
                    let rest = &line[i + kw.len()..];
                    if kw == "for" && (line.trim_start().starts_with("impl") || rest.starts_with('<')) {
                        continue;
                    }
                    let mut header = rest.to_string();
                    let mut k = n;
                    while !header.contains('{') && k + 1 < lines.len() {
                        k += 1;
                        header.push(' ');
                        header.push_str(lines[k].trim());
                    }
                    let header = header.split('{').next().unwrap_or("").trim().to_string();
                    match classify(&header) {
                        Some((b, what)) => found.push(Found {
                            at: at.clone(),
                            bound: b,
                            what: what.into(),
                            text: format!("{kw} {header}"),
                        }),
                        None => unknown.push(format!("{at}: {kw} {header}")),
                    }
                }
            }
            // Looping methods: classified by their receiver (the line up to the call).
            for m in METHODS {
                for (i, _) in line.match_indices(m) {
                    let recv = &line[..i];
                    if let Some(p) = PENDING.iter().find(|p| rel == p.0 && m.contains(p.1)) {
                        pending.push(Found { at: at.clone(), bound: p.2, what: p.3.into(), text: line.trim().into() });
                        continue;
                    }
                    let last = receiver(line, recv.len());
                    if *m == ".map(" && NOT_LOOPS.iter().any(|w| last.contains(w)) {
                        continue;
                    }
                    match classify(last) {
                        Some((b, what)) => {
                            found.push(Found { at: at.clone(), bound: b, what: what.into(), text: line.trim().into() })
                        }
                        None if *m == ".contains(" => {} // ranges and slices of known length are classified above
                        None => unknown.push(format!("{at}: {}", line.trim())),
                    }
                }
            }
        }
    }
    (found, unknown, pending)
}

#[test]
fn every_loop_of_the_code_under_test_has_a_known_bound() {
    let (found, unknown, pending) = scan();
    for f in &found {
        println!("{:<42} {:>3}  {:<34} {}", f.at, f.bound, f.what, f.text.chars().take(90).collect::<String>());
    }
    for p in &pending {
        println!("PENDING {:<34} {:>3}  {}", p.at, p.bound, p.what);
    }
    assert!(unknown.is_empty(), "loops with no known bound (add their domain to DOMAINS):\n{}", unknown.join("\n"));
    // A pending entry that no longer matches anything is stale: remove it
    // (and the note in proofs::setup::KERNEL_UNWIND) once main drops the table.
    for (file, what, _, _) in PENDING {
        assert!(pending.iter().any(|p| p.at.starts_with(file)), "PENDING entry {file} {what} is gone: remove it");
    }
    let largest = found.iter().map(|f| f.bound).max().expect("the kernel has loops");
    println!("largest bounded loop: {largest} iterations -> unwind {}", largest + 1);
    assert_eq!(largest + 1, proofs::setup::KERNEL_UNWIND, "KERNEL_UNWIND must be the largest loop bound + 1");
    assert!(found.len() > 20, "the scan found too few loops ({}): is it still reading the sources?", found.len());
}

#[test]
fn the_scan_flags_an_unclassified_loop() {
    // The classifier must be able to fail: a loop over an unknown slice.
    assert!(classify(" b in bytes.iter()").is_none());
    assert_eq!(classify(" (i, ax) in self.axes.iter().enumerate()").map(|c| c.0), Some(6));
    assert_eq!(classify(" g in HOMING_GROUPS").map(|c| c.0), Some(3));
}
