//! The numeric core: one trait, two implementations (`f32` and [`Fx`]).
//!
//! Every arithmetic operation the kernel performs goes through [`Scalar`], so
//! the same source is instantiated for IEEE `f32` and for fixed point. The
//! operations are total: they never panic, never wrap silently (fixed point
//! saturates), and the kernel checks [`Scalar::is_finite`] wherever an `f32`
//! NaN or infinity could appear.
//!
//! The methods are deliberately named `plus`, `minus`, `times` rather than
//! using `core::ops`: the `fixed` crate's operators panic on overflow in debug
//! builds and wrap in release builds, and neither is acceptable here.
//!
//! # Fixed-point format: [`Fx`] = `I8F24`
//!
//! A signed 32-bit word with 8 integer and 24 fractional bits:
//! range [-128, 128), resolution 2^-24 = 5.96e-8.
//!
//! *Range* (docs/spec/robot.md section 1): the widest joint range is J6, -6.283..6.283
//! rad; before homing the observer's angle is relative to the power-on reading
//! and a homing seek can travel the whole range, so joint angles stay within
//! about +-13 rad. Velocities are at most 6 rad/s (runaway threshold 7.5
//! rad/s), gains at most Kp = 5 /s, observer gains <= 1. Everything the kernel
//! stores fits with an order of magnitude of headroom; intermediate products
//! that could exceed the range (Kp times a huge error) saturate and are then
//! caught by the velocity clamp and the plausibility checks. Quantities that
//! do not fit (step rates up to ~110 000 steps/s, encoder counts) never live
//! in `Fx`: they pass through [`Scalar::from_counts`] and
//! [`Scalar::to_rate`], which use a 64-bit intermediate and a
//! high-precision scale ([`Scalar::Wide`]).
//!
//! *Resolution*: one encoder count is 2 pi / 4096 / gear, at least 7.7e-5 rad
//! of joint angle (J2, gear 20), i.e. ~1300 LSB. The observer integrates
//! `v * dt` every millisecond: a velocity of 1e-4 rad/s still moves the
//! estimate by 1.7 LSB per tick, so slow motion is not lost to truncation
//! (I16F16 would lose everything under 0.015 rad/s). Command text has 3 or 4
//! decimals (1e-3 / 1e-4 rad), far above the resolution.
//!
//! # Branch-free core
//! `min`, `max`, `select` and the saturating operations compile to
//! conditional-select instructions on both the host and the Cortex-M7; the
//! per-axis numeric code uses them instead of `if` so its execution time does
//! not depend on the data.

use core::num::NonZeroU32;
use fixed::types::I8F24;

/// The fixed-point variant's number type. See the module docs for the choice.
pub type Fx = I8F24;

