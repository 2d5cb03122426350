//! The facts `ctx::product_lemmas` asserts about abstracted products
//! (the interpolator's braking test and the soft-stop envelope rest on
//! them), established per kind of fact and variant:
//!
//! - **proved by z3** (`f32`: a NaN factor, a factor in `[-1, 1]`, two
//!   finite factors, and the square's sign, infinity and zero): each fact
//!   as `ctx::product_lemmas` writes it, instantiated once on fresh inputs
//!   `x`, `y` and the real products `x y` or `x x` (the same terms the
//!   symbolic `f32` builds, not abstracted), its negation unsatisfiable:
//!   on unconstrained inputs the instance is the schema;
//! - **exhaustive** (the square facts of both variants, including
//!   "`|x| <= |y|` implies `x x <= y y`", which z3 does not decide within
//!   minutes): every one of the 2^32 inputs, on the concrete types. The
//!   square of `x` equals the square of `|x|` bit for bit (checked for
//!   every `x`), and the square of a non-negative value is non-decreasing
//!   in it (checked for every consecutive pair of the 2^31 non-negative
//!   values, `f32` ordered by bit pattern up to `+inf`): together
//!   monotonicity in `|x|` for every pair. What is enumerated is Rust's
//!   `f32` multiplication and the `fixed` crate's `saturating_mul`; that
//!   the symbolic terms compute the same is the semantics check
//!   (`tests/semantics.rs`, sampled);
//! - **proved by z3 over the integers** (`I8F24`, a factor in `[-1, 1]`,
//!   where the bit-vector form, a 64-bit multiplier of two unknowns, is not
//!   decided within minutes): the product term `SymFx::times` builds,
//!   written over the integers operator for operator ([`INT_PRODUCT`]),
//!   and the fact as `ctx::product_lemmas` writes it, likewise; z3 proves
//!   the fact for every pair of 32-bit words, and that the transcription
//!   is exact (the 64-bit product of two words never wraps). The
//!   transcription is checked against the kernel's multiply on
//!   enumerated slices (every word times +-1.0 and +-(1.0 - 1 LSB), every
//!   factor in `[-1, 1]` times 48 boundary words) and on random pairs, and
//!   z3's own evaluation of it against its Rust mirror on samples; boundary
//!   values and random pairs also check the fact on the concrete type.
//!
//! `every_lemma_kind_is_established` fails if `ctx::product_lemmas` asserts
//! a kind of fact none of these establishes.
//!
//! The z3 and exhaustive tests are `#[ignore]`d (z3 is needed, and 2^32
//! iterations want a release build): `proofs/smt/run.sh` runs them.

use fixed::types::I8F24;
use smt::ctx::{self, LemmaKind, Sort};
use smt::sym::{Sym, SymF32, SymFx};
use std::collections::BTreeSet;
use std::time::Instant;

fn xorshift(seed: &mut u64) -> u64 {
    *seed ^= *seed << 13;
    *seed ^= *seed >> 7;
    *seed ^= *seed << 17;
    *seed
}

/// `a => b`.
fn implies(a: bool, b: bool) -> bool {
    !a || b
}

fn f32_values() -> Vec<f32> {
    let mut v = vec![
        0.0,
        -0.0,
        1.0,
        -1.0,
        0.5,
        f32::from_bits(0x3f7f_ffff),
        f32::from_bits(0x3f80_0001),
        f32::MIN_POSITIVE,
        f32::from_bits(1),
        -f32::from_bits(1),
        f32::MAX,
        f32::MIN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        1.8e19,
        -1.9e19,
        3.0,
        6.0,
        0.03,
    ];
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    for _ in 0..3000 {
        v.push(f32::from_bits(xorshift(&mut seed) as u32));
        v.push((xorshift(&mut seed) % 2_000_001) as f32 / 100_000.0 - 10.0);
    }
    v
}

