//! The symbolic scalars compute what `f32` and `I8F24` compute, bit for
//! bit: every operation of their `Scalar` impls is evaluated by z3 on
//! concrete inputs (ground terms, simplified to a value) and compared with
//! the concrete implementation on the same inputs. Inputs: boundary values
//! (signed zeros, subnormals, the largest finite values, infinities, NaNs,
//! `MIN`/`MAX` and their neighbours, the kernel's constants, products at
//! the saturation threshold) in every pair, plus seeded random ones.
//! Sampled: the binary operations (2^64 inputs) and the operations with an
//! integer operand (`times_int`, `div_int`). Exhaustive: `neg`, `abs` and
//! `is_finite` of `f32` and `neg`, `abs` of `I8F24`, on every one of the
//! 2^32 inputs (the last two tests). The counts are printed.
//!
//! These need the `z3` binary, so `cargo test` skips them; `proofs/smt/run.sh`
//! runs them (`--include-ignored`).

use fixed::types::I8F24;
use kernel::Scalar;
use smt::ctx::{self, f32_literal, name, Sort};
use smt::sym::{Sym, SymF32, SymFx};

/// Random draws per binary operation (on top of every boundary pair).
const RANDOM_PAIRS: usize = 6_000;
/// Random draws per unary operation.
const RANDOM_SINGLES: usize = 6_000;

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn u32(&mut self) -> u32 {
        (self.next() >> 32) as u32
    }
}

/// Checks collected as Boolean terms that must simplify to `true`.
#[derive(Default)]
struct Batch {
    ids: Vec<u32>,
    labels: Vec<String>,
}

impl Batch {
    fn push(&mut self, text: String, label: impl FnOnce() -> String) {
        self.ids.push(ctx::term(Sort::Bool, text));
        self.labels.push(label());
    }
    fn f32(&mut self, got: SymF32, want: f32, label: impl FnOnce() -> String) {
        let t = if want.is_nan() {
            format!("(fp.isNaN {})", name(got.0))
        } else {
            format!("(= {} {})", name(got.0), f32_literal(want))
        };
        self.push(t, || format!("{} = {want:?} ({:#010x})", label(), want.to_bits()));
    }
    fn fx(&mut self, got: SymFx, want: I8F24, label: impl FnOnce() -> String) {
        let t = format!("(= {} {})", name(got.0), ctx::bv32_literal(want.to_bits() as u32));
        self.push(t, || format!("{} = {want} ({:#010x})", label(), want.to_bits()));
    }
    fn bool(&mut self, got: smt::sym::B, want: bool, label: impl FnOnce() -> String) {
        let t = if want { name(got.0) } else { format!("(not {})", name(got.0)) };
        self.push(t, || format!("{} = {want}", label()));
    }
    /// Evaluates everything; returns the number of checks.
    fn run(self) -> usize {
        let n = self.ids.len();
        let mut bad = Vec::new();
        for (ids, labels) in self.ids.chunks(4000).zip(self.labels.chunks(4000)) {
            let out = ctx::simplify_many(ids);
            for (o, l) in out.iter().zip(labels) {
                if o != "true" {
                    bad.push(format!("{l}: z3 says {o}"));
                }
            }
        }
        assert!(bad.is_empty(), "{} of {n} mismatches, first: {:#?}", bad.len(), &bad[..bad.len().min(20)]);
        n
    }
}

fn f32_specials() -> Vec<f32> {
    let mut v = vec![
        0.0,
        1.0,
        0.5,
        2.0,
        3.0,
        6.0,
        16.0,
        32.0,
        64.0,
        0.001,
        0.03,
        0.06,
        4.0e-6,
        0.1,
        5.0,
        1e-5,
        f32::MIN_POSITIVE,
        f32::from_bits(1),
        f32::from_bits(0x007f_ffff),
        f32::MAX,
        f32::from_bits(0x7f7f_fffe),
        f32::INFINITY,
        16_777_216.0,
        16_777_217.0,
        1.0 + f32::EPSILON,
        1.0 - f32::EPSILON / 2.0,
        1.5e38,
        3.4e38,
    ];
    let negs: Vec<f32> = v.iter().map(|x| -x).collect();
    v.extend(negs);
    v.extend([f32::NAN, -f32::NAN, f32::from_bits(0x7f80_0001), f32::from_bits(0xffc0_1234)]);
    v
}

