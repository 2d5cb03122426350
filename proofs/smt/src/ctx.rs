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
    /// It *is* such a product, of these two nodes (see [`Ctx::load`]:
    /// abstracted in the first check).
    product: Option<(u32, u32)>,
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
    /// Feasibility checks not made on the whole path condition (nonlinear
    /// literals, or every decision with `blind_all`; see
    /// [`Ctx::check_with`]): both outcomes explored.
    blind: u64,
    /// Explore both outcomes of every decision without asking z3 (see
    /// [`explore_blind`]).
    blind_all: bool,
    /// A decision on a constant (a term without inputs) takes its value
    /// from z3's evaluator instead of exploring both outcomes (see
    /// [`explore_blind_evaluating_constants`]).
    evaluate_constants: bool,
    /// Unsatisfiable cores of property checks on earlier paths: (property,
    /// path literals). A path whose condition contains every literal of a
    /// core of its property is proved without z3 (`u32::MAX`: the path
    /// literals alone are unsatisfiable, any property).
    cores: Vec<(u32, Vec<(u32, bool)>)>,
    /// Property checks answered from `cores`.
    reused: u64,
}

/// The per-thread context.
struct Ctx {
    z3: Z3,
    nodes: Vec<Node>,
    cons: HashMap<(Sort, String), u32>,
    /// Declared inputs, by name, for counterexamples.
    vars: Vec<(String, u32)>,
    explorer: Explorer,
    /// The problem loaded last has no floating-point term.
    bit_vectors_only: bool,
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
            bit_vectors_only: false,
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
        self.nodes.push(Node { sort, cmd, deps, ground, nonlinear, product: None });
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
        self.nodes.push(Node { sort, cmd, deps: Vec::new(), ground: false, nonlinear: false, product: None });
        self.cons.insert(key, id);
        if !label.starts_with("choice ") {
            self.vars.push((label.to_string(), id));
        }
        id
    }

    /// Starts z3 afresh with the definitions `roots` need (and only
    /// those): every check is a one-shot problem (see `z3::check_command`).
    ///
    /// With `abstracted`, every product of two non-constant terms in the
    /// cone is declared as a fresh unconstrained constant instead of being
    /// defined (z3 no longer bit-blasts a multiplier of two unknowns), and
    /// only facts that hold for the real product are asserted about it
    /// ([`Ctx::product_lemmas`]). The result is a weaker formula than the
    /// real one: `unsat` for it is `unsat` for the real one. Returns
    /// whether any product was abstracted.
    fn load(&mut self, roots: &[u32], abstracted: bool, cores: bool) -> bool {
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
        if cores {
            // Minimised cores are reused on many more paths (16 checks
            // instead of 78 on the interpolator's acceleration bound).
            self.z3.send("(set-option :produce-unsat-cores true)");
            self.z3.send("(set-option :sat.core.minimize true)");
            self.z3.send("(set-option :smt.core.minimize true)");
        }
        self.bit_vectors_only = true;
        let mut products = Vec::new();
        for (i, (n, _)) in self.nodes.iter().zip(need).enumerate().filter(|(_, (_, k))| *k) {
            self.bit_vectors_only &= n.sort != Sort::F32;
            match n.product {
                Some((a, b)) if abstracted => {
                    let id = u32::try_from(i).expect("fewer than 2^32 terms");
                    self.z3.send(&format!("(declare-const {} {})", name(id), n.sort.smt()));
                    products.push((id, a, b, n.sort));
                }
                _ => self.z3.send(&n.cmd),
            }
        }
        for lemma in product_lemmas(&products) {
            self.z3.send(&format!("(assert {})", lemma.text));
        }
        !products.is_empty()
    }

    /// Marks node `id` (a product of `a` and `b`) nonlinear if neither
    /// factor is a constant.
    fn mark_product(&mut self, id: u32, a: u32, b: u32) {
        let ground = |c: &Ctx, i: u32| c.nodes.get(i as usize).map(|n| n.ground).expect("a node of this context");
        if !ground(self, a) && !ground(self, b) {
            if let Some(n) = self.nodes.get_mut(id as usize) {
                n.nonlinear = true;
                n.product = Some((a, b));
            }
        }
    }

    /// Satisfiability of the path condition plus `extra`, in stages, each
    /// on a formula implied by the real one (so `unsat` at any stage is
    /// `unsat` for the real one):
    ///
    /// 1. the path condition without its literals that contain a product
    ///    of two non-constant terms ("nonlinear"), plus `extra`;
    /// 2. everything, with those products abstracted ([`Ctx::load`]);
    /// 3. everything.
    ///
    /// A feasibility check (`Check::Decision`) stops after stage 1: if that
    /// is not `unsat` and literals were left out, it answers `Unknown`
    /// (the caller explores both outcomes: sound, an infeasible path costs
    /// time, never soundness); and a nonlinear `extra` is not checked at
    /// all (`Unknown`). A property check (`Check::Property`) goes on until
    /// a stage is conclusive (the last one is the real formula, so its
    /// `sat` is a real counterexample).
    fn check_with(&mut self, extra: Option<(u32, bool)>, timeout_ms: u32, kind: Check) -> Sat {
        let nonlinear = |c: &Ctx, l: &(u32, bool)| c.nodes.get(l.0 as usize).is_some_and(|n| n.nonlinear);
        let mut all = self.explorer.lits.clone();
        all.extend(extra);
        if kind == Check::Decision && extra.is_some_and(|e| nonlinear(self, &e)) {
            self.explorer.blind += 1;
            return Sat::Unknown;
        }
        let linear: Vec<(u32, bool)> = all.iter().copied().filter(|l| !nonlinear(self, l)).collect();
        let dropped = linear.len() < all.len();
        if kind == Check::Decision {
            let r = self.check_lits(&linear, timeout_ms, false, false);
            if dropped && r == Sat::Sat {
                self.explorer.blind += 1;
                return Sat::Unknown;
            }
            if r == Sat::Unknown {
                self.explorer.unknown += 1;
            }
            return r;
        }
        let cores = self.explorer.blind_all;
        let prop = extra.map(|e| e.0);
        if cores {
            let have: std::collections::HashSet<(u32, bool)> = all.iter().copied().collect();
            let hit = self
                .explorer
                .cores
                .iter()
                .any(|(p, core)| (*p == u32::MAX || Some(*p) == prop) && core.iter().all(|l| have.contains(l)));
            if hit {
                self.explorer.reused += 1;
                return Sat::Unsat;
            }
        }
        let stages: &[(bool, bool)] =
            if dropped { &[(false, true), (true, false), (false, false)] } else { &[(false, false)] };
        for (i, &(abstracted, linear_only)) in stages.iter().enumerate() {
            let last = i + 1 == stages.len();
            let lits = if linear_only { &linear } else { &all };
            let ms = if last { timeout_ms } else { timeout_ms.min(STAGE_TIMEOUT_MS) };
            let r = self.check_lits(lits, ms, abstracted, cores);
            if r == Sat::Unsat {
                if cores {
                    let core = self.z3.unsat_core();
                    let negated = extra.map(|e| (e.0, e.1));
                    let key = if core.iter().any(|&k| lits.get(k).copied() == negated) {
                        prop.unwrap_or(u32::MAX)
                    } else {
                        u32::MAX
                    };
                    let core: Vec<(u32, bool)> =
                        core.iter().filter_map(|&k| lits.get(k).copied()).filter(|l| Some(*l) != negated).collect();
                    self.explorer.cores.push((key, core));
                }
                return r;
            }
            if last {
                return r;
            }
        }
        Sat::Unknown
    }

    /// One check of the conjunction of `lits`; with `cores`, each literal
    /// is named `l<index>` for [`crate::z3::Z3::unsat_core`].
    fn check_lits(&mut self, lits: &[(u32, bool)], timeout_ms: u32, abstracted: bool, cores: bool) -> Sat {
        let ids: Vec<u32> = lits.iter().map(|l| l.0).chain(self.vars.iter().map(|v| v.1)).collect();
        self.load(&ids, abstracted, cores);
        for (i, &(id, v)) in lits.iter().enumerate() {
            if cores {
                self.z3.send(&format!("(assert (! {} :named l{i}))", literal(id, v)));
            } else {
                self.z3.send(&format!("(assert {})", literal(id, v)));
            }
        }
        let t0 = Instant::now();
        let r = self.z3.check(timeout_ms, self.explorer.blind_all, !self.bit_vectors_only);
        if std::env::var_os("SMT_VERBOSE").is_some() {
            let (paths, depth) = (self.explorer.pending.len(), self.explorer.decisions.len());
            eprintln!(
                "    check{}: {r:?} in {:.2} s ({} literals, depth {depth}, {paths} pending)",
                if abstracted { " (abstracted)" } else { "" },
                t0.elapsed().as_secs_f64(),
                lits.len()
            );
        }
        r
    }
}

