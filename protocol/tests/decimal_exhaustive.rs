//! The integer decimal conversion (`Scalar::from_decimal`, used by the
//! parser) equals the text conversion
//! (`Scalar::parse_decimal`: core's correctly rounded float parser for
//! `f32`, `fixed`'s for `Fx`), bit for bit.
//!
//! Two levels, each exhaustive over its domain in the `#[ignore]`d tests
//! (run them in release, about a minute on one core:
//! `cargo test -p protocol --release --test decimal_exhaustive -- --ignored --nocapture`,
//! each prints its case count and time) and strided in the default run:
//!
//! - **conversion**: every mantissa `m` of `(-1)^s m / 10^k` for `k` = 3 and
//!   4 (the dialects) and both signs, `f32` for `m` in `0..=2^24 + 2^20` (the
//!   whole division path, `m <= 2^24`, and the start of the integer
//!   rounding above it), then every 127th `m` up to `u32::MAX`,
//!   `Fx` for `m` up to `129 * 10^k` (every value it can hold, and past its
//!   range) and for every `k` in 0..=5; other `k` and larger `m` sampled;
//! - **parser**: every value of every field of both dialects, both scalar
//!   types, from 0.1 (rad or rad/s) below the joint's lower limit to 0.1
//!   above its upper one at the dialect's resolution (a position field of
//!   J1 in the configurator dialect: every number -2.2000 .. 2.2000), each
//!   in a frame of zeros, parsed by the parser and by the pre-issue-14
//!   reference (`tests/reference`): same verdict and bit-identical values.

mod reference;

use kernel::config::{ArmConfig, PAROL6, PAROL6_VALIDATED};
use kernel::scalar::{decimal_text, DECIMAL_TEXT_CAP};
use kernel::Fx;
use protocol::{Dialect, DialectLock, Parser};
use reference::{same, Bits};
use std::time::Instant;

/// Compares `from_decimal` with `parse_decimal` of the text for every `m`
/// in `ms`, both signs; returns the number of cases.
fn conversion<S: Bits>(k: u32, ms: impl Iterator<Item = u32>) -> u64 {
    let mut buf = [0u8; DECIMAL_TEXT_CAP];
    let mut n = 0u64;
    for m in ms {
        for neg in [false, true] {
            let text = decimal_text(&mut buf, neg, m, k).expect("k <= 9");
            let want = S::parse_decimal(text).map(S::bits);
            let got = S::from_decimal(neg, m, k).map(S::bits);
            assert_eq!(got, want, "{text} (m = {m}, k = {k})");
            n += 2;
        }
    }
    n
}

/// A fixed sample of large mantissas (beyond the exhaustive ranges): an LCG
/// over all of u32, plus the edges.
fn large_sample(count: u32) -> impl Iterator<Item = u32> {
    let mut x = 0x2545_f491u32;
    let edges = [u32::MAX, u32::MAX - 1, (1 << 24) + 1, (1 << 25) - 1, 1 << 31, 999_999_999, 1_000_000_000];
    edges.into_iter().chain((0..count).map(move |_| {
        x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        x
    }))
}

fn conversion_all(stride: usize) -> u64 {
    let mut n = 0;
    for k in [3, 4] {
        n += conversion::<f32>(k, (0..=(1u32 << 24) + (1 << 20)).step_by(stride));
    }
    for k in (0..=9).filter(|k| *k != 3 && *k != 4) {
        n += conversion::<f32>(k, (0..=(1u32 << 24) + (1 << 20)).step_by(stride * 97));
    }
    // f32 above 2^24 (integer rounding, no division in f32): every 127th
    // mantissa up to u32::MAX for the dialects' decimals, every 1009th for
    // the others.
    for k in 0..=9 {
        let step = if k == 3 || k == 4 { 127 } else { 1009 };
        n += conversion::<f32>(k, ((1u32 << 24) + (1 << 20)..=u32::MAX).step_by(stride * step));
    }
    for k in 0..=5u32 {
        let top = 129 * 10u32.pow(k);
        n += conversion::<Fx>(k, (0..=top).step_by(stride));
    }
    for k in 0..=9 {
        n += conversion::<f32>(k, large_sample(20_000 / stride as u32));
        n += conversion::<Fx>(k, large_sample(20_000 / stride as u32));
    }
    n
}

#[test]
fn conversion_sampled() {
    conversion_all(997);
}

#[test]
#[ignore = "exhaustive: run in release (see the file's doc)"]
fn conversion_exhaustive() {
    let t = Instant::now();
    let n = conversion_all(1);
    println!("conversion: {n} cases equal, {:.1} s", t.elapsed().as_secs_f64());
}

