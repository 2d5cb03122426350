//! Fixed-point decimal text of `f64`s, byte for byte as `core::fmt`'s
//! `{:.N}` writes it, without its exact (big-number) float formatting where
//! the answer is unambiguous. The scenario runs format hundreds of thousands
//! of numbers (the hosts' motion frames, the plots): `core::fmt` was a large
//! share of the simulator's time.

use std::fmt::Write as _;

const POW10: [f64; 5] = [1.0, 10.0, 100.0, 1000.0, 10000.0];
const POW10_U: [u64; 5] = [1, 10, 100, 1000, 10000];

/// Appends `v` as `format!("{v:.N}")` with `N = decimals` (at most 4) does.
///
/// `|v| * 10^N` is rounded to the nearest integer where that is
/// unambiguous: `|v| < 1e6`, so the computed product is within 1.2e-6 of the
/// exact one, and its fraction is not within 1e-4 of one half (where the
/// exact value could lie on the other side of the tie, or `core::fmt`'s
/// tie rule decides). Anything else (near a tie, non-finite, large, more
/// decimals) is written by `core::fmt`. The sign is written for every
/// negative value, `-0.0` and values that round to zero included, as
/// `core::fmt` (and C's `printf`) do.
pub fn push_fixed(s: &mut String, v: f64, decimals: usize) {
    let a = v.abs();
    if let (true, Some(&scale), Some(&unit)) = (a < 1e6, POW10.get(decimals), POW10_U.get(decimals)) {
        let scaled = a * scale;
        // (Signed conversions: one instruction each way on x86-64; the
        // value is below 1e10.)
        let i = scaled as i64;
        let frac = scaled - i as f64; // exact: an integer part below 2^53
        if (frac - 0.5).abs() > 1e-4 {
            let n = (if frac > 0.5 { i + 1 } else { i }) as u64;
            // Sign, up to 7 integer digits, the point, up to 4 decimals.
            let mut buf = [0u8; 16];
            let mut k = buf.len();
            let (mut int, mut fr) = (n / unit, n % unit);
            for _ in 0..decimals {
                k -= 1;
                buf[k] = b'0' + (fr % 10) as u8;
                fr /= 10;
            }
            if decimals > 0 {
                k -= 1;
                buf[k] = b'.';
            }
            loop {
                k -= 1;
                buf[k] = b'0' + (int % 10) as u8;
                int /= 10;
                if int == 0 {
                    break;
                }
            }
            if v.is_sign_negative() {
                k -= 1;
                buf[k] = b'-';
            }
            // (Byte by byte: a call to copy a few bytes costs more.)
            s.extend(buf[k..].iter().map(|b| char::from(*b)));
            return;
        }
    }
    let _ = write!(s, "{v:.decimals$}");
}

/// Appends `n` in decimal, as `format!("{n}")` does.
pub fn push_u32(s: &mut String, mut n: u32) {
    let mut buf = [0u8; 10];
    let mut k = buf.len();
    loop {
        k -= 1;
        buf[k] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    s.extend(buf[k..].iter().map(|b| char::from(*b)));
}

#[cfg(test)]
mod tests {
    use super::{push_fixed, push_u32};
    use crate::rng::Rng;

    fn same(v: f64, d: usize) {
        let mut s = String::new();
        push_fixed(&mut s, v, d);
        assert_eq!(s, format!("{v:.d$}"), "{v:e} ({:#x}), {d} decimals", v.to_bits());
    }

    #[test]
    fn push_fixed_formats_as_core_fmt() {
        let fixed = [
            0.0,
            -0.0,
            0.05,
            -0.05,
            0.25,
            -0.25,
            0.35,
            0.45,
            0.95,
            -0.95,
            0.04,
            -0.04,
            0.0005,
            -0.0005,
            0.00005,
            -0.00004,
            1.0005,
            2.5,
            1e-300,
            -1e-300,
            9.95,
            99.95,
            1099.95,
            123456.75,
            999_999.999_95,
            1e6,
            -1e6,
            1e7 + 0.05,
            1e300,
            f64::MAX,
            f64::MIN_POSITIVE,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.049999999,
            0.050000001,
        ];
        for d in 0..=5 {
            for v in fixed {
                same(v, d);
            }
        }
        let mut r = Rng::new(7);
        for k in 0..600_000u64 {
            let u = r.uniform();
            let d = (k % 5) as usize;
            let v = match (k / 5) % 4 {
                0 => (u - 0.5) * 20.0,
                // Exact ties at d decimals and their neighbours.
                1 => {
                    let unit = 10f64.powi(d as i32);
                    let t = (((u * 2e5) as i64 - 100_000) as f64 + 0.5) / unit;
                    f64::from_bits(t.to_bits().wrapping_add((k / 20) % 5).wrapping_sub(2))
                }
                2 => (u - 0.5) * 2e6,
                _ => f64::from_bits(r.next_u64()),
            };
            same(v, d);
        }
    }

    #[test]
    fn push_u32_formats_as_core_fmt() {
        for n in [0, 1, 9, 10, 99, 100, 1532, 65535, 4_000_000_000, u32::MAX] {
            let mut s = String::new();
            push_u32(&mut s, n);
            assert_eq!(s, n.to_string());
        }
    }
}