/// The scalar operations the kernel needs. Implemented for `f32` and [`Fx`].
pub trait Scalar: Copy + PartialEq + PartialOrd + core::fmt::Debug + Send + Sync + 'static {
    /// Additive identity.
    const ZERO: Self;
    /// Multiplicative identity.
    const ONE: Self;
    /// A high-precision multiplier used to convert between this type and
    /// integers (encoder counts, step rates) that may not fit in `Self`.
    type Wide: Copy + PartialEq + core::fmt::Debug + Send + Sync + 'static;

    /// Converts a configuration constant. Saturates; NaN becomes zero.
    /// Used at initialisation, never in the tick.
    fn from_f32(x: f32) -> Self;
    /// Lossy conversion for reporting and plotting.
    fn to_f32(self) -> f32;
    /// A configuration constant as a [`Self::Wide`] scale. Initialisation only.
    fn wide_from_f64(x: f64) -> Self::Wide;

    /// Saturating addition.
    fn plus(self, rhs: Self) -> Self;
    /// Saturating subtraction.
    fn minus(self, rhs: Self) -> Self;
    /// Saturating multiplication.
    fn times(self, rhs: Self) -> Self;
    /// Saturating multiplication by an integer.
    fn times_int(self, n: i32) -> Self;
    /// `self / n` for `n >= 1`, correctly rounded for `f32`, truncated for
    /// fixed point; `n < 1` gives zero. Used once per accepted target, not
    /// per tick.
    fn div_int(self, n: i32) -> Self;
    /// Saturating negation.
    fn neg(self) -> Self;
    /// Saturating absolute value.
    fn abs(self) -> Self;
    /// Minimum. For `f32` a NaN operand is ignored (IEEE minNum): callers
    /// that must reject NaN check [`Self::is_finite`] first.
    fn min(self, rhs: Self) -> Self;
    /// Maximum; see [`Self::min`] about NaN.
    fn max(self, rhs: Self) -> Self;
    /// False for NaN and infinities; always true for fixed point.
    fn is_finite(self) -> bool;

    /// `n * k` where `n` is an integer that may not fit in `Self` (encoder
    /// counts). Saturating.
    fn from_counts(n: i32, k: Self::Wide) -> Self;
    /// `self * k` rounded toward zero to an integer (step rates). Saturating;
    /// NaN gives 0.
    fn to_rate(self, k: Self::Wide) -> i32;
    /// `round(self * scale)` with ties away from zero, saturating to `i64`;
    /// NaN gives 0. Used to print exact decimals (scale = 10^decimals).
    fn to_scaled_int(self, scale: i64) -> i64;
    /// Parses plain decimal text (`-?digits(.digits)?`) with correct rounding
    /// to the nearest representable value, without going through another
    /// floating type. The caller validates the syntax; anything else that
    /// `core` would accept (exponents, `inf`, `nan`) must already be
    /// rejected. Returns `None` if the text does not parse or the value does
    /// not fit.
    fn parse_decimal(text: &str) -> Option<Self>;
    /// `mantissa / 10^decimals`, negated if `negative`: exactly what
    /// [`Self::parse_decimal`] returns for that number written out (a `-` if
    /// `negative`, then the mantissa's digits, zero-padded to at least
    /// `decimals + 1` digits, with a point before the last `decimals`; see
    /// [`decimal_text`]). `decimals` at most [`MAX_DECIMALS`]; more gives
    /// `None`.
    ///
    /// The protocol's numbers have a fixed count of decimals (3 or 4): the
    /// parser gathers their digits into an integer and converts it here. The
    /// default writes the text and calls `parse_decimal`; `f32` and [`Fx`]
    /// compute the same value with integer arithmetic (`f32`: one exactly
    /// rounded division for mantissas up to 2^24, integer rounding above;
    /// `Fx` with decimals up to 5), checked against `parse_decimal` for every
    /// mantissa the protocol's fields can carry, and sampled for every `u32`
    /// (`protocol/tests/decimal_exhaustive.rs`).
    fn from_decimal(negative: bool, mantissa: u32, decimals: u32) -> Option<Self> {
        let mut buf = [0u8; DECIMAL_TEXT_CAP];
        Self::parse_decimal(decimal_text(&mut buf, negative, mantissa, decimals)?)
    }

    /// `if c { a } else { b }`, written so the compiler can use a
    /// conditional select.
    #[inline(always)]
    fn select(c: bool, a: Self, b: Self) -> Self {
        if c {
            a
        } else {
            b
        }
    }

    /// Saturates `self` to `[-limit, limit]` (`limit >= 0`). A non-finite
    /// input gives zero (never `limit`: `f32::min` would turn NaN into the
    /// limit, and `clamp` would pass NaN through).
    #[inline(always)]
    fn saturate(self, limit: Self) -> Self {
        let s = self.min(limit).max(limit.neg());
        Self::select(self.is_finite(), s, Self::ZERO)
    }

    /// Clamps `self` into the closed interval spanned by `a` and `b`, in
    /// either order.
    #[inline(always)]
    fn clamp_between(self, a: Self, b: Self) -> Self {
        let lo = a.min(b);
        let hi = a.max(b);
        self.max(lo).min(hi)
    }
}

/// Largest `decimals` [`Scalar::from_decimal`] accepts (`10^9` fits a `u32`).
pub const MAX_DECIMALS: u32 = 9;

/// Bytes [`decimal_text`] needs: a sign, ten digits, a point.
pub const DECIMAL_TEXT_CAP: usize = 12;

/// Writes `mantissa / 10^decimals` (negated if `negative`) as plain decimal
/// text into the end of `buf` and returns it: `-` if `negative`, the
/// mantissa's digits zero-padded to at least `decimals + 1` digits, a point
/// before the last `decimals` digits (none if `decimals` is 0). E.g.
/// `(true, 5, 3)` gives `-0.005`, `(false, 1234, 4)` gives `0.1234`, `(true,
/// 0, 3)` gives `-0.000`. `None` if `decimals > MAX_DECIMALS`.
pub fn decimal_text(buf: &mut [u8; DECIMAL_TEXT_CAP], negative: bool, mantissa: u32, decimals: u32) -> Option<&str> {
    if decimals > MAX_DECIMALS {
        return None;
    }
    let mut m = mantissa;
    let mut i = buf.len();
    let mut written = 0u32;
    // Digits from the least significant: at most ten for a u32, plus the
    // zero padding up to decimals + 1 <= 10 digits.
    loop {
        i = i.checked_sub(1)?;
        // `m % 10 < 10`: the `|` cannot carry into the `'0'` bits.
        *buf.get_mut(i)? = b'0' | (m % 10) as u8;
        m /= 10;
        written = written.saturating_add(1);
        if written == decimals {
            i = i.checked_sub(1)?;
            *buf.get_mut(i)? = b'.';
        }
        if m == 0 && written > decimals {
            break;
        }
    }
    if negative {
        i = i.checked_sub(1)?;
        *buf.get_mut(i)? = b'-';
    }
    core::str::from_utf8(buf.get(i..)?).ok()
}

/// `10^k` as `f32` for `k = 0..=10`: every one is exact (`10^k = 2^k 5^k`
/// and `5^10 < 2^24`).
const POW10_F32: [f32; 11] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10];

