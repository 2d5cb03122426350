//! The per-thread proof context: a hash-consed arena of SMT terms (each one
//! defined once in z3 as `t<id>`), the z3 process, and the path explorer.
//!
//! # Path enumeration
//!
//! The kernel's generic code branches on `bool`s (comparisons,
//! `is_finite`, and the `select`s that take them). A symbolic value cannot
//! give a concrete `bool`, so every comparison asks [`decide`]: the first
//! time a decision is met on a path, z3 is asked which outcomes are
//! feasible under the path condition so far; one is taken, the other (if
//! feasible too) is queued as a new prefix. The function is re-run for
//! every queued prefix (depth first), replaying the recorded outcomes. Each
//! complete path ends with one check: `path condition AND NOT property`;
//! unsatisfiable on every path is a proof for all inputs.

use crate::z3::{Sat, Z3};
use std::cell::RefCell;
use std::collections::HashMap;
use std::time::{Duration, Instant};

/// Sorts of terms.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Sort {
    /// SMT `Bool`.
    Bool,
    /// IEEE binary32: `(_ FloatingPoint 8 24)`.
    F32,
    /// 32-bit two's-complement word (the bits of an `I8F24`).
    Bv32,
}

impl Sort {
    fn smt(self) -> &'static str {
        match self {
            Sort::Bool => "Bool",
            Sort::F32 => "(_ FloatingPoint 8 24)",
            Sort::Bv32 => "(_ BitVec 32)",
        }
    }
}

/// Node ids created first in every context, in this order, so that the
/// `Scalar` constants `ZERO` and `ONE` can be compile-time values.
pub const F32_ZERO: u32 = 0;
/// `1.0f32`.
pub const F32_ONE: u32 = 1;
/// `I8F24::ZERO`.
pub const FX_ZERO: u32 = 2;
/// `I8F24::ONE`.
pub const FX_ONE: u32 = 3;
/// `true`.
pub const TRUE: u32 = 4;
/// `false`.
pub const FALSE: u32 = 5;

/// The SMT name of node `id`.
pub fn name(id: u32) -> String {
    format!("t{id}")
}

/// SMT literal of an `f32` (any bit pattern; every NaN is SMT's one NaN).
pub fn f32_literal(x: f32) -> String {
    if x.is_nan() {
        return "(_ NaN 8 24)".to_string();
    }
    let b = x.to_bits();
    format!("(fp #b{} #b{:08b} #b{:023b})", b >> 31, (b >> 23) & 0xff, b & 0x7f_ffff)
}

/// SMT literal of a 32-bit word.
pub fn bv32_literal(bits: u32) -> String {
    format!("#x{bits:08x}")
}

struct Node {
    sort: Sort,
    /// Its `define-fun` / `declare-const` command.
    cmd: String,
    /// The nodes its definition refers to (all with smaller ids).
    deps: Vec<u32>,
    /// Depends on no input (a constant).
    ground: bool,
    /// Its cone contains a product of two non-constant terms.
    nonlinear: bool,
}

/// The node ids a term's text refers to (`t<digits>` tokens).
fn refs(text: &str) -> Vec<u32> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let boundary = i == 0 || matches!(b[i - 1], b'(' | b' ');
        if boundary && b[i] == b't' {
            let digits = b[i + 1..].iter().take_while(|c| c.is_ascii_digit()).count();
            let end = i + 1 + digits;
            if digits > 0 && (end == b.len() || matches!(b[end], b')' | b' ')) {
                out.push(text[i + 1..end].parse().expect("digits"));
            }
            i = end;
        } else {
            i += 1;
        }
    }
    out
}