/// The `f32` facts are also enumerated here on samples (cheap, no z3).
#[test]
fn f32_product_facts_hold_on_samples() {
    let v = f32_values();
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut pairs: Vec<(f32, f32)> = v.iter().take(20).flat_map(|&x| v.iter().take(20).map(move |&y| (x, y))).collect();
    for _ in 0..400_000 {
        let i = (xorshift(&mut seed) % v.len() as u64) as usize;
        let j = (xorshift(&mut seed) % v.len() as u64) as usize;
        pairs.push((v[i], v[j]));
    }
    for (x, y) in pairs {
        let p = x * y;
        for (a, b) in [(x, y), (y, x)] {
            assert!(implies(a.is_nan(), p.is_nan()), "NaN factor {a} * {b} = {p}");
            let small = b.abs() <= 1.0 && !p.is_nan();
            assert!(implies(small, p.abs() <= a.abs()), "|{a} * {b}| = {p} > |{a}|");
        }
        assert!(implies(x.is_finite() && y.is_finite(), !p.is_nan()), "{x} * {y} is NaN");
        let (sx, sy) = (x * x, y * y);
        assert_eq!(x.is_nan(), sx.is_nan());
        assert!(x.is_nan() || sx >= 0.0);
        assert!(implies(x.is_infinite(), sx.is_infinite()));
        assert!(implies(x == 0.0, sx == 0.0));
        assert!(implies(x.abs() <= y.abs(), sx <= sy), "{x}^2 = {sx} > {y}^2 = {sy}");
    }
}

/// The `I8F24` facts on the concrete type, on samples (cheap, no z3): a
/// factor in `[-1, 1]` (proved over the integers below) and the
/// exhaustively checked square facts again on pairs.
#[test]
fn i8f24_product_facts_hold_on_samples() {
    let mut v: Vec<i32> =
        vec![0, 1, -1, i32::MIN, i32::MAX, i32::MIN + 1, i32::MAX - 1, 1 << 24, -(1 << 24), (1 << 24) - 1];
    v.extend([-(1 << 24) + 1, 1 << 23, 46_341 << 12, -(46_341 << 12)]);
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    for _ in 0..3000 {
        v.push(xorshift(&mut seed) as i32);
        v.push((xorshift(&mut seed) % (1 << 26)) as i32 - (1 << 25));
    }
    let one = I8F24::ONE;
    let mut pairs: Vec<(i32, i32)> = v.iter().take(14).flat_map(|&x| v.iter().take(14).map(move |&y| (x, y))).collect();
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    for _ in 0..400_000 {
        let i = (xorshift(&mut seed) % v.len() as u64) as usize;
        let j = (xorshift(&mut seed) % v.len() as u64) as usize;
        pairs.push((v[i], v[j]));
    }
    for (x, y) in pairs {
        let (x, y) = (I8F24::from_bits(x), I8F24::from_bits(y));
        let p = x.saturating_mul(y);
        for (a, b) in [(x, y), (y, x)] {
            assert!(implies(b.saturating_abs() <= one, p.saturating_abs() <= a.saturating_abs()), "|{a} * {b}| = {p}");
        }
        let (sx, sy) = (x.saturating_mul(x), y.saturating_mul(y));
        assert!(sx >= I8F24::ZERO);
        assert!(implies(x.saturating_abs() <= y.saturating_abs(), sx <= sy), "{x}^2 = {sx} > {y}^2 = {sy}");
    }
}

/// How each kind of fact is established, per variant (see the module
/// documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum How {
    Z3,
    /// z3 on the integer transcription of the bit-vector terms.
    Z3Integers,
    Exhaustive,
}

fn how(sort: Sort, kind: LemmaKind) -> How {
    match (sort, kind) {
        (_, LemmaKind::SquareMonotone) | (Sort::Bv32, LemmaKind::SquareSign) => How::Exhaustive,
        (Sort::F32, LemmaKind::SquareSign | LemmaKind::SquareInfinite | LemmaKind::SquareZero) => How::Z3,
        (Sort::F32, _) => How::Z3,
        (Sort::Bv32, LemmaKind::FactorAtMostOne) => How::Z3Integers,
        _ => panic!("{sort:?} {kind:?}: no way to establish it"),
    }
}

