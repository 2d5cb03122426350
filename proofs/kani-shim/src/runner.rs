//! Runs one harness: exhaustive enumeration of its choice tree when it is
//! small and narrow, seeded sampling otherwise; reports what it did.

use std::cell::{Cell, RefCell};
use std::collections::BTreeMap;
use std::io::Write;
use std::panic::{self, AssertUnwindSafe};
use std::sync::Once;

/// Largest choice tree enumerated exhaustively (leaves).
pub const EXHAUSTIVE_LIMIT: u64 = 1 << 20;
/// Largest domain of a single draw that exhaustive mode accepts.
pub const NARROW_DOMAIN: u64 = 1 << 16;

/// Samples per sampled harness: `KANI_SHIM_SAMPLES`, default 2000.
pub fn samples() -> u64 {
    std::env::var("KANI_SHIM_SAMPLES").ok().and_then(|s| s.parse().ok()).unwrap_or(2000)
}

/// Payload of the panic `kani::assume(false)` raises to discard a case.
#[derive(Debug)]
pub struct Discarded;

/// SplitMix64. Hand-written (five lines) rather than taken from `rand`: the
/// sequence for a seed must never change between dependency versions, or a
/// recorded failing seed would no longer reproduce.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// Next 64 random bits.
    #[allow(clippy::should_implement_trait)]
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
}

#[derive(Debug)]
enum Mode {
    Exhaustive { prefix: Vec<u64>, trace: Vec<(u64, u64)>, too_wide: bool },
    Sampled { rng: Rng },
}

/// Where `kani::any()` gets its values for the current case.
#[derive(Debug)]
pub struct Source {
    mode: Mode,
}

impl Source {
    /// A value in `0..domain` (`domain >= 1`).
    pub fn draw(&mut self, domain: u64) -> u64 {
        count_symbolic_value();
        let domain = domain.max(1);
        match &mut self.mode {
            Mode::Exhaustive { prefix, trace, too_wide } => {
                if domain > NARROW_DOMAIN {
                    *too_wide = true;
                }
                let v = prefix.get(trace.len()).copied().unwrap_or(0).min(domain - 1);
                trace.push((v, domain));
                v
            }
            Mode::Sampled { rng } => {
                // One draw in four lands on an edge of the domain.
                if rng.next() % 4 == 0 {
                    [0, 1.min(domain - 1), domain - 1, domain / 2][(rng.next() % 4) as usize]
                } else {
                    rng.next() % domain
                }
            }
        }
    }
    /// A value from a domain too wide to enumerate: makes the harness sampled.
    pub fn wide<T>(&mut self, f: impl FnOnce(&mut Rng) -> T) -> T {
        count_symbolic_value();
        match &mut self.mode {
            Mode::Exhaustive { too_wide, .. } => {
                *too_wide = true;
                f(&mut Rng(0))
            }
            Mode::Sampled { rng } => f(rng),
        }
    }
}

/// The running harness's covers: (file, line) -> (label, satisfied).
type Covers = BTreeMap<(&'static str, u32), (&'static str, bool)>;

thread_local! {
    static SOURCE: RefCell<Option<Source>> = const { RefCell::new(None) };
    static COVERS: RefCell<Covers> = const { RefCell::new(BTreeMap::new()) };
    /// The running harness's `#[kani::unwind(N)]` (None: not declared).
    static UNWIND: Cell<Option<u32>> = const { Cell::new(None) };
    /// Most iterations any instrumented loop ran in one entry, this harness.
    static LONGEST: Cell<u64> = const { Cell::new(0) };
    /// Largest bound a `needs_unwind` call asked for, this harness.
    static NEEDED: Cell<u32> = const { Cell::new(0) };
    /// The running harness's stated footprint (None: not stated).
    static FOOTPRINT: Cell<Option<Footprint>> = const { Cell::new(None) };
    /// Symbolic values drawn and ticks run in the current case.
    static CASE: Cell<Footprint> = const { Cell::new(Footprint { symbolic_values: 0, ticks: 0 }) };
    /// The largest of each over the harness's cases.
    static MOST: Cell<Footprint> = const { Cell::new(Footprint { symbolic_values: 0, ticks: 0 }) };
    /// Inside [`hint`]: draws that are not symbolic values under Kani.
    static HINTING: Cell<bool> = const { Cell::new(false) };
}

/// A harness's symbolic footprint: how many symbolic values it draws
/// (every primitive value a `kani::any()` produces: an array of six `f32`
/// is six, an `Option<u8>` two) and how many kernel ticks it runs (set-up
/// included), on its longest path. Stated in the harness's documentation
/// as `Footprint: N symbolic values, T ticks` (see `kani-shim-macros`);
/// a case that exceeds either figure fails the harness.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Footprint {
    /// Primitive values drawn by `kani::any()`.
    pub symbolic_values: u64,
    /// Kernel ticks run ([`tick`]).
    pub ticks: u64,
}