impl Scalar for f32 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    type Wide = f32;

    fn from_f32(x: f32) -> Self {
        if x.is_nan() {
            0.0
        } else {
            x
        }
    }
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self
    }
    fn wide_from_f64(x: f64) -> f32 {
        x as f32
    }
    #[inline(always)]
    fn plus(self, rhs: Self) -> Self {
        self + rhs
    }
    #[inline(always)]
    fn minus(self, rhs: Self) -> Self {
        self - rhs
    }
    #[inline(always)]
    fn times(self, rhs: Self) -> Self {
        self * rhs
    }
    #[inline(always)]
    fn times_int(self, n: i32) -> Self {
        self * n as f32
    }
    #[inline(always)]
    fn div_int(self, n: i32) -> Self {
        if n >= 1 {
            self / n as f32
        } else {
            0.0
        }
    }
    #[inline(always)]
    fn neg(self) -> Self {
        -self
    }
    #[inline(always)]
    fn abs(self) -> Self {
        // Clearing the sign bit: exact, branch-free, and NaN stays NaN.
        f32::from_bits(self.to_bits() & 0x7fff_ffff)
    }
    // IEEE minNum / maxNum written out as a compare and a select, not
    // `f32::min`/`max`: on the shipped FPv4-SP build those are calls to
    // compiler-builtins' `fminf`/`fmaxf` (about 20 instructions each, 14 per
    // axis in the interpolator), and Rust leaves the sign of `min(+0.0,
    // -0.0)` unspecified, so host and target could differ there. This form
    // is the same on every target: a NaN operand is ignored (minNum), and of
    // two equal operands (+0.0 and -0.0 included) `self` is returned.
    #[inline(always)]
    fn min(self, rhs: Self) -> Self {
        if rhs < self || self.is_nan() {
            rhs
        } else {
            self
        }
    }
    #[inline(always)]
    fn max(self, rhs: Self) -> Self {
        if rhs > self || self.is_nan() {
            rhs
        } else {
            self
        }
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
    #[inline(always)]
    fn from_counts(n: i32, k: f32) -> Self {
        // Counts stay far below 2^24 in this robot (|n| < 2^19), so the
        // conversion is exact and only the product rounds.
        n as f32 * k
    }
    #[inline(always)]
    fn to_rate(self, k: f32) -> i32 {
        // `as` saturates and maps NaN to 0.
        (self * k) as i32
    }
    fn to_scaled_int(self, scale: i64) -> i64 {
        // f64 holds every f32 exactly and the product of an f32 with a small
        // power of ten is exact in f64 to far more digits than printed.
        let x = f64::from(self) * scale as f64;
        // Round half away from zero without `f64::round` (std only).
        let r = if x >= 0.0 { x + 0.5 } else { x - 0.5 };
        r as i64
    }
    fn parse_decimal(text: &str) -> Option<Self> {
        // core's float parser is correctly rounded (Eisel-Lemire with a
        // big-decimal fallback), straight from the decimal text to f32.
        let v: f32 = text.parse().ok()?;
        if v.is_finite() {
            Some(v)
        } else {
            None
        }
    }
    #[inline]
    fn from_decimal(negative: bool, mantissa: u32, decimals: u32) -> Option<Self> {
        // Exact method: for `mantissa <= 2^24` both `mantissa as f32` and
        // `10^decimals` (decimals <= 10) are exact f32 values, so the one
        // IEEE division below is the only rounding: the quotient is
        // `m / 10^k` correctly rounded to nearest (ties to even), which is
        // what core's parser returns for the text. No f64, no double
        // rounding. Negation is exact and keeps `-0.000` as -0.0, as the
        // text parser does. The protocol's accepted values are far below
        // the bound (|v| < 7 rad, mantissa < 70_000); a larger mantissa
        // (a value beyond every joint limit, still to be reported exactly as
        // before) is rounded with integer arithmetic by `f32_quotient`.
        match POW10_F32.get(decimals as usize) {
            Some(&p) if mantissa <= 1 << 24 && decimals <= MAX_DECIMALS => {
                let v = mantissa as f32 / p;
                Some(if negative { -v } else { v })
            }
            _ => f32_from_large_decimal(negative, mantissa, decimals),
        }
    }
}

/// `10^k` for `k = 0..=MAX_DECIMALS`.
const POW10_U64: [u64; MAX_DECIMALS as usize + 1] =
    [1, 10, 100, 1_000, 10_000, 100_000, 1_000_000, 10_000_000, 100_000_000, 1_000_000_000];

/// [`Scalar::from_decimal`] for `f32` off its division path (out of line:
/// no accepted frame takes it).
#[inline(never)]
fn f32_from_large_decimal(negative: bool, mantissa: u32, decimals: u32) -> Option<f32> {
    if decimals > MAX_DECIMALS {
        return None;
    }
    let v = f32_quotient(mantissa, decimals);
    Some(if negative { -v } else { v })
}