/// The lemmas for the products `x y`, `x x`, `y y` of fresh inputs (every
/// kind the function writes: per product, per square, per pair of
/// squares), with the nodes they name.
fn instantiated<S: Sym>(sort: Sort) -> (Vec<ctx::Lemma>, Vec<u32>) {
    let (x, y) = (S::var("x"), S::var("y"));
    let (p, sx, sy) = (x.times(y), x.times(x), y.times(y));
    let products = [(p.id(), x.id(), y.id(), sort), (sx.id(), x.id(), x.id(), sort), (sy.id(), y.id(), y.id(), sort)];
    (ctx::product_lemmas(&products), vec![p.id(), sx.id(), sy.id()])
}

#[test]
#[ignore = "needs z3 (the lemmas are written over its terms): proofs/smt/run.sh"]
fn every_lemma_kind_is_established() {
    let mut seen = BTreeSet::new();
    for sort in [Sort::F32, Sort::Bv32] {
        let lemmas = ctx::session(|| match sort {
            Sort::F32 => instantiated::<SymF32>(sort).0,
            _ => instantiated::<SymFx>(sort).0,
        });
        assert!(!lemmas.is_empty());
        for l in lemmas {
            assert_eq!(l.sort, sort);
            seen.insert((format!("{sort:?}"), format!("{:?}", l.kind), how(sort, l.kind)));
        }
    }
    for (sort, kind, how) in &seen {
        println!("{sort} {kind}: {how:?}");
    }
    // Every (variant, kind) the function writes: 5 for f32 (+ monotone), 3 for I8F24.
    assert_eq!(seen.len(), 7 + 3, "{seen:?}");
}

/// Every `f32` lemma that z3 establishes, proved by z3 on the real
/// products (the negation of each instance unsatisfiable).
#[test]
#[ignore = "needs z3: proofs/smt/run.sh"]
fn f32_product_lemmas_are_proved_by_z3() {
    let t0 = Instant::now();
    let (proved, kinds) = ctx::session(|| {
        let (lemmas, roots) = instantiated::<SymF32>(Sort::F32);
        let mut kinds = BTreeSet::new();
        let mut proved = 0;
        // One instance per kind: on fresh inputs an instance is the
        // schema (the others differ only by renaming or by `x == y`).
        let mut done = BTreeSet::new();
        for l in lemmas.iter().filter(|l| how(l.sort, l.kind) == How::Z3 && done.insert(format!("{:?}", l.kind))) {
            let t = Instant::now();
            let r = ctx::refute(&roots, &l.text, smt::z3::property_timeout_ms());
            assert_eq!(r, smt::z3::Sat::Unsat, "{:?} not proved: {}", l.kind, l.text);
            println!("lemma {:?} (f32): proved in {:.1} s", l.kind, t.elapsed().as_secs_f64());
            kinds.insert(format!("{:?}", l.kind));
            proved += 1;
        }
        (proved, kinds)
    });
    assert_eq!((proved, kinds.len()), (6, 6), "{kinds:?}");
    println!("product lemmas: {proved} f32 kinds proved by z3 in {:.1} s", t0.elapsed().as_secs_f64());
}

/// Runs `check(lo, hi)` on the halves of `0..=last` on two threads.
fn split(last: u32, check: impl Fn(u32, u32) + Sync) {
    let mid = last / 2;
    std::thread::scope(|s| {
        s.spawn(|| check(0, mid));
        check(mid + 1, last);
    });
}

