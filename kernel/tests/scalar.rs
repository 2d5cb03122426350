//! The scalar operations the kernel's clamps rest on, at their edges.

/// `Scalar::min`/`max` on `f32` return the number when either operand is
/// NaN (IEEE minNum/maxNum), whichever side the NaN is on.
#[test]
fn f32_min_and_max_return_the_number_beside_a_nan_on_either_side() {
    use kernel::Scalar;
    assert_eq!(Scalar::max(f32::NAN, 1.0f32), 1.0);
    assert_eq!(Scalar::max(1.0f32, f32::NAN), 1.0);
    assert_eq!(Scalar::min(f32::NAN, 1.0f32), 1.0);
    assert_eq!(Scalar::min(1.0f32, f32::NAN), 1.0);
}

/// `from_f32` of a NaN is zero in both variants (`config::check` keeps NaN
/// out of every configuration value; the conversion never passes one on).
#[test]
fn from_f32_of_a_nan_is_zero_in_both_variants() {
    use kernel::{Fx, Scalar};
    for nan in [f32::NAN, -f32::NAN, f32::from_bits(0x7f80_0001)] {
        assert_eq!(<f32 as Scalar>::from_f32(nan).to_bits(), 0, "{nan}");
        assert_eq!(<Fx as Scalar>::from_f32(nan), Fx::ZERO, "{nan}");
    }
    assert_eq!(<f32 as Scalar>::from_f32(-2.5), -2.5);
    assert_eq!(<Fx as Scalar>::from_f32(-2.5), Fx::from_num(-2.5));
}

/// `div_int` by a count below one is zero in both variants (the kernel
/// divides only by segment lengths of at least one tick); by a count of at
/// least one it divides.
#[test]
fn div_int_by_a_count_below_one_is_zero_in_both_variants() {
    use kernel::{Fx, Scalar};
    for n in [0, -1, -2, i32::MIN] {
        assert_eq!(Scalar::div_int(3.0f32, n).to_bits(), 0, "3 / {n}");
        assert_eq!(Scalar::div_int(Fx::from_num(3), n), Fx::ZERO, "3 / {n}");
    }
    assert_eq!(Scalar::div_int(3.0f32, 2), 1.5);
    assert_eq!(Scalar::div_int(Fx::from_num(3), 2), Fx::from_num(1.5));
}

/// `f32`'s `from_decimal` off its division path (a mantissa above 2^24,
/// rounded with integer arithmetic) equals core's correctly rounded parser
/// of the same text, bit for bit, both signs, every number of decimals the
/// protocol allows; more decimals than that are refused (`None`), on both
/// paths. Catches: a rounding error in `f32_quotient` (ties to odd, a tie
/// read without the remainder), a sign lost, a decimal count not refused.
#[test]
fn f32_from_decimal_beyond_the_fast_path_equals_the_text_parser() {
    use kernel::Scalar;
    let max = kernel::scalar::MAX_DECIMALS;
    // Ties at 2^24 and 2^25 (to even, both ways), values just above a tie
    // (the remainder decides: 16_803_599 with 7 decimals, 16_783_721 with
    // 8, 16_778_850 with 9), the largest mantissas.
    let mantissas = [
        (1 << 24) + 1,
        (1 << 24) + 3,
        (1 << 25) + 2,
        (1 << 25) + 6,
        33_554_433,
        16_803_599,
        16_783_721,
        16_778_850,
        123_456_789,
        999_999_999,
        4_294_967_295,
    ];
    let mut n = 0;
    for m in mantissas {
        for k in 0..=max {
            for negative in [false, true] {
                let s = m.to_string();
                let text = if k == 0 {
                    s
                } else {
                    let s = format!("{:0>w$}", m, w = k as usize + 1);
                    let (int, frac) = s.split_at(s.len() - k as usize);
                    format!("{int}.{frac}")
                };
                let text = if negative { format!("-{text}") } else { text };
                let want: f32 = text.parse().expect("a decimal");
                let got = <f32 as Scalar>::from_decimal(negative, m, k).expect("within the decimals allowed");
                assert_eq!(got.to_bits(), want.to_bits(), "{text}: {got} vs {want}");
                n += 1;
            }
        }
        assert_eq!(<f32 as Scalar>::from_decimal(false, m, max + 1), None, "{m} with {} decimals", max + 1);
    }
    assert_eq!(<f32 as Scalar>::from_decimal(false, 12, max + 1), None, "a small mantissa with too many decimals");
    assert_eq!(n, mantissas.len() * (max as usize + 1) * 2);
}

/// The fixed-point wide constant (`FxWide`, 48 fraction bits: the per-count
/// and per-step factors derived at start-up) rounds to the nearest, halves
/// away from zero, on both sides of zero: exact halves, values just beside
/// them, and the PAROL6's own factors.
#[test]
fn fx_wide_from_f64_rounds_to_nearest_on_both_sides() {
    use kernel::scalar::FxWide;
    use kernel::{Fx, Scalar};
    let one = (1u64 << 48) as f64;
    let lsb = 1.0 / one;
    let mut xs = vec![0.0, 1.0, 0.5, 3.0e-4, 2.0 * std::f64::consts::PI / 16384.0, 1.0 / 3.0, 123.456];
    for k in [1.0f64, 3.0, 1023.0, 4.0e6] {
        xs.push((k + 0.5) * lsb);
        xs.push((k + 0.25) * lsb);
        xs.push((k + 0.75) * lsb);
    }
    for &x in &xs {
        for x in [x, -x] {
            let want = (x * one).round() as i64;
            assert_eq!(<Fx as Scalar>::wide_from_f64(x), FxWide(want), "{x:e}");
        }
    }
}