/// `m / 10^k` correctly rounded to the nearest `f32` (ties to even), with
/// integer arithmetic only, for `m > 0` and `k <= MAX_DECIMALS` (else 0).
///
/// `n = m 2^(31+z)` (`z` = leading zeros of `m`) is `m` normalised to
/// `2^62 <= n < 2^63`; `q = n div 10^k` has at least 33 significant bits
/// and `r = n mod 10^k` is what lies below them. The exact value is
/// `(q + r / 10^k) 2^-(31+z)`: keeping `q`'s top 24 bits and rounding on the
/// bits dropped (a half exactly only if they are `100..0` and `r` is 0)
/// gives a significand `s <= 2^24`, exact in `f32`, and `s 2^e` with
/// `-53 <= e <= 8` is a normal `f32`, so the product below is exact too.
fn f32_quotient(m: u32, k: u32) -> f32 {
    let (Some(&p), false) = (POW10_U64.get(k as usize), m == 0) else {
        return 0.0;
    };
    let z = m.leading_zeros(); // 0..=31 (m > 0)
    let n = u64::from(m).wrapping_shl(z.wrapping_add(31)); // 2^62 <= n < 2^63
    let (Some(q), Some(r)) = (n.checked_div(p), n.checked_rem(p)) else {
        return 0.0;
    };
    // q >= 2^62 / 10^9 > 2^32: 33 to 63 significant bits, of which `shift`
    // (9..=39) are dropped.
    let shift = 40u32.wrapping_sub(q.leading_zeros());
    let kept = q.wrapping_shr(shift);
    let dropped = q & 1u64.wrapping_shl(shift).wrapping_sub(1);
    let half = 1u64.wrapping_shl(shift.wrapping_sub(1));
    let up = dropped > half || (dropped == half && (r != 0 || kept & 1 == 1));
    // At most 2^24: exact in f32.
    let significand = kept.wrapping_add(u64::from(up)) as f32;
    // 2^e with e = shift - 31 - z in -53..=8, from its bits (biased
    // exponent 127 + e in 74..=135).
    let biased = 96u32.wrapping_add(shift).wrapping_sub(z);
    significand * f32::from_bits(biased.wrapping_shl(23))
}

/// Fractional bits of [`Fx`].
const FX_FRAC: u32 = 24;
/// Extra fractional bits of [`Fx`]'s wide scale (Q(24+24) in an `i64`).
const WIDE_EXTRA: u32 = 24;

/// Per decimal count k = 0..=5: (10^k, C, D, E) with E = 5^k,
/// C = 2^(24-k) div E, D = 2^(24-k) mod E, so that
/// r 2^24 / 10^k = r C + r D / E ([`Fx`]'s `from_decimal`).
const FX_DECIMAL: [(NonZeroU32, u32, u32, NonZeroU32); 6] = [
    (nz(1), 1 << 24, 0, nz(1)),
    (nz(10), 1_677_721, 3, nz(5)),
    (nz(100), 167_772, 4, nz(25)),
    (nz(1_000), 16_777, 27, nz(125)),
    (nz(10_000), 1_677, 451, nz(625)),
    (nz(100_000), 167, 2_413, nz(3_125)),
];

/// A nonzero constant (a zero would become 1 and fail the table's check
/// below at compile time).
const fn nz(x: u32) -> NonZeroU32 {
    match NonZeroU32::new(x) {
        Some(n) => n,
        None => NonZeroU32::MIN,
    }
}

// The table is what its comment says (checked at compile time).
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)]
const _: () = {
    let mut k = 0;
    while k < FX_DECIMAL.len() {
        let (pow, c, d, e) = FX_DECIMAL[k];
        let two = 1u32 << (FX_FRAC - k as u32);
        assert!(pow.get() == 10u32.pow(k as u32) && e.get() == 5u32.pow(k as u32));
        assert!(c == two / e.get() && d == two % e.get());
        k += 1;
    }
};

// The fixed-point tick's arithmetic, written with 32 x 32 -> 64-bit
// multiplies (one `smull`/`umull` each on the Cortex-M7) instead of what
// `fixed` and i128 compile to there (a 64 x 64-bit multiply with overflow
// detection for `saturating_mul`, `__multi3` and i128 shifts for the counts
// and rates: together about 900 of the fixed-point tick's 3400 instructions,
// docs/BENCHMARKS.md). Each returns exactly what the wide expression
// (i64 / i128, as `fixed` computes it) returns for every input; `tests::fx_fast_paths_equal_the_wide_reference`
// checks them against it.

