//! The symbolic scalars: [`SymF32`] (IEEE binary32, SMT `FloatingPoint 8
//! 24`) and [`SymFx`] (`I8F24` as a 32-bit bit-vector with the `fixed`
//! crate's saturation and rounding), each implementing `kernel::Scalar`,
//! and [`B`], Boolean terms for stating properties.
//!
//! Every arithmetic method builds a term; every `bool` the trait returns
//! (comparisons, `is_finite`) is a path decision ([`crate::ctx::decide`]).
//! Constants (`ZERO`, `ONE`, `from_f32`) are the concrete implementation's
//! own values, as SMT literals.

use crate::ctx::{self, name, Sort};
use core::cmp::Ordering;
use fixed::types::I8F24;
use kernel::Scalar;

/// A Boolean term, for properties and preconditions (never a decision).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct B(pub u32);

impl B {
    /// `true`.
    pub const TRUE: B = B(ctx::TRUE);
    /// `false`.
    pub const FALSE: B = B(ctx::FALSE);
    fn op(text: String) -> B {
        B(ctx::term(Sort::Bool, text))
    }
    /// Conjunction.
    pub fn and(self, o: B) -> B {
        B::op(format!("(and {} {})", name(self.0), name(o.0)))
    }
    /// Disjunction.
    pub fn or(self, o: B) -> B {
        B::op(format!("(or {} {})", name(self.0), name(o.0)))
    }
    /// Negation.
    #[allow(clippy::should_implement_trait)]
    pub fn not(self) -> B {
        B::op(format!("(not {})", name(self.0)))
    }
    /// Implication.
    pub fn implies(self, o: B) -> B {
        B::op(format!("(=> {} {})", name(self.0), name(o.0)))
    }
    /// Conjunction of all.
    pub fn all(items: &[B]) -> B {
        items.iter().fold(B::TRUE, |a, &b| a.and(b))
    }
    /// A Boolean input (unconstrained).
    pub fn var(label: &str) -> B {
        B(ctx::var(Sort::Bool, label))
    }
    /// Makes this a precondition of the current path.
    pub fn assume(self) {
        ctx::assume(self.0);
    }
    /// This term's outcome on the current path (a decision).
    pub fn decide(self) -> bool {
        ctx::decide(self.0)
    }
    /// This term's outcome on the current path, both outcomes explored
    /// without a feasibility check ([`ctx::branch`]).
    pub fn branch(self) -> bool {
        ctx::branch(self.0)
    }
}

/// The `Wide` type of the symbolic scalars: the conversions that use it
/// (`from_counts`, `to_rate`) are not part of the proven code and panic if
/// reached, so a proof that reaches them fails loudly.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Unsupported;

/// A symbolic scalar, with term-level (non-deciding) predicates for
/// stating properties.
pub trait Sym: Scalar {
    /// Variant name for reports.
    const VARIANT: &'static str;
    /// An input: any value of the type (every bit pattern).
    fn var(label: &str) -> Self;
    /// The node id.
    fn id(self) -> u32;
    /// `self < o` as a term.
    fn t_lt(self, o: Self) -> B;
    /// `self <= o` as a term.
    fn t_le(self, o: Self) -> B;
    /// `self == o` as a term (`PartialEq`: IEEE equality for `f32`).
    fn t_eq(self, o: Self) -> B;
    /// `is_finite` as a term.
    fn t_finite(self) -> B;
    /// Same value, bit for bit (NaN equals NaN: SMT has one NaN).
    fn t_same(self, o: Self) -> B {
        B(ctx::term(Sort::Bool, format!("(= {} {})", name(self.id()), name(o.id()))))
    }
    /// `self >= o` as a term.
    fn t_ge(self, o: Self) -> B {
        o.t_le(self)
    }
    /// `self > o` as a term.
    fn t_gt(self, o: Self) -> B {
        o.t_lt(self)
    }
}

fn unsupported(what: &str) -> ! {
    panic!("Scalar::{what} is not modelled by the symbolic scalar: the proven code must not reach it")
}