/// The state of path enumeration.
#[derive(Debug, Default)]
struct Explorer {
    /// Outcomes to replay at the start of this run.
    prefix: Vec<bool>,
    /// Outcomes taken in this run.
    decisions: Vec<bool>,
    /// The path condition: (Boolean node, required value).
    lits: Vec<(u32, bool)>,
    /// Prefixes still to run.
    pending: Vec<Vec<bool>>,
    /// An assumption is unsatisfiable on this path: it is discarded.
    dead: bool,
    /// Per-run counter of fresh choice variables.
    choices: u32,
    /// Decisions are evaluated by simplification (ground terms only).
    evaluate: bool,
    /// Feasibility checks z3 could not decide in time.
    unknown: u64,
}

/// The per-thread context.
struct Ctx {
    z3: Z3,
    nodes: Vec<Node>,
    cons: HashMap<(Sort, String), u32>,
    /// Declared inputs, by name, for counterexamples.
    vars: Vec<(String, u32)>,
    explorer: Explorer,
}

thread_local! {
    static CTX: RefCell<Option<Ctx>> = const { RefCell::new(None) };
}

fn with<R>(f: impl FnOnce(&mut Ctx) -> R) -> R {
    CTX.with(|c| {
        let mut c = c.borrow_mut();
        let ctx = c.as_mut().expect("no SMT context on this thread: run inside smt::ctx::session");
        f(ctx)
    })
}

impl Ctx {
    fn new() -> Ctx {
        let mut c = Ctx {
            z3: Z3::start(),
            nodes: Vec::new(),
            cons: HashMap::new(),
            vars: Vec::new(),
            explorer: Explorer::default(),
        };
        let fixed = [
            (Sort::F32, f32_literal(0.0)),
            (Sort::F32, f32_literal(1.0)),
            (Sort::Bv32, bv32_literal(0)),
            (Sort::Bv32, bv32_literal(fixed::types::I8F24::ONE.to_bits() as u32)),
            (Sort::Bool, "true".to_string()),
            (Sort::Bool, "false".to_string()),
        ];
        for (want, (sort, text)) in fixed.into_iter().enumerate() {
            let id = c.term(sort, text);
            assert_eq!(id as usize, want, "reserved node ids out of order");
        }
        c
    }

    fn term(&mut self, sort: Sort, text: String) -> u32 {
        if let Some(&id) = self.cons.get(&(sort, text.clone())) {
            return id;
        }
        let id = u32::try_from(self.nodes.len()).expect("fewer than 2^32 terms");
        let deps = refs(&text);
        debug_assert!(deps.iter().all(|&d| d < id));
        let node = |d: &u32| self.nodes.get(*d as usize).expect("a node of this context");
        let ground = deps.iter().all(|d| node(d).ground);
        let nonlinear = deps.iter().any(|d| node(d).nonlinear);
        let cmd = format!("(define-fun {} () {} {})", name(id), sort.smt(), text);
        self.nodes.push(Node { sort, cmd, deps, ground, nonlinear });
        self.cons.insert((sort, text), id);
        id
    }

    fn var(&mut self, sort: Sort, label: &str) -> u32 {
        let key = (sort, format!("var {label}"));
        if let Some(&id) = self.cons.get(&key) {
            return id;
        }
        let id = u32::try_from(self.nodes.len()).expect("fewer than 2^32 terms");
        let cmd = format!("(declare-const {} {})", name(id), sort.smt());
        self.nodes.push(Node { sort, cmd, deps: Vec::new(), ground: false, nonlinear: false });
        self.cons.insert(key, id);
        if !label.starts_with("choice ") {
            self.vars.push((label.to_string(), id));
        }
        id
    }

    /// Starts z3 afresh with the definitions `roots` need (and only
    /// those): every check is a one-shot problem (see `z3::check_command`).
    fn load(&mut self, roots: &[u32]) {
        let mut need = vec![false; self.nodes.len()];
        let mut stack: Vec<u32> = roots.to_vec();
        while let Some(i) = stack.pop() {
            let seen = need.get_mut(i as usize).expect("a node of this context");
            if !*seen {
                *seen = true;
                stack.extend(self.nodes.get(i as usize).map(|n| n.deps.iter().copied()).into_iter().flatten());
            }
        }
        self.z3.reset();
        for (n, _) in self.nodes.iter().zip(need).filter(|(_, k)| *k) {
            self.z3.send(&n.cmd);
        }
    }