/// Facts true of the real products, asserted when they are abstracted
/// (`(id, a, b, sort)`: node `id` is `a * b`). For squares (`a == b`),
/// per variant:
///
/// - `f32` (`fl(x x)`, rounded to nearest): NaN iff `x` is NaN, else
///   `>= +0`; infinite if `x` is; zero if `x` is; and for two squares,
///   `|x| <= |y|` implies `fl(x x) <= fl(y y)` (the real square is monotone
///   in `|x|`, and rounding to nearest is monotone);
/// - `I8F24` (`saturating_mul`: `floor(x^2 / 2^24)`, saturating to MAX as
///   the operands' signs agree): `>= 0`; and for two squares,
///   `saturating_abs(x) <= saturating_abs(y)` implies `x x <= y y` (`|MIN|`
///   saturates to MAX, and both their squares saturate to MAX).
///
/// For every product `p = x y`, each way round:
///
/// - `f32`: a NaN factor gives NaN, two finite factors do not; if
///   `|y| <= 1` and `p` is not NaN, `|p| <= |x|` (`|x y| <= |x|`, `|x|` is
///   representable and rounding is monotone; `inf * 0`, the only other
///   NaN, is excluded);
/// - `I8F24`: if `saturating_abs(y) <= 1.0`, `saturating_abs(p) <=
///   saturating_abs(x)` (`floor(x y / 2^24)` lies between `x` and `-|x|`
///   rounded toward it, as `x` is an integer of LSBs; `MIN * -1`
///   saturates to MAX = `|MIN|` saturated).
///
/// How each kind is established (z3 on the real product, z3 on its
/// integer transcription, or every input enumerated): `tests/lemmas.rs`
/// and the README.
pub fn product_lemmas(products: &[(u32, u32, u32, Sort)]) -> Vec<Lemma> {
    use LemmaKind::*;
    let squares: Vec<(String, String, Sort)> =
        products.iter().filter(|p| p.1 == p.2).map(|p| (name(p.0), name(p.1), p.3)).collect();
    let abs = |v: &str| format!("(ite (= {v} {MIN}) {MAX} (ite (bvslt {v} #x00000000) (bvneg {v}) {v}))");
    let mut out = Vec::new();
    let mut push = |kind: LemmaKind, sort: Sort, text: String| out.push(Lemma { kind, sort, text });
    for &(p, a, b, sort) in products {
        let (p, a, b) = (name(p), name(a), name(b));
        for (x, y) in [(&a, &b), (&b, &a)] {
            match sort {
                Sort::F32 => {
                    push(NanFactor, sort, format!("(=> (fp.isNaN {x}) (fp.isNaN {p}))"));
                    push(
                        FactorAtMostOne,
                        sort,
                        format!(
                            "(=> (and (fp.leq (fp.abs {y}) (fp #b0 #x7f #b00000000000000000000000)) (not (fp.isNaN {p}))) \
                             (fp.leq (fp.abs {p}) (fp.abs {x})))"
                        ),
                    );
                }
                Sort::Bv32 => {
                    push(
                        FactorAtMostOne,
                        sort,
                        format!(
                            "(=> (bvsle {} {}) (bvsle {} {}))",
                            abs(y),
                            crate::ctx::bv32_literal(1 << 24),
                            abs(&p),
                            abs(x)
                        ),
                    );
                }
                Sort::Bool => {}
            }
        }
        if sort == Sort::F32 {
            let finite = |v: &str| format!("(not (or (fp.isNaN {v}) (fp.isInfinite {v})))");
            push(FiniteFactors, sort, format!("(=> (and {} {}) (not (fp.isNaN {p})))", finite(&a), finite(&b)));
        }
    }
    for (p, x, sort) in &squares {
        match sort {
            Sort::F32 => {
                push(SquareSign, *sort, format!("(ite (fp.isNaN {x}) (fp.isNaN {p}) (fp.leq (_ +zero 8 24) {p}))"));
                push(SquareInfinite, *sort, format!("(=> (fp.isInfinite {x}) (fp.isInfinite {p}))"));
                push(SquareZero, *sort, format!("(=> (fp.isZero {x}) (fp.isZero {p}))"));
            }
            Sort::Bv32 => push(SquareSign, *sort, format!("(bvsle #x00000000 {p})")),
            Sort::Bool => {}
        }
    }
    for (i, (p, x, sort)) in squares.iter().enumerate() {
        for (q, y, _) in squares.iter().skip(i + 1).filter(|s| s.2 == *sort) {
            match sort {
                Sort::F32 => {
                    for (p, x, q, y) in [(p, x, q, y), (q, y, p, x)] {
                        push(
                            SquareMonotone,
                            *sort,
                            format!("(=> (fp.leq (fp.abs {x}) (fp.abs {y})) (fp.leq {p} {q}))"),
                        );
                    }
                }
                Sort::Bv32 => {
                    for (p, x, q, y) in [(p, x, q, y), (q, y, p, x)] {
                        push(SquareMonotone, *sort, format!("(=> (bvsle {} {}) (bvsle {p} {q}))", abs(x), abs(y)));
                    }
                }
                Sort::Bool => {}
            }
        }
    }
    out
}