/// `f32`, every input: the square of `x` is the square of `|x|` bit for
/// bit, NaN iff `x` is, else `>= +0`, infinite for an infinite `x`, zero
/// for a zero; and the square is non-decreasing over the non-negative
/// values `+0 ..= +inf` in bit order (their numeric order). Hence every
/// square fact of `ctx::product_lemmas`, monotonicity included.
#[test]
#[ignore = "2^32 inputs: proofs/smt/run.sh runs it in release"]
fn f32_square_lemmas_hold_on_every_input() {
    let t0 = Instant::now();
    split(u32::MAX, |lo, hi| {
        for b in lo..=hi {
            let x = f32::from_bits(b);
            let s = x * x;
            if x.is_nan() {
                assert!(s.is_nan(), "{b:#x}");
                continue;
            }
            assert!(!s.is_nan() && s >= 0.0, "{b:#x}");
            assert_eq!(s.to_bits(), (x.abs() * x.abs()).to_bits(), "{b:#x}");
            assert!(!x.is_infinite() || s.is_infinite(), "{b:#x}");
            assert!(x != 0.0 || s == 0.0, "{b:#x}");
        }
    });
    let top = f32::INFINITY.to_bits();
    split(top - 1, |lo, hi| {
        for b in lo..=hi {
            let (x, y) = (f32::from_bits(b), f32::from_bits(b + 1));
            assert!(x < y, "{b:#x}: bit order is numeric order");
            assert!(x * x <= y * y, "{b:#x}: {x}^2 > {y}^2");
        }
    });
    println!(
        "f32 square lemmas: every one of 2^32 inputs, {} monotone steps, exhaustive in {:.1} s",
        top,
        t0.elapsed().as_secs_f64()
    );
}

/// `I8F24`, every input: the square of `x` is the square of
/// `saturating_abs(x)` and `>= 0`; the square is non-decreasing over
/// `0 ..= MAX`. Hence both square facts of `ctx::product_lemmas`.
#[test]
#[ignore = "2^32 inputs: proofs/smt/run.sh runs it in release"]
fn i8f24_square_lemmas_hold_on_every_input() {
    let t0 = Instant::now();
    let sq = |b: i32| {
        let x = I8F24::from_bits(b);
        x.saturating_mul(x)
    };
    split(u32::MAX, |lo, hi| {
        for u in lo..=hi {
            let b = u as i32;
            let s = sq(b);
            assert!(s >= I8F24::ZERO, "{b:#x}");
            assert_eq!(s, sq(I8F24::from_bits(b).saturating_abs().to_bits()), "{b:#x}");
        }
    });
    split(i32::MAX as u32 - 1, |lo, hi| {
        for u in lo..=hi {
            let b = u as i32;
            assert!(sq(b) <= sq(b + 1), "{b:#x}");
        }
    });
    println!(
        "I8F24 square lemmas: every one of 2^32 inputs, {} monotone steps, exhaustive in {:.1} s",
        i32::MAX,
        t0.elapsed().as_secs_f64()
    );
}

/// The `I8F24` product as `SymFx::times` builds it, over the integers.
/// The bit-vector term is `(let ((q (bvashr (bvmul (sign_extend a)
/// (sign_extend b)) 24))) (ite (and (bvsle q MAX) (bvsge q MIN)) (extract
/// q) (ite (xor (bvslt a 0) (bvslt b 0)) MIN MAX)))` on 32-bit words; each
/// word is an integer in `[MIN, MAX]` (its signed value), and operator for
/// operator: `sign_extend` keeps the signed value; `bvmul` of two 64-bit
/// words is their product modulo 2^64, which is the integer product when
/// that lies in the signed 64-bit range (`nowrap`, proved below for every
/// pair of words); `bvashr` by 24 is the floor of the quotient by 2^24
/// (SMT-LIB `div` by a positive divisor is the floor); the range test and
/// the saturation are the same comparisons; `extract` of a value in the
/// 32-bit range is that value. `sabs` is `ctx::product_lemmas`' `abs`
/// (`saturating_abs`) likewise.
const INT_PRODUCT: &str = "\
(define-fun MIN () Int (- 2147483648)) \
(define-fun MAX () Int 2147483647) \
(define-fun word ((v Int)) Bool (and (<= MIN v) (<= v MAX))) \
(define-fun nowrap ((a Int) (b Int)) Bool \
  (and (<= (- 9223372036854775808) (* a b)) (<= (* a b) 9223372036854775807))) \
(define-fun mul ((a Int) (b Int)) Int \
  (let ((q (div (* a b) 16777216))) \
    (ite (and (<= q MAX) (>= q MIN)) q (ite (xor (< a 0) (< b 0)) MIN MAX)))) \
(define-fun sabs ((v Int)) Int (ite (= v MIN) MAX (ite (< v 0) (- v) v)))";