fn count_symbolic_value() {
    if HINTING.with(Cell::get) {
        return;
    }
    let c = CASE.with(|c| {
        let mut f = c.get();
        f.symbolic_values += 1;
        c.set(f);
        f
    });
    if let Some(b) = FOOTPRINT.with(Cell::get) {
        if c.symbolic_values > b.symbolic_values {
            panic!(
                "symbolic footprint exceeded: this case draws a symbolic value beyond the {} its footprint states",
                b.symbolic_values
            );
        }
    }
}

/// One kernel tick of the running harness (the proofs crate calls it
/// from every tick it runs), counted against its stated footprint.
pub fn tick() {
    let c = CASE.with(|c| {
        let mut f = c.get();
        f.ticks += 1;
        c.set(f);
        f
    });
    if let Some(b) = FOOTPRINT.with(Cell::get) {
        if c.ticks > b.ticks {
            panic!("symbolic footprint exceeded: this case runs a tick beyond the {} its footprint states", b.ticks);
        }
    }
}

/// A value drawn only to steer the shim's sampling (for example, how
/// often a draw lands in a typical range): written in `#[cfg(not(kani))]`
/// code, it is no symbolic value under Kani and is not counted in the
/// footprint.
pub fn hint<T: crate::Arbitrary>() -> T {
    struct Reset;
    impl Drop for Reset {
        fn drop(&mut self) {
            HINTING.with(|h| h.set(false));
        }
    }
    HINTING.with(|h| h.set(true));
    let _reset = Reset;
    with_source(T::any_from)
}

/// One entry into an instrumented loop (the `#[kani::proof]` and
/// `kani::loops` macros create it before the loop and call
/// [`Loop::iteration`] at the top of its body).
#[derive(Debug)]
pub struct Loop {
    file: &'static str,
    line: u32,
    count: u64,
}

impl Loop {
    /// Enters the loop written at `file:line`.
    pub fn enter(file: &'static str, line: u32) -> Self {
        Loop { file, line, count: 0 }
    }
    /// One more iteration. Kani's `#[kani::unwind(N)]` allows at most N - 1
    /// iterations per entry (the N-th unwinding is the unwinding assertion):
    /// one more fails the harness, as the unwinding assertion fails under
    /// Kani.
    pub fn iteration(&mut self) {
        self.count += 1;
        LONGEST.with(|l| l.set(l.get().max(self.count)));
        if let Some(n) = UNWIND.with(Cell::get) {
            if self.count > u64::from(n.saturating_sub(1)) {
                panic!(
                    "unwinding assertion: the loop at {}:{} runs iteration {}, but #[kani::unwind({n})] allows at most {}",
                    self.file,
                    self.line,
                    self.count,
                    n.saturating_sub(1)
                );
            }
        }
    }
}

/// A loop the shim cannot instrument (in the code under test, or in
/// `core`) runs up to `n - 1` iterations: the harness's declared unwind must
/// be at least `n`. `what` names the loop and where its bound is stated.
pub fn needs_unwind(n: u32, what: &str) {
    NEEDED.with(|c| c.set(c.get().max(n)));
    if let Some(d) = UNWIND.with(Cell::get) {
        if d < n {
            panic!("unwinding assertion: {what} needs #[kani::unwind({n})] or more; the harness declares {d}");
        }
    }
}

/// Calls `f` with the current case's source.
pub fn with_source<T>(f: impl FnOnce(&mut Source) -> T) -> T {
    SOURCE.with(|s| {
        let mut s = s.borrow_mut();
        match s.as_mut() {
            Some(src) => f(src),
            None => panic!("kani::any() called outside a #[kani::proof] harness"),
        }
    })
}

/// Declares the covers written in a function body (the `#[kani::proof]`
/// and `kani::loops` macros call it when the body is entered): each is then
/// required to be satisfied by the end of the harness, reached or not.
pub fn declare_covers(file: &'static str, covers: &[(u32, &'static str)]) {
    COVERS.with(|c| {
        let mut c = c.borrow_mut();
        for (line, label) in covers {
            c.entry((file, *line)).or_insert((label, false));
        }
    });
}

pub(crate) fn record_cover(file: &'static str, line: u32, label: &'static str, cond: bool) {
    let declared = COVERS.with(|c| match c.borrow_mut().get_mut(&(file, line)) {
        Some(e) => {
            e.1 |= cond;
            true
        }
        None => false,
    });
    if !declared {
        panic!(
            "kani::cover! at {file}:{line} ({label:?}) was not declared before it was reached: write it in a \
             #[kani::proof] body or in a helper marked #[cfg_attr(not(kani), kani::loops)], so that the shim \
             requires it even when its line never runs"
        );
    }
}