    /// Marks node `id` (a product of `a` and `b`) nonlinear if neither
    /// factor is a constant.
    fn mark_product(&mut self, id: u32, a: u32, b: u32) {
        let ground = |c: &Ctx, i: u32| c.nodes.get(i as usize).map(|n| n.ground).expect("a node of this context");
        if !ground(self, a) && !ground(self, b) {
            if let Some(n) = self.nodes.get_mut(id as usize) {
                n.nonlinear = true;
            }
        }
    }

    /// Satisfiability of the path condition plus `extra`, first with the
    /// path condition's literals free of nonlinear products only (a
    /// weaker formula: if it is unsatisfiable, so is the whole; z3 decides
    /// it much faster), then, if that is not conclusive, with all of it.
    fn check_with(&mut self, extra: Option<(u32, bool)>, timeout_ms: u32) -> Sat {
        let linear: Vec<(u32, bool)> = self
            .explorer
            .lits
            .iter()
            .copied()
            .filter(|l| !self.nodes.get(l.0 as usize).is_some_and(|n| n.nonlinear))
            .collect();
        if linear.len() < self.explorer.lits.len() {
            let mut lits = linear;
            lits.extend(extra);
            if self.check_lits(&lits, timeout_ms.min(LINEAR_TIMEOUT_MS)) == Sat::Unsat {
                return Sat::Unsat;
            }
        }
        let mut lits = self.explorer.lits.clone();
        lits.extend(extra);
        self.check_lits(&lits, timeout_ms)
    }

    fn check_lits(&mut self, lits: &[(u32, bool)], timeout_ms: u32) -> Sat {
        let ids: Vec<u32> = lits.iter().map(|l| l.0).chain(self.vars.iter().map(|v| v.1)).collect();
        self.load(&ids);
        for &(id, v) in lits {
            self.z3.send(&format!("(assert {})", literal(id, v)));
        }
        let t0 = Instant::now();
        let r = self.z3.check(timeout_ms);
        if std::env::var_os("SMT_VERBOSE").is_some() {
            let (paths, depth) = (self.explorer.pending.len(), self.explorer.decisions.len());
            eprintln!(
                "    check: {r:?} in {:.2} s ({} literals, depth {depth}, {paths} pending)",
                t0.elapsed().as_secs_f64(),
                lits.len()
            );
        }
        r
    }
}

/// Timeout of the first, weaker check of [`Ctx::check_with`].
const LINEAR_TIMEOUT_MS: u32 = 10_000;

/// Runs `f` with a fresh context (and z3 process) on this thread.
pub fn session<R>(f: impl FnOnce() -> R) -> R {
    struct Reset;
    impl Drop for Reset {
        fn drop(&mut self) {
            CTX.with(|c| c.borrow_mut().take());
        }
    }
    CTX.with(|c| {
        let mut c = c.borrow_mut();
        assert!(c.is_none(), "nested SMT sessions");
        *c = Some(Ctx::new());
    });
    let _reset = Reset;
    f()
}

/// Sort of node `id`.
pub fn sort_of(id: u32) -> Sort {
    with(|c| c.nodes.get(id as usize).map(|n| n.sort).expect("a node of this context"))
}

/// The hash-consed node for `text` of sort `sort`.
pub fn term(sort: Sort, text: String) -> u32 {
    with(|c| c.term(sort, text))
}

/// The hash-consed node for the product `text` of nodes `a` and `b`
/// (tracked: path conditions with products of two inputs are checked
/// last, see [`Ctx::check_with`]).
pub fn product(sort: Sort, text: String, a: u32, b: u32) -> u32 {
    with(|c| {
        let id = c.term(sort, text);
        c.mark_product(id, a, b);
        id
    })
}