/// [`INT_PRODUCT`]'s `mul`, in Rust (i128: exact), operator for operator;
/// z3 evaluates `mul` on samples and must agree with it.
fn int_mul(a: i32, b: i32) -> i32 {
    let q = (i128::from(a) * i128::from(b)).div_euclid(1 << 24);
    match i32::try_from(q) {
        Ok(q) => q,
        Err(_) if (a < 0) != (b < 0) => i32::MIN,
        Err(_) => i32::MAX,
    }
}

/// An SMT-LIB integer as z3 prints it (`5`, `(- 5)`).
fn smt_int(text: &str) -> i128 {
    let t = text.trim();
    match t.strip_prefix("(-").and_then(|r| r.strip_suffix(')')) {
        Some(n) => -n.trim().parse::<i128>().unwrap_or_else(|e| panic!("{t}: {e}")),
        None => t.parse().unwrap_or_else(|e| panic!("{t}: {e}")),
    }
}

/// An SMT-LIB integer literal (a negative one as `(- n)`).
fn lit(v: i32) -> String {
    if v < 0 {
        format!("(- {})", -i64::from(v))
    } else {
        v.to_string()
    }
}

/// 48 boundary words: zero, +-1 LSB, the ends, +-1.0 and its neighbours,
/// +-0.5, the saturation threshold of a product with 1.0, powers of two.
fn boundary_words() -> Vec<i32> {
    let one = 1i32 << 24;
    let mut v = vec![0, 1, -1, i32::MIN, i32::MIN + 1, i32::MAX, i32::MAX - 1, one, -one, one - 1, -one + 1];
    v.extend([one + 1, -one - 1, one / 2, -one / 2, 46_341 << 12, -(46_341 << 12), 3, -3, 0x00ff_ffff, -0x00ff_ffff]);
    for k in [4, 8, 12, 16, 20, 23, 25, 28, 30] {
        v.extend([1 << k, -(1 << k), (1 << k) - 1]);
    }
    v
}

/// `I8F24`, a factor in `[-1, 1]` does not grow the other: proved by z3
/// over the integers ([`INT_PRODUCT`]), for every pair of 32-bit words;
/// with it, that the transcription is exact (no 64-bit wrap), that the
/// premises are satisfiable, that the fact fails for a factor 1 LSB above
/// 1.0 (z3's counterexample replayed on the kernel's multiply), and that
/// z3's evaluation of `mul` equals [`int_mul`] on samples.
#[test]
#[ignore = "needs z3: proofs/smt/run.sh"]
fn i8f24_factor_lemma_is_proved_by_z3_over_the_integers() {
    use kernel::Scalar;
    let t0 = Instant::now();
    let mut z = smt::z3::Z3::start();
    let timeout = smt::z3::property_timeout_ms();
    let premises = |bound: u32| format!("(assert (word x)) (assert (word y)) (assert (<= (sabs y) {bound}))");
    let mut check = |goal: &str| {
        z.reset();
        z.send(INT_PRODUCT);
        z.send("(declare-const x Int) (declare-const y Int)");
        z.send(goal);
        let r = z.check(timeout, false, false);
        (r, if r == smt::z3::Sat::Sat { z.values(&["x".to_string(), "y".to_string()]) } else { Vec::new() })
    };
    // The 64-bit product of two words never wraps.
    let (r, _) = check("(assert (word x)) (assert (word y)) (assert (not (nowrap x y)))");
    assert_eq!(r, smt::z3::Sat::Unsat, "the integer transcription is not exact");
    // The fact, with `y` the factor in [-1, 1] (the other way round is the
    // same formula with the names swapped: `mul` is symmetric).
    let one = 1u32 << 24;
    let (r, _) = check(&format!("{} (assert (not (<= (sabs (mul x y)) (sabs x))))", premises(one)));
    assert_eq!(r, smt::z3::Sat::Unsat, "the factor lemma is not proved");
    let (r, _) = check(&premises(one));
    assert_eq!(r, smt::z3::Sat::Sat, "vacuous: no input satisfies the premises");
    // A factor 1 LSB above 1.0 can grow the other: z3 finds it, and the
    // kernel's multiply really does.
    let (r, xy) = check(&format!("{} (assert (not (<= (sabs (mul x y)) (sabs x))))", premises(one + 1)));
    assert_eq!(r, smt::z3::Sat::Sat, "a factor above 1.0 should be refuted");
    let (x, y) = (smt_int(&xy[0]), smt_int(&xy[1]));
    let (x, y) = (I8F24::from_bits(x as i32), I8F24::from_bits(y as i32));
    let p = Scalar::times(x, y);
    assert!(y.saturating_abs().to_bits() as u32 == one + 1, "{y}");
    assert!(p.saturating_abs() > x.saturating_abs(), "z3's counterexample {x} * {y} = {p} does not replay");
    println!("I8F24 factor lemma, refuted for a factor of 1.0 + 1 LSB: {x} * {y} = {p}");
    // z3's `mul` is `int_mul`.
    let words = boundary_words();
    let mut pairs: Vec<(i32, i32)> = words.iter().flat_map(|&a| words.iter().map(move |&b| (a, b))).collect();
    let mut seed = 0x6a09_e667_f3bc_c909u64;
    for _ in 0..2000 {
        let a = xorshift(&mut seed) as i32;
        let b = (xorshift(&mut seed) % (2 * u64::from(one) + 1)) as i64 - i64::from(one);
        pairs.push((a, b as i32));
        pairs.push((a, xorshift(&mut seed) as i32));
    }
    z.reset();
    z.send(INT_PRODUCT);
    let terms: Vec<String> = pairs.iter().map(|&(a, b)| format!("(mul {} {})", lit(a), lit(b))).collect();
    for ((a, b), got) in pairs.iter().zip(z.simplify_many(&terms)) {
        assert_eq!(smt_int(&got), i128::from(int_mul(*a, *b)), "mul {a} {b}");
    }
    println!(
        "I8F24 factor lemma: proved by z3 over the integers ({} checks, z3's mul = int_mul on {} pairs) in {:.1} s",
        z.checks,
        pairs.len(),
        t0.elapsed().as_secs_f64()
    );
}