fn install_hook() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let default = panic::take_hook();
        panic::set_hook(Box::new(move |info| {
            if info.payload().downcast_ref::<Discarded>().is_none() {
                default(info);
            }
        }));
    });
}

enum Outcome {
    Passed,
    Discarded,
}

fn run_case(harness: fn(), mode: Mode) -> (Result<Outcome, Box<dyn std::any::Any + Send>>, Mode) {
    SOURCE.with(|s| *s.borrow_mut() = Some(Source { mode }));
    CASE.with(|c| c.set(Footprint::default()));
    let r = panic::catch_unwind(AssertUnwindSafe(harness));
    let case = CASE.with(Cell::get);
    MOST.with(|m| {
        let most = m.get();
        m.set(Footprint {
            symbolic_values: most.symbolic_values.max(case.symbolic_values),
            ticks: most.ticks.max(case.ticks),
        })
    });
    let src = SOURCE.with(|s| s.borrow_mut().take());
    let mode = src.map(|s| s.mode).unwrap_or(Mode::Sampled { rng: Rng(0) });
    let r = match r {
        Ok(()) => Ok(Outcome::Passed),
        Err(p) if p.downcast_ref::<Discarded>().is_some() => Ok(Outcome::Discarded),
        Err(p) => Err(p),
    };
    (r, mode)
}

fn fnv1a(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3))
}

/// What a harness run did.
#[derive(Debug, Clone)]
pub struct Report {
    /// `exhaustive` or `sampled`.
    pub kind: &'static str,
    /// Cases that ran to the end.
    pub cases: u64,
    /// Cases discarded by `kani::assume`.
    pub discarded: u64,
    /// Covers satisfied / declared.
    pub covers: (usize, usize),
    /// Seed (sampled only).
    pub seed: Option<u64>,
    /// Most iterations an instrumented loop ran in one entry.
    pub longest_loop: u64,
    /// Largest unwind the uninstrumented loops asked for (`needs_unwind`).
    pub needed_unwind: u32,
    /// The largest footprint of any case (symbolic values, ticks).
    pub footprint: Footprint,
}

/// Runs a harness without a declared unwind bound or footprint.
pub fn run(name: &str, harness: fn()) {
    run_harness(name, harness, None, None);
}

/// Runs a harness whose loops may run at most `unwind - 1` iterations per
/// entry and whose cases stay within `footprint`; panics (failing the
/// test) on a counterexample, an exceeded loop bound or footprint, or an
/// unreached cover.
pub fn run_harness(name: &str, harness: fn(), unwind: Option<u32>, footprint: Option<Footprint>) {
    if let Err(e) = check_within(name, harness, unwind, footprint) {
        panic!("{e}");
    }
}

/// [`check_within`] with no stated footprint.
pub fn check(name: &str, harness: fn(), unwind: Option<u32>) -> Result<Report, String> {
    check_within(name, harness, unwind, None)
}