/// Defines `PartialEq` / `PartialOrd` on a symbolic type through decisions.
macro_rules! deciding_order {
    ($T:ty) => {
        impl PartialEq for $T {
            fn eq(&self, o: &Self) -> bool {
                self.t_eq(*o).decide()
            }
        }
        impl PartialOrd for $T {
            fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
                if self.t_lt(*o).decide() {
                    Some(Ordering::Less)
                } else if o.t_lt(*self).decide() {
                    Some(Ordering::Greater)
                } else if self.t_eq(*o).decide() {
                    Some(Ordering::Equal)
                } else {
                    None
                }
            }
            fn lt(&self, o: &Self) -> bool {
                self.t_lt(*o).decide()
            }
            fn le(&self, o: &Self) -> bool {
                self.t_le(*o).decide()
            }
            fn gt(&self, o: &Self) -> bool {
                o.t_lt(*self).decide()
            }
            fn ge(&self, o: &Self) -> bool {
                o.t_le(*self).decide()
            }
        }
    };
}

// ---------------------------------------------------------------- f32 --

/// A symbolic IEEE binary32 (round to nearest, ties to even; subnormals;
/// one NaN: the kernel never looks at NaN payloads).
#[derive(Clone, Copy, Debug)]
pub struct SymF32(pub u32);

impl SymF32 {
    /// The literal `x` (bit for bit; every NaN becomes SMT's NaN).
    pub fn constant(x: f32) -> SymF32 {
        SymF32(ctx::term(Sort::F32, ctx::f32_literal(x)))
    }
    fn op(text: String) -> SymF32 {
        SymF32(ctx::term(Sort::F32, text))
    }
    fn bool(text: String) -> B {
        B(ctx::term(Sort::Bool, text))
    }
    /// `f32::min` / `f32::max`: a NaN operand is ignored (the other is
    /// returned; NaN only if both are); otherwise the smaller / larger; if
    /// they compare equal (`+0.0` and `-0.0`), Rust returns either one, "non-
    /// deterministically" (core::intrinsics::minnumf32 docs): a fresh
    /// choice variable picks it, so a proof holds for both.
    fn min_max(self, o: SymF32, lt: &str) -> SymF32 {
        let k = name(ctx::choice());
        let (a, b) = (name(self.0), name(o.0));
        SymF32::op(format!(
            "(ite (fp.isNaN {a}) {b} (ite (fp.isNaN {b}) {a} (ite ({lt} {a} {b}) {a} (ite ({lt} {b} {a}) {b} (ite {k} {a} {b})))))"
        ))
    }
}

deciding_order!(SymF32);

impl Sym for SymF32 {
    const VARIANT: &'static str = "f32";
    fn var(label: &str) -> Self {
        SymF32(ctx::var(Sort::F32, label))
    }
    fn id(self) -> u32 {
        self.0
    }
    fn t_lt(self, o: Self) -> B {
        SymF32::bool(format!("(fp.lt {} {})", name(self.0), name(o.0)))
    }
    fn t_le(self, o: Self) -> B {
        SymF32::bool(format!("(fp.leq {} {})", name(self.0), name(o.0)))
    }
    fn t_eq(self, o: Self) -> B {
        SymF32::bool(format!("(fp.eq {} {})", name(self.0), name(o.0)))
    }
    fn t_finite(self) -> B {
        let a = name(self.0);
        SymF32::bool(format!("(not (or (fp.isNaN {a}) (fp.isInfinite {a})))"))
    }
}

impl Scalar for SymF32 {
    const ZERO: Self = SymF32(ctx::F32_ZERO);
    const ONE: Self = SymF32(ctx::F32_ONE);
    type Wide = Unsupported;