/// An input of the proof: an unconstrained constant (every bit pattern).
pub fn var(sort: Sort, label: &str) -> u32 {
    with(|c| c.var(sort, label))
}

/// A fresh unconstrained Boolean for a choice the semantics leaves open
/// (which zero `f32::min` returns for `+0.0` and `-0.0`). Numbered per
/// run, so a replayed path meets the same variables.
pub fn choice() -> u32 {
    with(|c| {
        let n = c.explorer.choices;
        c.explorer.choices += 1;
        c.var(Sort::Bool, &format!("choice {n}"))
    })
}

fn literal(cond: u32, outcome: bool) -> String {
    if outcome {
        name(cond)
    } else {
        format!("(not {})", name(cond))
    }
}

/// The outcome of the Boolean term `cond` on the current path (see the
/// module docs). Panics outside [`explore`] / [`evaluate`].
pub fn decide(cond: u32) -> bool {
    match cond {
        TRUE => return true,
        FALSE => return false,
        _ => {}
    }
    with(|c| {
        debug_assert_eq!(c.nodes.get(cond as usize).map(|n| n.sort), Some(Sort::Bool));
        if c.explorer.evaluate {
            c.load(&[cond]);
            let v = c.z3.simplify(&name(cond));
            return match v.as_str() {
                "true" => true,
                "false" => false,
                _ => panic!("decision on a non-ground term in evaluation mode: {v}"),
            };
        }
        if c.explorer.dead {
            // The run is discarded; any outcome will do.
            return true;
        }
        let i = c.explorer.decisions.len();
        let outcome = if let Some(&o) = c.explorer.prefix.get(i) {
            o
        } else {
            // `unknown` counts as feasible: an infeasible path explored
            // costs time, never soundness (its property check is then
            // trivially unsatisfiable).
            let ms = crate::z3::decide_timeout_ms();
            let t = c.check_with(Some((cond, true)), ms);
            if t == Sat::Unknown {
                c.explorer.unknown += 1;
            }
            let f = if t == Sat::Unsat { Sat::Unsat } else { c.check_with(Some((cond, false)), ms) };
            if f == Sat::Unknown {
                c.explorer.unknown += 1;
            }
            if t == Sat::Unsat {
                false
            } else if f != Sat::Unsat {
                let mut p = c.explorer.decisions.clone();
                p.push(false);
                c.explorer.pending.push(p);
                true
            } else {
                true
            }
        };
        c.explorer.decisions.push(outcome);
        c.explorer.lits.push((cond, outcome));
        outcome
    })
}

/// Adds `cond` to the path condition (a precondition). A path on which it
/// cannot hold is discarded; if no path survives the proof fails as
/// vacuous.
pub fn assume(cond: u32) {
    if cond == TRUE {
        return;
    }
    with(|c| {
        if c.explorer.evaluate {
            panic!("assume in evaluation mode");
        }
        if c.explorer.dead {
            return;
        }
        let replaying = c.explorer.decisions.len() < c.explorer.prefix.len();
        if !replaying && c.check_with(Some((cond, true)), crate::z3::property_timeout_ms()) == Sat::Unsat {
            c.explorer.dead = true;
            return;
        }
        c.explorer.lits.push((cond, true));
    })
}

/// A counterexample: each input's name and value as z3 prints it.
pub type Counterexample = Vec<(String, String)>;

/// What one proof established.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// Complete feasible paths, each checked against the property.
    pub paths: u64,
    /// Runs discarded because a precondition cannot hold on them.
    pub discarded: u64,
    /// Satisfiability checks made.
    pub checks: u64,
    /// Feasibility checks z3 could not decide in time (both outcomes were
    /// explored).
    pub undecided: u64,
    /// Wall-clock time.
    pub time: Duration,
    /// `None`: the property holds on every path. `Some`: inputs for which
    /// it does not.
    pub counterexample: Option<Counterexample>,
}

impl Outcome {
    /// True if proved (no counterexample and at least one path).
    pub fn proved(&self) -> bool {
        self.counterexample.is_none() && self.paths > 0
    }
}