/// `I8F24::saturating_mul` on the raw bits. `fixed` computes
/// `(a * (b << 8)) >> 32` in i64 and saturates when that product overflows;
/// with `p = a b` (exact in i64, |p| <= 2^62) the product is `p << 8`, which
/// overflows exactly when `p >> 24` is outside i32, and otherwise the result
/// is `p >> 24` (both floor). On overflow `p != 0`, so its sign is the
/// operands' sign rule `fixed` uses (different signs: MIN, else MAX).
#[inline(always)]
fn fx_mul_bits(a: i32, b: i32) -> i32 {
    let p = i64::from(a).wrapping_mul(i64::from(b)); // |p| <= 2^62: exact
                                                     // p >> 24 fits in i32 exactly when p's top 9 bits (63..55) are all equal,
                                                     // i.e. when the high word's bits 31..23 are: one compare of the high
                                                     // word instead of two 64-bit compares.
    let hi = (p >> 32) as i32;
    if hi >> 23 == hi >> 31 {
        (p >> FX_FRAC) as i32
    } else if p < 0 {
        i32::MIN
    } else {
        i32::MAX
    }
}

/// `|a| * |k|` as (high, low) parts: `high * 2^32 + low`, exact
/// (`|a| <= 2^31`, `|k| <= 2^63`, so high < 2^62 and low < 2^63).
#[inline(always)]
fn mag_product(a: u32, k: u64) -> (u64, u64) {
    let (kh, kl) = ((k >> 32) as u32, k as u32);
    (u64::from(a).wrapping_mul(u64::from(kh)), u64::from(a).wrapping_mul(u64::from(kl)))
}

/// `clamp(floor(n k / 2^24), i32)`, which the wide reference computes in
/// i128 (where the product, below 2^94, never saturates).
#[inline(always)]
fn fx_from_counts_bits(n: i32, k: i64) -> i32 {
    let (hi, lo) = mag_product(n.unsigned_abs(), k.unsigned_abs());
    let negative = (n < 0) != (k < 0);
    // m = hi 2^32 + lo; m >> 24 = hi 2^8 + lo >> 24 (hi 2^32 is a multiple of
    // 2^24, so the discarded bits are lo's low 24). At hi >= 2^40 the
    // quotient exceeds 2^48 and saturates whatever its sign.
    if hi >= 1 << 40 {
        return if negative { i32::MIN } else { i32::MAX };
    }
    let q = (hi << 8).wrapping_add(lo >> WIDE_EXTRA); // < 2^48 + 2^39: exact
    if negative {
        // floor(-m / 2^24) = -ceil(m / 2^24)
        let up = q.wrapping_add(u64::from(lo & ((1 << WIDE_EXTRA) - 1) != 0));
        if up > 1 << 31 {
            i32::MIN
        } else {
            (up as i64).wrapping_neg() as i32
        }
    } else if q > i32::MAX as u64 {
        i32::MAX
    } else {
        q as i32
    }
}

/// `bits * k` with 72 fractional bits dropped, truncated toward zero
/// (in i128 in the wide reference): `(hi 2^32 + lo) >> 72 = (hi + lo >> 32) >> 40`
/// (floor of a floor), and `hi + (lo >> 32) < 2^63` cannot overflow.
#[inline(always)]
fn fx_to_rate(bits: i32, k: i64) -> i32 {
    let (hi, lo) = mag_product(bits.unsigned_abs(), k.unsigned_abs());
    // The product is below 2^94, so `mag` is below 2^22 and fits an i32
    // (a saturation at i32::MAX could never apply).
    let mag = (hi.wrapping_add(lo >> 32) >> (FX_FRAC + FX_FRAC + WIDE_EXTRA - 32)) as i32;
    if (bits < 0) != (k < 0) {
        mag.wrapping_neg()
    } else {
        mag
    }
}

/// The wide scale of [`Fx`]: a signed value with 48 fractional bits (range
/// +-32768, checked for the step-rate scale by the configuration), so a
/// per-count scale such as 2 pi / 4096 / 18.0952 (8.5e-5) keeps ~7 significant
/// decimal digits more than `Fx` would give it (accumulated over 10^5 counts
/// the error stays under 1e-9 rad).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FxWide(pub i64);

impl Scalar for Fx {
    const ZERO: Self = Fx::ZERO;
    const ONE: Self = Fx::ONE;
    type Wide = FxWide;