/// The kinds of fact [`product_lemmas`] asserts (each a schema over the
/// nodes it names; see `tests/lemmas.rs` for how each is established).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LemmaKind {
    /// A NaN factor gives a NaN product (`f32`).
    NanFactor,
    /// A factor in `[-1, 1]` gives a product no larger in magnitude than
    /// the other factor.
    FactorAtMostOne,
    /// Two finite factors give a product that is not NaN (`f32`).
    FiniteFactors,
    /// A square is NaN iff its operand is (`f32`), else `>= 0`.
    SquareSign,
    /// The square of an infinity is infinite (`f32`).
    SquareInfinite,
    /// The square of a zero is zero (`f32`).
    SquareZero,
    /// `|x| <= |y|` implies `x x <= y y`.
    SquareMonotone,
}

/// One fact asserted about abstracted products: an SMT formula over the
/// product and factor nodes it names.
#[derive(Clone, Debug)]
pub struct Lemma {
    /// Which schema it instantiates.
    pub kind: LemmaKind,
    /// The sort of the product.
    pub sort: Sort,
    /// The formula.
    pub text: String,
}

/// Refutes the negation of `formula` over the real definitions of the
/// nodes it names (`roots`, none abstracted): `Unsat` proves `formula`
/// for every value of the inputs those nodes depend on. Bit-blasted, as
/// the blind proofs' checks are.
pub fn refute(roots: &[u32], formula: &str, timeout_ms: u32) -> Sat {
    with(|c| {
        c.load(roots, false, false);
        c.z3.send(&format!("(assert (not {formula}))"));
        let fp = !c.bit_vectors_only;
        c.z3.check(timeout_ms, true, fp)
    })
}