/// The integer transcription is the kernel's multiply (`Scalar::times` for
/// `I8F24`) and `fixed`'s `saturating_mul` (which `SymFx::times` is read
/// from): on every word times +-1.0 and +-(1.0 - 1 LSB) (the factor's ends
/// and their neighbours: 2^34 products), every factor in `[-1, 1]` (2^25 + 1
/// words) times each boundary word, and 4,000,000 random pairs.
#[test]
#[ignore = "2^34 products: proofs/smt/run.sh runs it in release"]
fn i8f24_integer_product_is_the_kernels_multiply() {
    use kernel::Scalar;
    let t0 = Instant::now();
    let same = |a: i32, b: i32| {
        let (x, y) = (I8F24::from_bits(a), I8F24::from_bits(b));
        let want = int_mul(a, b);
        assert_eq!(Scalar::times(x, y).to_bits(), want, "{a} * {b}");
        assert_eq!(x.saturating_mul(y).to_bits(), want, "{a} * {b} (fixed)");
    };
    let one = 1i32 << 24;
    split(u32::MAX, |lo, hi| {
        for u in lo..=hi {
            let a = std::hint::black_box(u) as i32;
            for b in [one, -one, one - 1, -one + 1] {
                same(a, b);
            }
        }
    });
    let words = boundary_words();
    split(2 * one as u32, |lo, hi| {
        for u in lo..=hi {
            let b = u as i32 - one;
            for &a in &words {
                same(a, b);
            }
        }
    });
    let mut seed = 0xbb67_ae85_84ca_a73bu64;
    for _ in 0..2_000_000 {
        let a = xorshift(&mut seed) as i32;
        let b = (xorshift(&mut seed) % (2 * one as u64 + 1)) as i64 - i64::from(one);
        same(a, b as i32);
        same(a, xorshift(&mut seed) as i32);
    }
    println!(
        "I8F24 integer product = the kernel's multiply: every word times +-1.0 and +-(1.0 - 1 LSB), \
         every factor in [-1, 1] times {} boundary words, 4,000,000 random pairs, in {:.1} s",
        words.len(),
        t0.elapsed().as_secs_f64()
    );
}