    fn from_f32(x: f32) -> Self {
        if x.is_nan() {
            Fx::ZERO
        } else {
            Fx::saturating_from_num(x)
        }
    }
    fn to_f32(self) -> f32 {
        self.to_num::<f32>()
    }
    fn wide_from_f64(x: f64) -> FxWide {
        // Round to nearest; saturate (the `as` cast saturates and maps NaN to 0).
        let scaled = x * (1u64 << (FX_FRAC + WIDE_EXTRA)) as f64;
        let r = if scaled >= 0.0 { scaled + 0.5 } else { scaled - 0.5 };
        FxWide(r as i64)
    }
    #[inline(always)]
    fn plus(self, rhs: Self) -> Self {
        self.saturating_add(rhs)
    }
    #[inline(always)]
    fn minus(self, rhs: Self) -> Self {
        self.saturating_sub(rhs)
    }
    #[inline(always)]
    fn times(self, rhs: Self) -> Self {
        Fx::from_bits(fx_mul_bits(self.to_bits(), rhs.to_bits()))
    }
    #[inline(always)]
    fn times_int(self, n: i32) -> Self {
        self.saturating_mul_int(n)
    }
    #[inline(always)]
    fn div_int(self, n: i32) -> Self {
        if n >= 1 {
            self.checked_div_int(n).unwrap_or(Self::ZERO)
        } else {
            Self::ZERO
        }
    }
    #[inline(always)]
    fn neg(self) -> Self {
        self.saturating_neg()
    }
    #[inline(always)]
    fn abs(self) -> Self {
        // `I8F24::saturating_abs` on the bits (MIN gives MAX), which compiles
        // to fewer instructions than `fixed`'s.
        Fx::from_bits(self.to_bits().saturating_abs())
    }
    #[inline(always)]
    fn min(self, rhs: Self) -> Self {
        Ord::min(self, rhs)
    }
    #[inline(always)]
    fn max(self, rhs: Self) -> Self {
        Ord::max(self, rhs)
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        true
    }
    #[inline(always)]
    fn from_counts(n: i32, k: FxWide) -> Self {
        Fx::from_bits(fx_from_counts_bits(n, k.0))
    }
    #[inline(always)]
    fn to_rate(self, k: FxWide) -> i32 {
        fx_to_rate(self.to_bits(), k.0)
    }
    fn to_scaled_int(self, scale: i64) -> i64 {
        let p = i128::from(self.to_bits()).saturating_mul(i128::from(scale));
        let half = 1i128 << (FX_FRAC - 1);
        let mag = (p.unsigned_abs().saturating_add(half as u128)) >> FX_FRAC;
        let mag = mag.min(i64::MAX as u128) as i64;
        if p < 0 {
            mag.saturating_neg()
        } else {
            mag
        }
    }
    fn parse_decimal(text: &str) -> Option<Self> {
        // `fixed`'s parser converts decimal text straight to the nearest
        // representable value (ties to even) and reports overflow.
        text.parse::<Fx>().ok()
    }
    #[inline]
    fn from_decimal(negative: bool, mantissa: u32, decimals: u32) -> Option<Self> {
        // bits = round(m 2^24 / 10^k) with only 32-bit integer operations:
        // m = q 10^k + r (r < 10^k) splits it into q 2^24 plus
        // round(r 2^24 / 10^k) = round(r 2^(24-k) / 5^k)
        //                      = r C + round(r D / E),
        // with C = 2^(24-k) div 5^k, D = 2^(24-k) mod 5^k, E = 5^k (the table).
        // E is odd, so r D / E is never an exact half: no ties, rounding to
        // nearest is (r D + (E - 1) / 2) div E, and the ties-to-even rule of
        // `fixed`'s parser never applies. Bounds: r D < 10^5 3125 < 2^29,
        // r C < 2^24, q <= 128 (checked) so q 2^24 + frac <= 2^31 + 2^24.
        // Symmetric rounding, so the sign is applied to the magnitude:
        // -128 (-2^31) is the one magnitude that fits only when negative.
        let Some(&(pow, c, d, e)) = FX_DECIMAL.get(decimals as usize) else {
            let mut buf = [0u8; DECIMAL_TEXT_CAP];
            return Self::parse_decimal(decimal_text(&mut buf, negative, mantissa, decimals)?);
        };
        let q = mantissa / pow;
        let r = mantissa % pow;
        if q > 128 {
            return None;
        }
        let frac = r.wrapping_mul(c).wrapping_add(r.wrapping_mul(d).wrapping_add(e.get() / 2) / e);
        let mag = (q << FX_FRAC).wrapping_add(frac);
        // At most 2^31 - 1, or 2^31 when negative.
        if mag > 0x7fff_ffff_u32.wrapping_add(u32::from(negative)) {
            return None;
        }
        let bits = if negative { mag.wrapping_neg() } else { mag };
        Some(Fx::from_bits(bits as i32))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn saturate_maps_non_finite_to_zero() {
        for x in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -f32::NAN] {
            assert_eq!(x.saturate(3.0), 0.0, "{x}");
        }
        assert_eq!(10.0f32.saturate(3.0), 3.0);
        assert_eq!((-10.0f32).saturate(3.0), -3.0);
        assert_eq!(1.5f32.saturate(3.0), 1.5);
        let l = Fx::from_num(3);
        assert_eq!(Fx::MAX.saturate(l), l);
        assert_eq!(Fx::MIN.saturate(l), -l);
    }

    #[test]
    fn fixed_ops_saturate_instead_of_panicking() {
        assert_eq!(Fx::MAX.plus(Fx::ONE), Fx::MAX);
        assert_eq!(Fx::MIN.minus(Fx::ONE), Fx::MIN);
        assert_eq!(Scalar::neg(Fx::MIN), Fx::MAX);
        // `Fx` has an inherent, panicking `abs`: generic kernel code only sees
        // the trait's saturating one.
        assert_eq!(Scalar::abs(Fx::MIN), Fx::MAX);
        assert_eq!(Fx::MAX.times(Fx::MAX), Fx::MAX);
        assert_eq!(Fx::MAX.times_int(1000), Fx::MAX);
        assert_eq!(<Fx as Scalar>::ONE, Fx::ONE);
    }