const MAX: &str = "#x7fffffff";
const MIN: &str = "#x80000000";

/// Timeout of the weaker stages of a property check ([`Ctx::check_with`]).
const STAGE_TIMEOUT_MS: u32 = 60_000;

/// What a [`Ctx::check_with`] is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Check {
    /// Path feasibility (or a precondition): `Unknown` explores both.
    Decision,
    /// A property on a complete path: only `Unsat` proves it.
    Property,
}

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
    decide_with(cond, false)
}

/// [`decide`] without asking z3 whether the outcomes are feasible: both are
/// explored (sound, as a blind decision is; see [`explore_blind`]). For
/// Boolean inputs the proof draws itself, which are feasible both ways
/// until the path condition mentions them.
pub fn branch(cond: u32) -> bool {
    decide_with(cond, true)
}

fn decide_with(cond: u32, open: bool) -> bool {
    match cond {
        TRUE => return true,
        FALSE => return false,
        _ => {}
    }
    with(|c| {
        debug_assert_eq!(c.nodes.get(cond as usize).map(|n| n.sort), Some(Sort::Bool));
        if c.explorer.evaluate {
            c.load(&[cond], false, false);
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
            let ground = c.nodes.get(cond as usize).is_some_and(|n| n.ground);
            // A constant condition (no input in it), when asked: z3's
            // evaluator gives its one outcome (blind exploration would take
            // both).
            let value = if ground && c.explorer.evaluate_constants {
                c.load(&[cond], false, false);
                match c.z3.simplify(&name(cond)).as_str() {
                    "true" => Some(true),
                    "false" => Some(false),
                    _ => None,
                }
            } else {
                None
            };
            let (t, f) = if let Some(v) = value {
                if v {
                    (Sat::Sat, Sat::Unsat)
                } else {
                    (Sat::Unsat, Sat::Sat)
                }
            } else if c.explorer.blind_all || open {
                c.explorer.blind += 1;
                (Sat::Unknown, Sat::Unknown)
            } else {
                let t = c.check_with(Some((cond, true)), ms, Check::Decision);
                (t, if t == Sat::Unsat { Sat::Unsat } else { c.check_with(Some((cond, false)), ms, Check::Decision) })
            };
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
        if !replaying
            && c.check_with(Some((cond, true)), crate::z3::property_timeout_ms(), Check::Decision) == Sat::Unsat
        {
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
    /// Feasibility checks left open because the path condition or the
    /// decision contains a product of two non-constant terms (both
    /// outcomes were explored; see `Ctx::check_with`).
    pub blind: u64,
    /// Property checks answered by an earlier path's unsatisfiable core
    /// (see [`explore_blind`]).
    pub reused: u64,
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
pub fn explore(f: impl FnMut() -> Vec<u32>) -> Outcome {
    explore_with(false, false, f)
}

/// [`explore`], but every decision explores both outcomes without asking
/// z3 whether they are feasible (infeasible paths included: each path's
/// property is still checked under its own path condition, so this is
/// sound), and a property check reuses the unsatisfiable cores of earlier
/// paths: a path containing every literal of such a core is proved with no
/// z3 call. Pays when most decisions do not matter to the property (each
/// path's check then needs few of its literals) and feasibility checks are
/// expensive (floating point).
pub fn explore_blind(f: impl FnMut() -> Vec<u32>) -> Outcome {
    explore_with(true, false, f)
}

/// [`explore_blind`], except that a decision on a constant (a term with
/// no input in it: the preparation steps of `props::gate_homing`) takes
/// the value z3's evaluator gives it, so only the outcome the code takes
/// is explored. For proofs whose decisions on inputs are each feasible
/// both ways, where feasibility checks cost most of the time.
pub fn explore_blind_evaluating_constants(f: impl FnMut() -> Vec<u32>) -> Outcome {
    explore_with(true, true, f)
}

fn explore_with(blind_all: bool, evaluate_constants: bool, mut f: impl FnMut() -> Vec<u32>) -> Outcome {
    let t0 = Instant::now();
    let checks0 = with(|c| {
        c.explorer = Explorer { pending: vec![Vec::new()], blind_all, evaluate_constants, ..Explorer::default() };
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
                match c.check_with(Some((prop, false)), crate::z3::property_timeout_ms(), Check::Property) {
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
    let (checks, undecided, blind, reused) = with(|c| {
        c.explorer.pending.clear();
        (c.z3.checks - checks0, c.explorer.unknown, c.explorer.blind, c.explorer.reused)
    });
    assert!(
        paths > 0 || counterexample.is_some(),
        "vacuous: no path satisfies the preconditions ({discarded} discarded)"
    );
    Outcome { paths, discarded, checks, undecided, blind, reused, time: t0.elapsed(), counterexample }
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
        c.load(&[id], false, false);
        c.z3.simplify(&name(id))
    })
}

/// z3's simplification of many nodes (pipelined).
pub fn simplify_many(ids: &[u32]) -> Vec<String> {
    let names: Vec<String> = ids.iter().map(|&i| name(i)).collect();
    with(|c| {
        c.load(ids, false, false);
        c.z3.simplify_many(&names)
    })
}

/// Satisfiability of the conjunction of Boolean nodes `lits` (outside
/// path exploration; for the semantics tests).
pub fn satisfiable(lits: &[u32]) -> bool {
    with(|c| {
        c.load(lits, false, false);
        for &l in lits {
            c.z3.send(&format!("(assert {})", name(l)));
        }
        match c.z3.check(crate::z3::property_timeout_ms(), false, true) {
            Sat::Sat => true,
            Sat::Unsat => false,
            Sat::Unknown => panic!("z3 could not decide a check"),
        }
    })
}