fn random_f32(r: &mut Rng) -> f32 {
    match r.next() % 3 {
        // any bit pattern
        0 => f32::from_bits(r.u32()),
        // moderate magnitudes (the kernel's range)
        1 => f32::from_bits((r.u32() & 0x807f_ffff) | ((0x70 + (r.u32() % 0x18)) << 23)),
        // tiny and subnormal
        _ => f32::from_bits((r.u32() & 0x80ff_ffff) & !0x7f00_0000),
    }
}

fn fx_specials() -> Vec<I8F24> {
    let mut bits: Vec<i32> = vec![
        0,
        1,
        2,
        0x0080_0000,
        0x0100_0000,
        0x00ff_ffff,
        0x0100_0001,
        0x0b50_4f33,
        0x0b50_4f34,
        0x0b50_4f32,
        0x1000_0000,
        0x4000_0000,
        0x7fff_ffff,
        0x7fff_fffe,
        0x0000_0100,
        0x0000_ffff,
        0x0001_0000,
        0x0300_0000,
        0x0600_0000,
        0x07ae_147b,
    ];
    let negs: Vec<i32> = bits.iter().map(|b| b.wrapping_neg()).collect();
    bits.extend(negs);
    bits.extend([i32::MIN, i32::MIN + 1]);
    bits.sort_unstable();
    bits.dedup();
    bits.into_iter().map(I8F24::from_bits).collect()
}

fn random_fx(r: &mut Rng) -> I8F24 {
    let b = r.u32() as i32;
    I8F24::from_bits(match r.next() % 3 {
        0 => b,
        1 => b >> 4,  // within +-8
        _ => b >> 20, // a few LSB
    })
}

/// Integers the kernel passes to `times_int` / `div_int`, and extremes.
const INTS: [i32; 12] = [0, 1, -1, 2, 3, 7, 1000, -1000, 128, 256, i32::MAX, i32::MIN];

fn f32_ops(b: &mut Batch, x: f32, y: f32) {
    let (sx, sy) = (SymF32::constant(x), SymF32::constant(y));
    let l = |op: &'static str| move || format!("{op}({x:?} [{:#010x}], {y:?} [{:#010x}])", x.to_bits(), y.to_bits());
    b.f32(sx.plus(sy), x.plus(y), l("plus"));
    b.f32(sx.minus(sy), x.minus(y), l("minus"));
    b.f32(sx.times(sy), x.times(y), l("times"));
    b.bool(sx.t_lt(sy), x < y, l("lt"));
    b.bool(sx.t_le(sy), x <= y, l("le"));
    b.bool(sx.t_gt(sy), x > y, l("gt"));
    b.bool(sx.t_ge(sy), x >= y, l("ge"));
    b.bool(sx.t_eq(sy), x == y, l("eq"));
    let zeros = x == 0.0 && y == 0.0 && x.to_bits() != y.to_bits();
    if !zeros {
        b.f32(Scalar::min(sx, sy), Scalar::min(x, y), l("min"));
        b.f32(Scalar::max(sx, sy), Scalar::max(x, y), l("max"));
    }
}

fn f32_unary(b: &mut Batch, x: f32) {
    let sx = SymF32::constant(x);
    let l = |op: String| move || format!("{op}({x:?} [{:#010x}])", x.to_bits());
    b.f32(Scalar::neg(sx), Scalar::neg(x), l("neg".into()));
    b.f32(Scalar::abs(sx), Scalar::abs(x), l("abs".into()));
    b.bool(sx.t_finite(), Scalar::is_finite(x), l("is_finite".into()));
    b.f32(SymF32::from_f32(x), <f32 as Scalar>::from_f32(x), l("from_f32".into()));
    for n in INTS {
        b.f32(sx.times_int(n), x.times_int(n), l(format!("times_int[{n}]")));
        b.f32(sx.div_int(n), x.div_int(n), l(format!("div_int[{n}]")));
    }
}