    fn from_f32(x: f32) -> Self {
        SymF32::constant(<f32 as Scalar>::from_f32(x))
    }
    fn to_f32(self) -> f32 {
        unsupported("to_f32")
    }
    fn wide_from_f64(_: f64) -> Unsupported {
        Unsupported
    }
    fn plus(self, rhs: Self) -> Self {
        SymF32::op(format!("(fp.add RNE {} {})", name(self.0), name(rhs.0)))
    }
    fn minus(self, rhs: Self) -> Self {
        SymF32::op(format!("(fp.sub RNE {} {})", name(self.0), name(rhs.0)))
    }
    fn times(self, rhs: Self) -> Self {
        SymF32(ctx::product(Sort::F32, format!("(fp.mul RNE {} {})", name(self.0), name(rhs.0)), self.0, rhs.0))
    }
    fn times_int(self, n: i32) -> Self {
        // `self * n as f32`: the conversion is Rust's, on a constant.
        SymF32::op(format!("(fp.mul RNE {} {})", name(self.0), ctx::f32_literal(n as f32)))
    }
    fn div_int(self, n: i32) -> Self {
        if n >= 1 {
            SymF32::op(format!("(fp.div RNE {} {})", name(self.0), ctx::f32_literal(n as f32)))
        } else {
            Self::ZERO
        }
    }
    fn neg(self) -> Self {
        SymF32::op(format!("(fp.neg {})", name(self.0)))
    }
    fn abs(self) -> Self {
        SymF32::op(format!("(fp.abs {})", name(self.0)))
    }
    fn min(self, rhs: Self) -> Self {
        self.min_max(rhs, "fp.lt")
    }
    fn max(self, rhs: Self) -> Self {
        self.min_max(rhs, "fp.gt")
    }
    fn is_finite(self) -> bool {
        self.t_finite().decide()
    }
    fn from_counts(_: i32, _: Unsupported) -> Self {
        unsupported("from_counts")
    }
    fn to_rate(self, _: Unsupported) -> i32 {
        unsupported("to_rate")
    }
    fn to_scaled_int(self, _: i64) -> i64 {
        unsupported("to_scaled_int")
    }
    fn parse_decimal(_: &str) -> Option<Self> {
        unsupported("parse_decimal")
    }
}

// -------------------------------------------------------------- I8F24 --

/// A symbolic `I8F24`: its 32-bit two's-complement word, with the `fixed`
/// crate's saturating operations (fixed 1.31 source, `saturating_*`,
/// `arith::i32::overflowing_mul`, `checked_div_int`).
#[derive(Clone, Copy, Debug)]
pub struct SymFx(pub u32);

const MAX: &str = "#x7fffffff";
const MIN: &str = "#x80000000";

impl SymFx {
    /// The literal `x`.
    pub fn constant(x: I8F24) -> SymFx {
        SymFx(ctx::term(Sort::Bv32, ctx::bv32_literal(x.to_bits() as u32)))
    }
    fn op(text: String) -> SymFx {
        SymFx(ctx::term(Sort::Bv32, text))
    }
    fn bool(text: String) -> B {
        B(ctx::term(Sort::Bool, text))
    }
    /// `i32::saturating_add` / `saturating_sub` (`op` = `bvadd` / `bvsub`):
    /// exact in 33 bits; out of range (bit 32 differs from bit 31)
    /// saturates toward the true result's sign (bit 32).
    fn saturating(self, o: SymFx, op: &str) -> SymFx {
        let (a, b) = (name(self.0), name(o.0));
        SymFx::op(format!(
            "(let ((s ({op} ((_ sign_extend 1) {a}) ((_ sign_extend 1) {b})))) \
             (ite (= ((_ extract 32 32) s) ((_ extract 31 31) s)) ((_ extract 31 0) s) \
             (ite (= ((_ extract 32 32) s) #b0) {MAX} {MIN})))"
        ))
    }
}

deciding_order!(SymFx);

impl Sym for SymFx {
    const VARIANT: &'static str = "I8F24";
    fn var(label: &str) -> Self {
        SymFx(ctx::var(Sort::Bv32, label))
    }
    fn id(self) -> u32 {
        self.0
    }
    fn t_lt(self, o: Self) -> B {
        SymFx::bool(format!("(bvslt {} {})", name(self.0), name(o.0)))
    }
    fn t_le(self, o: Self) -> B {
        SymFx::bool(format!("(bvsle {} {})", name(self.0), name(o.0)))
    }
    fn t_eq(self, o: Self) -> B {
        self.t_same(o)
    }
    fn t_finite(self) -> B {
        B::TRUE
    }
}

impl Scalar for SymFx {
    const ZERO: Self = SymFx(ctx::FX_ZERO);
    const ONE: Self = SymFx(ctx::FX_ONE);
    type Wide = Unsupported;