    #[test]
    fn counts_conversion_is_precise_for_both() {
        let k = core::f64::consts::TAU / 4096.0 / 18.0952;
        let n = 200_000;
        let exact = n as f64 * k;
        let fx = Fx::from_counts(n, Fx::wide_from_f64(k));
        assert!((fx.to_num::<f64>() - exact).abs() < 1e-7, "{fx} vs {exact}");
        let f = f32::from_counts(n, f32::wide_from_f64(k));
        assert!((f64::from(f) - exact).abs() < 1e-5);
        assert_eq!(Fx::from_counts(i32::MAX, FxWide(i64::MAX)), Fx::MAX);
        assert_eq!(Fx::from_counts(i32::MIN, FxWide(i64::MAX)), Fx::MIN);
    }

    #[test]
    fn rate_conversion_truncates_toward_zero_and_saturates() {
        let spr = 18431.62;
        let v = Fx::from_num(6);
        let r = v.to_rate(Fx::wide_from_f64(spr));
        assert_eq!(r, 110_589);
        assert_eq!((-v).to_rate(Fx::wide_from_f64(spr)), -110_589);
        assert_eq!(6.0f32.to_rate(spr as f32), 110_589);
        assert_eq!(f32::NAN.to_rate(spr as f32), 0);
        assert_eq!(Fx::MAX.to_rate(Fx::wide_from_f64(30_000.0)), 3_839_999);
        assert_eq!(Fx::MIN.to_rate(Fx::wide_from_f64(30_000.0)), -3_840_000);
        // The largest product of the two ranges (128 x 32768) still fits in i32.
        assert_eq!(Fx::MAX.to_rate(FxWide(i64::MAX)), 4_194_303);
        assert_eq!(Fx::from_num(3).to_rate(Fx::wide_from_f64(-1000.5)), -3001);
    }

    #[test]
    fn scaled_int_rounds_half_away_from_zero() {
        assert_eq!(Fx::from_num(0.0005).to_scaled_int(1000), 1);
        assert_eq!(Fx::from_num(-1.2346).to_scaled_int(10_000), -12346);
        assert_eq!((-1.2346f32).to_scaled_int(10_000), -12346);
        assert_eq!(f32::NAN.to_scaled_int(1000), 0);
        assert_eq!(f32::INFINITY.to_scaled_int(1000), i64::MAX);
    }

    #[test]
    fn parse_decimal_is_correctly_rounded() {
        assert_eq!(f32::parse_decimal("0.123"), Some(0.123f32));
        assert_eq!(f32::parse_decimal("-2.7191"), Some(-2.7191f32));
        let fx = Fx::parse_decimal("0.001").unwrap();
        let ideal = 0.001 * (1u64 << 24) as f64; // 16777.216
        assert_eq!(fx.to_bits(), ideal.round() as i32);
        assert_eq!(Fx::parse_decimal("-0.000"), Some(Fx::ZERO));
        assert_eq!(Fx::parse_decimal("200.000"), None);
        assert_eq!(f32::parse_decimal("1e39"), None);
    }

    #[test]
    fn f32_min_max_are_min_num_max_num_with_self_on_ties() {
        let nan = f32::NAN;
        // A NaN operand is ignored; two NaNs give NaN.
        assert_eq!(Scalar::min(nan, 2.0f32), 2.0);
        assert_eq!(Scalar::min(2.0f32, nan), 2.0);
        assert_eq!(Scalar::max(nan, -2.0f32), -2.0);
        assert_eq!(Scalar::max(-2.0f32, nan), -2.0);
        assert!(Scalar::min(nan, nan).is_nan() && Scalar::max(nan, nan).is_nan());
        // Equal operands: `self`, so the sign of a zero is defined.
        assert_eq!(Scalar::min(0.0f32, -0.0).to_bits(), 0.0f32.to_bits());
        assert_eq!(Scalar::min(-0.0f32, 0.0).to_bits(), (-0.0f32).to_bits());
        assert_eq!(Scalar::max(0.0f32, -0.0).to_bits(), 0.0f32.to_bits());
        assert_eq!(Scalar::max(-0.0f32, 0.0).to_bits(), (-0.0f32).to_bits());
        // Otherwise the same as `f32::min`/`max` (a sampled sweep of bit
        // patterns, infinities and subnormals included).
        let mut x: u32 = 0x1234_5678;
        for _ in 0..100_000 {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            let (a, b) = (f32::from_bits(x), f32::from_bits(x.rotate_left(11)));
            if a == b {
                continue;
            }
            assert_eq!(Scalar::min(a, b).to_bits(), f32::min(a, b).to_bits(), "{a} {b}");
            assert_eq!(Scalar::max(a, b).to_bits(), f32::max(a, b).to_bits(), "{a} {b}");
        }
        for (a, b) in [(f32::INFINITY, 1.0f32), (f32::NEG_INFINITY, 1.0), (1e-45, -1e-45), (f32::MAX, f32::MIN)] {
            assert_eq!(Scalar::min(a, b), f32::min(a, b));
            assert_eq!(Scalar::max(b, a), f32::max(b, a));
        }
    }