fn fx_ops(b: &mut Batch, x: I8F24, y: I8F24) {
    let (sx, sy) = (SymFx::constant(x), SymFx::constant(y));
    let l = |op: &'static str| move || format!("{op}({x} [{:#010x}], {y} [{:#010x}])", x.to_bits(), y.to_bits());
    b.fx(sx.plus(sy), Scalar::plus(x, y), l("plus"));
    b.fx(sx.minus(sy), Scalar::minus(x, y), l("minus"));
    b.fx(sx.times(sy), Scalar::times(x, y), l("times"));
    b.fx(Scalar::min(sx, sy), Scalar::min(x, y), l("min"));
    b.fx(Scalar::max(sx, sy), Scalar::max(x, y), l("max"));
    b.bool(sx.t_lt(sy), x < y, l("lt"));
    b.bool(sx.t_le(sy), x <= y, l("le"));
    b.bool(sx.t_gt(sy), x > y, l("gt"));
    b.bool(sx.t_ge(sy), x >= y, l("ge"));
    b.bool(sx.t_eq(sy), x == y, l("eq"));
}

fn fx_unary(b: &mut Batch, x: I8F24) {
    let sx = SymFx::constant(x);
    let l = |op: String| move || format!("{op}({x} [{:#010x}])", x.to_bits());
    b.fx(Scalar::neg(sx), Scalar::neg(x), l("neg".into()));
    b.fx(Scalar::abs(sx), Scalar::abs(x), l("abs".into()));
    for n in INTS {
        b.fx(sx.times_int(n), x.times_int(n), l(format!("times_int[{n}]")));
        b.fx(sx.div_int(n), x.div_int(n), l(format!("div_int[{n}]")));
    }
}

#[test]
#[ignore = "needs the z3 binary: proofs/smt/run.sh runs it"]
fn f32_operations_match_bit_for_bit() {
    ctx::session(|| {
        let mut r = Rng(0x9e37_79b9_7f4a_7c15);
        let sp = f32_specials();
        let mut b = Batch::default();
        for &x in &sp {
            for &y in &sp {
                f32_ops(&mut b, x, y);
            }
            f32_unary(&mut b, x);
        }
        for _ in 0..RANDOM_PAIRS {
            let (x, y) = (random_f32(&mut r), random_f32(&mut r));
            f32_ops(&mut b, x, y);
            // a neighbour: rounding ties and cancellation
            let z = f32::from_bits(x.to_bits() ^ (r.u32() & 0xff));
            f32_ops(&mut b, x, z);
        }
        for _ in 0..RANDOM_SINGLES {
            f32_unary(&mut b, random_f32(&mut r));
        }
        let n = b.run();
        println!(
            "f32: {n} checks ({} boundary values, every pair; {} random pairs and neighbours, {RANDOM_SINGLES} random singles)",
            sp.len(),
            RANDOM_PAIRS
        );
    });
}

/// `f32::min`/`max` of `+0.0` and `-0.0`: Rust may return either, so the
/// model allows exactly those two, and Rust's answer here is one of them.
#[test]
#[ignore = "needs the z3 binary: proofs/smt/run.sh runs it"]
fn f32_min_max_of_signed_zeros_allow_exactly_either() {
    ctx::session(|| {
        let (p, n) = (0.0f32, -0.0f32);
        for (x, y) in [(p, n), (n, p)] {
            for (op, got, rust) in [
                ("min", Scalar::min(SymF32::constant(x), SymF32::constant(y)), Scalar::min(x, y)),
                ("max", Scalar::max(SymF32::constant(x), SymF32::constant(y)), Scalar::max(x, y)),
            ] {
                assert!(rust == 0.0, "{op}({x:?}, {y:?}) = {rust:?}");
                let is = |z: f32| ctx::term(Sort::Bool, format!("(= {} {})", name(got.0), f32_literal(z)));
                assert!(ctx::satisfiable(&[is(p)]), "{op}({x:?}, {y:?}) cannot be +0");
                assert!(ctx::satisfiable(&[is(n)]), "{op}({x:?}, {y:?}) cannot be -0");
                let other = ctx::term(Sort::Bool, format!("(not (or {} {}))", name(is(p)), name(is(n))));
                assert!(!ctx::satisfiable(&[other]), "{op}({x:?}, {y:?}) can be something else");
            }
        }
    });
}