/// Proves that the Boolean terms returned by `f` hold on every feasible
/// path of `f` (for every value of every input `f` declares with [`var`]
/// that satisfies its [`assume`]s). Stops at the first counterexample.
/// Panics if no path is feasible (a vacuous precondition).
pub fn explore(mut f: impl FnMut() -> Vec<u32>) -> Outcome {
    let t0 = Instant::now();
    let checks0 = with(|c| {
        c.explorer = Explorer { pending: vec![Vec::new()], ..Explorer::default() };
        c.z3.checks
    });
    let (mut paths, mut discarded) = (0u64, 0u64);
    let mut counterexample = None;
    while let Some(prefix) = with(|c| c.explorer.pending.pop()) {
        with(|c| {
            let e = &mut c.explorer;
            e.prefix = prefix;
            e.decisions.clear();
            e.lits.clear();
            e.dead = false;
            e.choices = 0;
        });
        let props = f();
        let cex = with(|c| {
            if c.explorer.dead {
                discarded += 1;
                return None;
            }
            paths += 1;
            // One check per conjunct: smaller problems than their conjunction.
            for &prop in &props {
                match c.check_with(Some((prop, false)), crate::z3::property_timeout_ms()) {
                    Sat::Unsat => {}
                    Sat::Unknown => panic!(
                        "z3 could not decide a property check within {} ms: the proof is NOT established",
                        crate::z3::property_timeout_ms()
                    ),
                    Sat::Sat => {
                        let names: Vec<String> = c.vars.iter().map(|(_, id)| name(*id)).collect();
                        let values = c.z3.values(&names);
                        return Some(c.vars.iter().map(|(l, _)| l.clone()).zip(values).collect::<Counterexample>());
                    }
                }
            }
            None
        });
        if cex.is_some() {
            counterexample = cex;
            break;
        }
    }
    let (checks, undecided) = with(|c| {
        c.explorer.pending.clear();
        (c.z3.checks - checks0, c.explorer.unknown)
    });
    assert!(
        paths > 0 || counterexample.is_some(),
        "vacuous: no path satisfies the preconditions ({discarded} discarded)"
    );
    Outcome { paths, discarded, checks, undecided, time: t0.elapsed(), counterexample }
}

/// Runs `f` with decisions evaluated by z3's simplifier (every term must be
/// ground: built from constants only). For checking the semantics.
pub fn evaluate<R>(f: impl FnOnce() -> R) -> R {
    with(|c| c.explorer.evaluate = true);
    struct Off;
    impl Drop for Off {
        fn drop(&mut self) {
            let _ = CTX.try_with(|c| {
                if let Ok(mut c) = c.try_borrow_mut() {
                    if let Some(c) = c.as_mut() {
                        c.explorer.evaluate = false;
                    }
                }
            });
        }
    }
    let _off = Off;
    f()
}

/// z3's simplification of node `id` (a value for a ground term).
pub fn simplify(id: u32) -> String {
    with(|c| {
        c.load(&[id]);
        c.z3.simplify(&name(id))
    })
}

/// z3's simplification of many nodes (pipelined).
pub fn simplify_many(ids: &[u32]) -> Vec<String> {
    let names: Vec<String> = ids.iter().map(|&i| name(i)).collect();
    with(|c| {
        c.load(ids);
        c.z3.simplify_many(&names)
    })
}

/// Satisfiability of the conjunction of Boolean nodes `lits` (outside
/// path exploration; for the semantics tests).
pub fn satisfiable(lits: &[u32]) -> bool {
    with(|c| {
        c.load(lits);
        for &l in lits {
            c.z3.send(&format!("(assert {})", name(l)));
        }
        match c.z3.check(crate::z3::property_timeout_ms()) {
            Sat::Sat => true,
            Sat::Unsat => false,
            Sat::Unknown => panic!("z3 could not decide a check"),
        }
    })
}