    fn from_f32(x: f32) -> Self {
        SymFx::constant(<I8F24 as Scalar>::from_f32(x))
    }
    fn to_f32(self) -> f32 {
        unsupported("to_f32")
    }
    fn wide_from_f64(_: f64) -> Unsupported {
        Unsupported
    }
    fn plus(self, rhs: Self) -> Self {
        self.saturating(rhs, "bvadd")
    }
    fn minus(self, rhs: Self) -> Self {
        self.saturating(rhs, "bvsub")
    }
    /// `saturating_mul`: `fixed` multiplies the bits widened to `i64`, the
    /// right one shifted left by the 8 integer bits, keeps the high word
    /// (`>> 32`: a floor), and saturates (toward the operands' sign
    /// product) when the `i64` product overflows, i.e. exactly when
    /// `floor(a b / 2^24)` is outside `i32`. Here: the exact product in 64
    /// bits (|a b| <= 2^62), an arithmetic shift by 24, a range check.
    fn times(self, rhs: Self) -> Self {
        let (a, b) = (name(self.0), name(rhs.0));
        let text = format!(
            "(let ((q (bvashr (bvmul ((_ sign_extend 32) {a}) ((_ sign_extend 32) {b})) #x0000000000000018))) \
             (ite (and (bvsle q #x000000007fffffff) (bvsge q #xffffffff80000000)) ((_ extract 31 0) q) \
             (ite (xor (bvslt {a} #x00000000) (bvslt {b} #x00000000)) {MIN} {MAX})))"
        );
        SymFx(ctx::product(Sort::Bv32, text, self.0, rhs.0))
    }
    /// `saturating_mul_int`: `i32::overflowing_mul` of the bits; on
    /// overflow MIN if the signs differ, else MAX.
    fn times_int(self, n: i32) -> Self {
        let a = name(self.0);
        let n64 = format!("#x{:016x}", i64::from(n) as u64);
        let (if_neg, if_pos) = if n < 0 { (MAX, MIN) } else { (MIN, MAX) };
        SymFx::op(format!(
            "(let ((p (bvmul ((_ sign_extend 32) {a}) {n64}))) \
             (ite (and (bvsle p #x000000007fffffff) (bvsge p #xffffffff80000000)) ((_ extract 31 0) p) \
             (ite (bvslt {a} #x00000000) {if_neg} {if_pos})))"
        ))
    }
    /// `checked_div_int(n)` for `n >= 1` (`i32::checked_div`: truncation
    /// toward zero, never `None` for `n >= 1`), else zero.
    fn div_int(self, n: i32) -> Self {
        if n >= 1 {
            SymFx::op(format!("(bvsdiv {} {})", name(self.0), ctx::bv32_literal(n as u32)))
        } else {
            Self::ZERO
        }
    }
    /// `saturating_neg`: only MIN overflows, to MAX.
    fn neg(self) -> Self {
        let a = name(self.0);
        SymFx::op(format!("(ite (= {a} {MIN}) {MAX} (bvneg {a}))"))
    }
    /// `saturating_abs`: only MIN overflows, to MAX.
    fn abs(self) -> Self {
        let a = name(self.0);
        SymFx::op(format!("(ite (= {a} {MIN}) {MAX} (ite (bvslt {a} #x00000000) (bvneg {a}) {a}))"))
    }
    /// `Ord::min` (equal values are the same bits).
    fn min(self, rhs: Self) -> Self {
        let (a, b) = (name(self.0), name(rhs.0));
        SymFx::op(format!("(ite (bvsle {a} {b}) {a} {b})"))
    }
    /// `Ord::max`.
    fn max(self, rhs: Self) -> Self {
        let (a, b) = (name(self.0), name(rhs.0));
        SymFx::op(format!("(ite (bvsle {a} {b}) {b} {a})"))
    }
    fn is_finite(self) -> bool {
        true
    }
    fn from_counts(_: i32, _: Unsupported) -> Self {
        unsupported("from_counts")
    }
    fn to_rate(self, _: Unsupported) -> i32 {
        unsupported("to_rate")
    }
    fn to_scaled_int(self, _: i64) -> i64 {
        unsupported("to_scaled_int")
    }
    fn parse_decimal(_: &str) -> Option<Self> {
        unsupported("parse_decimal")
    }
}