#[test]
#[ignore = "needs the z3 binary: proofs/smt/run.sh runs it"]
fn fixed_operations_match_bit_for_bit() {
    ctx::session(|| {
        let mut r = Rng(0x2545_f491_4f6c_dd1d);
        let sp = fx_specials();
        let mut b = Batch::default();
        for &x in &sp {
            for &y in &sp {
                fx_ops(&mut b, x, y);
            }
            fx_unary(&mut b, x);
        }
        for _ in 0..RANDOM_PAIRS {
            let (x, y) = (random_fx(&mut r), random_fx(&mut r));
            fx_ops(&mut b, x, y);
            // a product at the saturation threshold: |x y| / 2^24 near 2^31
            let xb = i64::from(x.to_bits());
            if xb != 0 {
                let t = (1i64 << 55) / xb + i64::from(r.u32() % 3) - 1;
                let t = t.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32;
                fx_ops(&mut b, x, I8F24::from_bits(t));
                fx_ops(&mut b, x, I8F24::from_bits(t.wrapping_neg()));
            }
        }
        for _ in 0..RANDOM_SINGLES {
            let x = random_fx(&mut r);
            fx_unary(&mut b, x);
            // at the saturation threshold of times_int(1000)
            fx_unary(&mut b, I8F24::from_bits(i32::MAX / 1000 + (r.u32() % 3) as i32 - 1));
        }
        for x in f32_specials() {
            b.fx(SymFx::from_f32(x), <I8F24 as Scalar>::from_f32(x), || format!("from_f32({x:?})"));
        }
        b.fx(SymFx::ZERO, I8F24::ZERO, || "ZERO".into());
        b.fx(SymFx::ONE, I8F24::ONE, || "ONE".into());
        let n = b.run();
        println!(
            "I8F24: {n} checks ({} boundary values, every pair; {RANDOM_PAIRS} random pairs with threshold products, {RANDOM_SINGLES} x 2 random singles)",
            sp.len()
        );
    });
}