    /// The former expressions, for `fx_fast_paths_equal_the_wide_reference`.
    fn ref_mul(a: i32, b: i32) -> i32 {
        Fx::from_bits(a).saturating_mul(Fx::from_bits(b)).to_bits()
    }
    fn ref_from_counts(n: i32, k: i64) -> i32 {
        let p = i128::from(n).saturating_mul(i128::from(k)) >> WIDE_EXTRA;
        p.max(i128::from(i32::MIN)).min(i128::from(i32::MAX)) as i32
    }
    fn ref_to_rate(bits: i32, k: i64) -> i32 {
        let p = i128::from(bits).saturating_mul(i128::from(k));
        let mag = p.unsigned_abs() >> (FX_FRAC + FX_FRAC + WIDE_EXTRA);
        let mag = mag.min(i32::MAX as u128) as i32;
        if p < 0 {
            mag.saturating_neg()
        } else {
            mag
        }
    }

    #[test]
    fn fx_fast_paths_equal_the_wide_reference() {
        // Edge operands (zero, one, the extremes, powers of two and their
        // neighbours, the shipped configuration's scales) in every pairing,
        // then 2 million pseudo-random pairs: sampled evidence; the
        // arguments are in the functions' comments.
        let mut e32: std::vec::Vec<i32> = std::vec![0, 1, -1, i32::MAX, i32::MIN, i32::MAX - 1, i32::MIN + 1];
        let mut e64: std::vec::Vec<i64> = std::vec![0, 1, -1, i64::MAX, i64::MIN, i64::MAX - 1, i64::MIN + 1];
        for s in 0..63 {
            for d in [-1i64, 0, 1] {
                let v = (1i64 << s) + d;
                e64.extend([v, -v]);
                if s < 31 {
                    e32.extend([v as i32, -(v as i32)]);
                }
            }
        }
        for j in crate::config::PAROL6.joints.iter() {
            for f in [j.rad_per_count(), j.steps_per_rad(), -j.steps_per_rad()] {
                e64.push(Fx::wide_from_f64(f).0);
            }
        }
        for &a in &e32 {
            for &b in &e32 {
                assert_eq!(fx_mul_bits(a, b), ref_mul(a, b), "mul {a} {b}");
            }
            for &w in &e64 {
                assert_eq!(fx_from_counts_bits(a, w), ref_from_counts(a, w), "counts {a} {w}");
                assert_eq!(fx_to_rate(a, w), ref_to_rate(a, w), "rate {a} {w}");
            }
        }
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        for i in 0..2_000_000u32 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            // Shrink some operands so every magnitude range is visited.
            let a = (x as i32) >> (i % 32);
            let b = ((x >> 32) as i32) >> ((i / 32) % 32);
            let w = (x.rotate_left(17) as i64) >> (i % 64);
            assert_eq!(fx_mul_bits(a, b), ref_mul(a, b), "mul {a} {b}");
            assert_eq!(fx_from_counts_bits(a, w), ref_from_counts(a, w), "counts {a} {w}");
            assert_eq!(fx_to_rate(a, w), ref_to_rate(a, w), "rate {a} {w}");
            let f = Fx::from_bits(a);
            assert_eq!(Scalar::abs(f), f.saturating_abs(), "abs {a}");
        }
        for &a in &e32 {
            let f = Fx::from_bits(a);
            assert_eq!(Scalar::abs(f), f.saturating_abs(), "abs {a}");
        }
    }

    /// `f32`'s `div_int` by a count below one is zero, and its
    /// `from_decimal` off the division path (a mantissa above 2^24) rounds
    /// as the text parser does; more decimals than allowed are refused. `kernel/tests/scalar.rs` checks both at
    /// length; they are here too because both functions are `#[inline]`,
    /// and LLVM's coverage does not count their copies inlined into another
    /// crate's tests.
    #[test]
    fn f32_div_int_below_one_and_a_decimal_beyond_the_division_path() {
        assert_eq!(Scalar::div_int(3.0f32, 0).to_bits(), 0);
        assert_eq!(Scalar::div_int(3.0f32, -1).to_bits(), 0);
        assert_eq!(<f32 as Scalar>::from_decimal(false, (1 << 24) + 1, 0), Some(16_777_216.0));
        assert_eq!(<f32 as Scalar>::from_decimal(true, 16_803_599, 7), "-1.6803599".parse::<f32>().ok());
        assert_eq!(<f32 as Scalar>::from_decimal(false, 12, MAX_DECIMALS + 1), None);
    }

    #[test]
    fn clamp_between_accepts_either_order() {
        assert_eq!(5.0f32.clamp_between(3.0, 1.0), 3.0);
        assert_eq!(0.0f32.clamp_between(3.0, 1.0), 1.0);
        assert_eq!(2.0f32.clamp_between(1.0, 3.0), 2.0);
    }
}