/// `i / 10^k` as the dialect prints it (`-0.000` for `neg_zero`).
fn number(i: i64, k: usize, neg_zero: bool) -> String {
    let p = 10i64.pow(k as u32);
    let sign = if i < 0 || neg_zero { "-" } else { "" };
    let a = i.unsigned_abs();
    format!("{sign}{}.{:0k$}", a / p as u64, a % p as u64)
}

/// The range of field `f` (1..=12) of `dialect` in units of 10^-k, widened
/// by 0.1 on each side.
fn field_range(c: &ArmConfig, dialect: Dialect, f: usize) -> (i64, i64) {
    let scale = dialect.scale() as f64;
    let (axis, is_pos) = dialect
        .fields()
        .iter()
        .enumerate()
        .find_map(|(j, &(p, v))| {
            if p == f {
                Some((j, true))
            } else if v == f {
                Some((j, false))
            } else {
                None
            }
        })
        .expect("field 1..=12");
    let j = &c.joints[axis];
    let (lo, hi) = if is_pos {
        (j.limit_min as f64, j.limit_max as f64)
    } else {
        (-(j.max_velocity as f64), j.max_velocity as f64)
    };
    (((lo - 0.1) * scale).floor() as i64, ((hi + 0.1) * scale).ceil() as i64)
}

/// Every value of every field (strided), in a frame of zeros, through the
/// parser and the reference; returns (cases, accepted).
fn fields<S: Bits>(stride: usize) -> (u64, u64) {
    let (mut n, mut ok) = (0u64, 0u64);
    for lock in [DialectLock::Auto, DialectLock::DriverOnly] {
        let p: Parser<S> = Parser::new(&PAROL6_VALIDATED, lock);
        for dialect in [Dialect::Driver, Dialect::Configurator] {
            let k = dialect.decimals();
            let zero = number(0, k, false);
            for f in 1..=12 {
                let (lo, hi) = field_range(&PAROL6, dialect, f);
                let values = (lo..=hi).step_by(stride).map(|i| (i, false)).chain([(0, true), (lo, false), (hi, false)]);
                for (i, neg_zero) in values {
                    let mut line = String::from("<7");
                    for g in 1..=12 {
                        line.push(',');
                        line.push_str(&if g == f { number(i, k, neg_zero) } else { zero.clone() });
                    }
                    line.push('>');
                    let got = p.parse(line.as_bytes());
                    let want = reference::parse(&p, line.as_bytes());
                    assert!(same(&got, &want), "{line}: {got:?} vs {want:?}");
                    n += 1;
                    ok += u64::from(got.is_ok());
                }
            }
        }
    }
    (n, ok)
}

#[test]
fn fields_sampled() {
    let (n, ok) = fields::<f32>(89);
    assert!(ok > 0 && ok < n);
    fields::<Fx>(89);
}

#[test]
#[ignore = "exhaustive: run in release (see the file's doc)"]
fn fields_exhaustive() {
    let t = Instant::now();
    let (n32, ok32) = fields::<f32>(1);
    let (nfx, okfx) = fields::<Fx>(1);
    println!(
        "fields: f32 {n32} frames ({ok32} accepted), Fx {nfx} frames ({okfx} accepted), all equal to the reference, {:.1} s",
        t.elapsed().as_secs_f64()
    );
}

#[test]
fn decimal_text_writes_the_number() {
    let mut buf = [0u8; DECIMAL_TEXT_CAP];
    for (neg, m, k, want) in [
        (false, 0, 3, "0.000"),
        (true, 0, 3, "-0.000"),
        (true, 5, 3, "-0.005"),
        (false, 1234, 4, "0.1234"),
        (false, 12345, 4, "1.2345"),
        (false, 7, 0, "7"),
        (true, u32::MAX, 9, "-4.294967295"),
        (false, 1, 9, "0.000000001"),
        (false, u32::MAX, 0, "4294967295"),
    ] {
        assert_eq!(decimal_text(&mut buf, neg, m, k), Some(want));
    }
    assert_eq!(decimal_text(&mut buf, false, 1, 10), None);
    // Against std's formatting, sampled.
    for m in large_sample(5000) {
        for k in 0..=9u32 {
            let p = 10u64.pow(k);
            let want = if k == 0 {
                format!("-{m}")
            } else {
                format!("-{}.{:0w$}", u64::from(m) / p, u64::from(m) % p, w = k as usize)
            };
            assert_eq!(decimal_text(&mut buf, true, m, k), Some(&want[..]));
        }
    }
}