/// The `bool`s the trait returns are decided on the same terms: the
/// comparisons and `is_finite`, called as trait methods (one z3 round trip
/// per decision) on every pair of a smaller boundary set, agree with the
/// concrete types. (The terms they decide are checked on every sample
/// above.)
#[test]
#[ignore = "needs the z3 binary: proofs/smt/run.sh runs it"]
fn trait_comparisons_decide_like_the_concrete_types() {
    ctx::session(|| {
        let mut n = 0;
        let sp = [
            0.0f32,
            -0.0,
            1.0,
            -1.0,
            0.5,
            f32::from_bits(1),
            -f32::MAX,
            f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        let fx: Vec<I8F24> =
            [0, 1, -1, 0x0100_0000, -0x0100_0000, i32::MAX, i32::MIN, i32::MIN + 1].map(I8F24::from_bits).to_vec();
        ctx::evaluate(|| {
            for &x in &sp {
                let sx = SymF32::constant(x);
                assert_eq!(Scalar::is_finite(sx), x.is_finite(), "is_finite({x:?})");
                for &y in &sp {
                    let sy = SymF32::constant(y);
                    let got = [sx < sy, sx <= sy, sx > sy, sx >= sy, sx == sy, sx != sy];
                    let want = [x < y, x <= y, x > y, x >= y, x == y, x != y];
                    assert_eq!(got, want, "{x:?} vs {y:?}");
                    assert_eq!(sx.partial_cmp(&sy), x.partial_cmp(&y), "{x:?} vs {y:?}");
                    n += 7;
                }
            }
            for &x in &fx {
                let sx = SymFx::constant(x);
                for &y in &fx {
                    let sy = SymFx::constant(y);
                    let got = [sx < sy, sx <= sy, sx > sy, sx >= sy, sx == sy, sx != sy];
                    let want = [x < y, x <= y, x > y, x >= y, x == y, x != y];
                    assert_eq!(got, want, "{x} vs {y}");
                    assert_eq!(sx.partial_cmp(&sy), x.partial_cmp(&y), "{x} vs {y}");
                    n += 7;
                }
            }
        });
        println!("trait comparisons: {n} decisions on boundary pairs");
    });
}

/// Runs `check` on every 32-bit pattern, split over two threads.
fn every_pattern(check: impl Fn(u32) + Sync) {
    std::thread::scope(|s| {
        s.spawn(|| (0..=u32::MAX / 2).for_each(&check));
        (u32::MAX / 2 + 1..=u32::MAX).for_each(&check);
    });
}

/// Exhaustive where the domain allows: the unary `f32` operations without a
/// constant operand (`neg`, `abs`, `is_finite`) on every one of the 2^32
/// bit patterns. z3 proves each symbolic operation equal to a bit-level
/// formula over the pattern (`neg` flips the sign bit, `abs` clears it,
/// `is_finite` is "exponent not all ones"; NaN as SMT's one NaN), for every
/// pattern at once; the kernel's `Scalar` impl for `f32` is compared with
/// the same formula on every pattern (NaN results: is NaN).
#[test]
#[ignore = "needs the z3 binary and 2^32 iterations: proofs/smt/run.sh runs it in release"]
fn f32_unary_operations_match_on_every_pattern() {
    let t0 = std::time::Instant::now();
    ctx::session(|| {
        let bits = ctx::var(Sort::Bv32, "bits");
        let x = SymF32(ctx::term(Sort::F32, format!("((_ to_fp 8 24) {})", name(bits))));
        let of_bits = |f: &str| format!("((_ to_fp 8 24) {f})");
        let b = name(bits);
        let cases = [
            (x.neg().0, format!("(= {} {})", name(x.neg().0), of_bits(&format!("(bvxor {b} #x80000000)")))),
            (x.abs().0, format!("(= {} {})", name(x.abs().0), of_bits(&format!("(bvand {b} #x7fffffff)")))),
            (x.t_finite().0, format!("(= {} (not (= ((_ extract 30 23) {b}) #xff)))", name(x.t_finite().0))),
        ];
        for (id, formula) in &cases {
            let r = ctx::refute(&[*id], formula, smt::z3::property_timeout_ms());
            assert_eq!(r, smt::z3::Sat::Unsat, "not proved for every pattern: {formula}");
        }
    });
    every_pattern(|b| {
        let x = f32::from_bits(std::hint::black_box(b));
        let same = |got: f32, want: u32| {
            let w = f32::from_bits(want);
            if w.is_nan() {
                got.is_nan()
            } else {
                got.to_bits() == want
            }
        };
        assert!(same(Scalar::neg(x), b ^ 0x8000_0000), "neg {b:#010x}");
        assert!(same(Scalar::abs(x), b & 0x7fff_ffff), "abs {b:#010x}");
        assert_eq!(Scalar::is_finite(x), (b >> 23) & 0xff != 0xff, "is_finite {b:#010x}");
    });
    println!(
        "f32: neg, abs, is_finite on every one of 2^32 patterns (z3: 3 formulas for all patterns), exhaustive in {:.1} s",
        t0.elapsed().as_secs_f64()
    );
}

/// Exhaustive: the `I8F24` `neg` and `abs` on every one of the 2^32 words.
/// Their symbolic terms are bit-vector formulas (`SymFx::neg`: `(ite (= a
/// MIN) MAX (bvneg a))`; `abs` also `bvslt a 0`); each is written here
/// operator for operator in Rust's wrapping integer operations (z3 checks
/// that transcription on the boundary and random words in
/// `fixed_operations_match_bit_for_bit`) and compared with the kernel's
/// `Scalar` impl for `I8F24` on every word.
#[test]
#[ignore = "2^32 iterations: proofs/smt/run.sh runs it in release"]
fn fixed_unary_operations_match_on_every_word() {
    let t0 = std::time::Instant::now();
    every_pattern(|u| {
        // Opaque to the optimiser: every word is really computed.
        let a = std::hint::black_box(u) as i32;
        let neg = if a == i32::MIN { i32::MAX } else { a.wrapping_neg() };
        let abs = if a == i32::MIN {
            i32::MAX
        } else if a < 0 {
            a.wrapping_neg()
        } else {
            a
        };
        let x = I8F24::from_bits(a);
        assert_eq!(Scalar::neg(x).to_bits(), neg, "neg {u:#010x}");
        assert_eq!(Scalar::abs(x).to_bits(), abs, "abs {u:#010x}");
    });
    println!("I8F24: neg, abs on every one of 2^32 words, exhaustive in {:.1} s", t0.elapsed().as_secs_f64());
}