/// Runs a harness and reports, or says why it failed (counterexample,
/// loop bound or footprint exceeded, cover never reached, every case
/// discarded).
pub fn check_within(
    name: &str,
    harness: fn(),
    unwind: Option<u32>,
    footprint: Option<Footprint>,
) -> Result<Report, String> {
    install_hook();
    FOOTPRINT.with(|f| f.set(footprint));
    MOST.with(|m| m.set(Footprint::default()));
    COVERS.with(|c| c.borrow_mut().clear());
    UNWIND.with(|u| u.set(unwind));
    LONGEST.with(|l| l.set(0));
    NEEDED.with(|c| c.set(0));
    let report = panic::catch_unwind(AssertUnwindSafe(|| match exhaustive(name, harness) {
        Some(r) => r,
        None => {
            COVERS.with(|c| c.borrow_mut().clear());
            sampled(name, harness)
        }
    }));
    UNWIND.with(|u| u.set(None));
    FOOTPRINT.with(|f| f.set(None));
    let report = report.map_err(|p| {
        let msg = p
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "panic".into());
        format!("kani-shim: {name}: FAILED: {msg}")
    })?;
    let covers = COVERS.with(|c| c.borrow().clone());
    let hit = covers.values().filter(|(_, h)| *h).count();
    let longest = LONGEST.with(Cell::get);
    let needed = NEEDED.with(Cell::get);
    let most = MOST.with(Cell::get);
    let report =
        Report { covers: (hit, covers.len()), longest_loop: longest, needed_unwind: needed, footprint: most, ..report };
    let stated = match footprint {
        Some(f) => format!("footprint {} symbolic values, {} ticks stated", f.symbolic_values, f.ticks),
        None => "no footprint stated".into(),
    };
    let seed = report.seed.map(|s| format!(", seed {s:#x}")).unwrap_or_default();
    let bound = match unwind {
        Some(n) => format!("unwind {n}"),
        None => "no unwind declared".into(),
    };
    let line = format!(
        "kani-shim: {name}: {}, {} cases ({} discarded by assume){seed}, covers {}/{}, {bound}: longest instrumented loop {longest} iterations, uninstrumented loops need unwind {needed}; {stated}: at most {} symbolic values and {} ticks in a case",
        report.kind,
        report.cases,
        report.discarded,
        hit,
        covers.len(),
        most.symbolic_values,
        most.ticks
    );
    println!("{line}");
    if let Ok(path) = std::env::var("KANI_SHIM_REPORT") {
        if let Ok(mut f) = std::fs::OpenOptions::new().create(true).append(true).open(&path) {
            let u = unwind.map(|n| n.to_string()).unwrap_or_else(|| "-".into());
            let _ = writeln!(
                f,
                "{name}\t{}\t{}\t{}\t{hit}/{}\t{u}\t{longest}\t{needed}\t{}\t{}",
                report.kind,
                report.cases,
                report.discarded,
                covers.len(),
                most.symbolic_values,
                most.ticks
            );
        }
    }
    let missed: Vec<String> =
        covers.iter().filter(|(_, (_, h))| !*h).map(|((f, l), (label, _))| format!("{f}:{l} {label}")).collect();
    if !missed.is_empty() {
        return Err(format!("{line}\ncover never satisfied (vacuous assumption or too few samples): {missed:?}"));
    }
    if report.cases == 0 {
        return Err(format!("{line}\nevery case was discarded by kani::assume: the harness is vacuous"));
    }
    Ok(report)
}

fn exhaustive(name: &str, harness: fn()) -> Option<Report> {
    let mut prefix: Vec<u64> = Vec::new();
    let (mut cases, mut discarded) = (0u64, 0u64);
    loop {
        let (r, mode) =
            run_case(harness, Mode::Exhaustive { prefix: prefix.clone(), trace: Vec::new(), too_wide: false });
        let Mode::Exhaustive { trace, too_wide, .. } = mode else { return None };
        if too_wide {
            return None;
        }
        if cases + discarded == 0 {
            let leaves = trace.iter().fold(1u64, |acc, (_, d)| acc.saturating_mul(*d));
            if leaves > EXHAUSTIVE_LIMIT {
                return None;
            }
        }
        match r {
            Ok(Outcome::Passed) => cases += 1,
            Ok(Outcome::Discarded) => discarded += 1,
            Err(p) => {
                eprintln!("kani-shim: {name}: counterexample (exhaustive), choices {:?}", trace);
                panic::resume_unwind(p);
            }
        }
        if cases + discarded > EXHAUSTIVE_LIMIT {
            return None;
        }
        // Next leaf of the choice tree, depth first.
        let mut t = trace;
        loop {
            match t.pop() {
                Some((v, d)) if v + 1 < d => {
                    t.push((v + 1, d));
                    break;
                }
                Some(_) => continue,
                None => {
                    return Some(Report {
                        kind: "exhaustive",
                        cases,
                        discarded,
                        covers: (0, 0),
                        seed: None,
                        longest_loop: 0,
                        needed_unwind: 0,
                        footprint: Footprint::default(),
                    })
                }
            }
        }
        prefix = t.iter().map(|(v, _)| *v).collect();
    }
}

fn sampled(name: &str, harness: fn()) -> Report {
    let seed = std::env::var("KANI_SHIM_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or_else(|| fnv1a(name));
    let n = samples();
    let (mut cases, mut discarded) = (0u64, 0u64);
    for i in 0..n {
        let case_seed = seed ^ i.wrapping_mul(0xA24B_AED4_963E_E407);
        let (r, _) = run_case(harness, Mode::Sampled { rng: Rng(case_seed) });
        match r {
            Ok(Outcome::Passed) => cases += 1,
            Ok(Outcome::Discarded) => discarded += 1,
            Err(p) => {
                eprintln!("kani-shim: {name}: counterexample (sampled), seed {seed:#x}, case {i}");
                panic::resume_unwind(p);
            }
        }
    }
    Report {
        kind: "sampled",
        cases,
        discarded,
        covers: (0, 0),
        seed: Some(seed),
        longest_loop: 0,
        needed_unwind: 0,
        footprint: Footprint::default(),
    }
}
