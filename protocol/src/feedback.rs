//! Feedback lines (firmware to host) and the feedback rate divider.
//!
//! No floating point is formatted: every value goes through
//! [`Scalar::to_scaled_int`] (round half away from zero, saturating, NaN
//! gives 0) and is printed as an integer with a decimal point inserted. So
//! `nan` and `inf` can never appear; an f32 infinity prints as the saturated
//! `i64` value. The sign comes from the rounded integer: a value that rounds
//! to zero prints `0.000` / `0.0000`, never `-0.000`.
//!
//! - Driver line (15 tokens, interleaved, 3 decimals):
//!   `<ACK,SEQ,p1,v1,p2,v2,p3,v3,p4,v4,p5,v5,p6,v6,H<d>>`
//! - Configurator line (grouped, 4 decimals, all numeric):
//!   `<ACK,SEQ,p1..p6,v1..v6,limit_bitmask,state_byte,tick_us>`

use crate::parse::Dialect;
use crate::text::{push_byte, push_scaled, push_str, push_u32};
use crate::{Full, Line};
use kernel::{Scalar, State, Status};

/// Which feedback lines to send each period.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FeedbackMode {
    /// Only the driver's line (about 100 bytes).
    Driver,
    /// Only the configurator's line (about 110 bytes).
    Configurator,
    /// Both clients on one stream, without a race: the configurator's line
    /// is sent with one leading space (` <ACK,...>`), which the ROS 2
    /// driver ignores (it keeps only lines that *start* with `<`) and the
    /// configurator strips before its regex; the driver's line (with its
    /// `H` token) fails the configurator's regex. So whatever a client
    /// reads last, it only ever takes its own line. See docs/PROTOCOL.md.
    #[default]
    Both,
}

/// The configurator's state byte: 1 nominal (Boot, Unhomed, Operational),
/// 2 homing, 3 fault or soft E-stop (Stopping, SoftEstop, Fault).
pub const fn state_byte(state: State) -> u8 {
    match state {
        State::Boot | State::Unhomed | State::Operational => 1,
        State::Homing => 2,
        State::Stopping | State::SoftEstop | State::Fault => 3,
    }
}

fn push_value<S: Scalar>(out: &mut Line, v: S, d: Dialect) -> Result<(), Full> {
    push_byte(out, b',')?;
    push_scaled(out, scaled(v, d), d.decimals())
}

/// `v.to_scaled_int(d.scale())`, for `f32` computed by [`f32_scaled`] with
/// integer arithmetic only (the same value: no soft `f64` in the image's
/// feedback path); the type test is resolved at compile time.
fn scaled<S: Scalar>(v: S, d: Dialect) -> i64 {
    if core::any::TypeId::of::<S>() == core::any::TypeId::of::<f32>() {
        // `to_f32` is the identity for `f32`.
        f32_scaled(
            v.to_f32(),
            match d {
                Dialect::Driver => 1_000,
                Dialect::Configurator => 10_000,
            },
        )
    } else {
        v.to_scaled_int(d.scale())
    }
}

/// `round(x * scale)` with ties away from zero, saturating to `i64`, NaN
/// 0: exactly `f32::to_scaled_int` (which computes it in `f64`, exactly:
/// the product has at most 24 + 32 significant bits and adding 0.5 is exact
/// below 2^52, an integer above), with integer arithmetic on the bits: the
/// value is `m * 2^e`, so `x * scale = (m * scale) * 2^e`, and
/// `m * scale < 2^56` fits a `u64`.
pub fn f32_scaled(x: f32, scale: u32) -> i64 {
    let bits = x.to_bits();
    let negative = bits >> 31 != 0;
    let exp = (bits >> 23) & 0xFF;
    let frac = u64::from(bits & 0x7F_FFFF);
    // 2^63: beyond every i64 magnitude but i64::MIN's; saturates.
    const SAT: u64 = 1 << 63;
    let mag = if exp == 0xFF {
        if frac != 0 {
            return 0; // NaN
        }
        SAT // infinity
    } else {
        let (m, e) = if exp == 0 { (frac, -149i32) } else { (frac | 1 << 23, (exp as i32).wrapping_sub(150)) };
        let p = m.wrapping_mul(u64::from(scale)); // < 2^24 * 2^32: exact
        if p == 0 {
            0
        } else if e >= 0 {
            if e >= 63 || p >= 1u64 << (63i32.wrapping_sub(e)) {
                SAT
            } else {
                p << e
            }
        } else {
            let s = e.unsigned_abs();
            if s >= 64 {
                0 // p < 2^56 <= 2^(s - 1): below one half
            } else {
                // floor(p / 2^s + 1/2); p + 2^(s - 1) < 2^56 + 2^62
                p.wrapping_add(1u64 << s.wrapping_sub(1)) >> s
            }
        }
    };
    match (i64::try_from(mag), negative) {
        (Ok(m), false) => m,
        (Ok(m), true) => m.wrapping_neg(), // m <= i64::MAX
        (Err(_), false) => i64::MAX,
        (Err(_), true) => i64::MIN,
    }
}

/// The driver's feedback line for `status`, acknowledging `seq`, `\n`-terminated.
pub fn driver_line<S: Scalar>(out: &mut Line, seq: u32, status: &Status<S>) -> Result<(), Full> {
    out.clear();
    push_str(out, "<ACK,")?;
    push_u32(out, seq)?;
    for (p, v) in status.position.iter().zip(&status.velocity) {
        push_value(out, *p, Dialect::Driver)?;
        push_value(out, *v, Dialect::Driver)?;
    }
    push_str(out, ",H")?;
    push_u32(out, status.homing as u32)?;
    push_str(out, ">\n")
}

/// The configurator's feedback line for `status`, acknowledging `seq`, with
/// the measured control-interrupt time `tick_us` last, `\n`-terminated.
pub fn configurator_line<S: Scalar>(out: &mut Line, seq: u32, status: &Status<S>, tick_us: u32) -> Result<(), Full> {
    out.clear();
    configurator_body(out, seq, status, tick_us)
}

fn configurator_body<S: Scalar>(out: &mut Line, seq: u32, status: &Status<S>, tick_us: u32) -> Result<(), Full> {
    push_str(out, "<ACK,")?;
    push_u32(out, seq)?;
    for v in status.position.iter().chain(&status.velocity) {
        push_value(out, *v, Dialect::Configurator)?;
    }
    push_byte(out, b',')?;
    push_u32(out, u32::from(status.limits & 0x3F))?;
    push_byte(out, b',')?;
    push_u32(out, u32::from(state_byte(status.state)))?;
    push_byte(out, b',')?;
    push_u32(out, tick_us)?;
    push_str(out, ">\n")
}

/// The configurator's line with one leading space, for [`FeedbackMode::Both`]
/// (the ROS 2 driver ignores lines that do not start with `<`).
pub fn configurator_line_beside_driver<S: Scalar>(
    out: &mut Line,
    seq: u32,
    status: &Status<S>,
    tick_us: u32,
) -> Result<(), Full> {
    out.clear();
    push_byte(out, b' ')?;
    configurator_body(out, seq, status, tick_us)
}

/// Divides the tick rate down to the feedback rate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FeedbackDivider {
    every: u32,
    count: u32,
}

impl FeedbackDivider {
    /// Feedback at `rate_hz` from a tick at `tick_hz` (every
    /// `max(1, tick_hz / rate_hz)` ticks; `rate_hz` 0 is treated as 1).
    pub const fn new(tick_hz: u32, rate_hz: u32) -> Self {
        let rate = if rate_hz == 0 { 1 } else { rate_hz };
        let every = match tick_hz.checked_div(rate) {
            Some(0) | None => 1,
            Some(e) => e,
        };
        FeedbackDivider { every, count: 0 }
    }
    /// 50 Hz at `tick_hz` (the rate the driver's peer firmware used).
    pub const fn default_for(tick_hz: u32) -> Self {
        Self::new(tick_hz, 50)
    }
    /// Ticks per feedback period.
    pub const fn every(&self) -> u32 {
        self.every
    }
    /// Call once per tick; true when feedback is due (on the first tick,
    /// then every `every` ticks).
    pub fn tick(&mut self) -> bool {
        let due = self.count == 0;
        self.count = self.count.saturating_add(1);
        if self.count >= self.every {
            self.count = 0;
        }
        due
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `f32_scaled` equals the kernel's `f32::to_scaled_int` (the f64
    /// method) on every exponent with edge and pseudo-random mantissas, both
    /// signs, both dialects' scales, and the special values. (The whole f32
    /// domain was compared once, for both scales, outside the test suite.)
    #[test]
    fn f32_scaled_equals_to_scaled_int() {
        let check = |bits: u32| {
            let x = f32::from_bits(bits);
            for scale in [1_000u32, 10_000] {
                assert_eq!(f32_scaled(x, scale), x.to_scaled_int(i64::from(scale)), "{x:e} ({bits:#x}) x {scale}");
            }
        };
        let mut r = 0x9E37_79B9u32;
        for exp in 0u32..=0xFF {
            for frac in [0u32, 1, 2, 0x40_0000, 0x40_0001, 0x7F_FFFE, 0x7F_FFFF] {
                for sign in [0u32, 1 << 31] {
                    check(sign | exp << 23 | frac);
                }
            }
            for _ in 0..2_000 {
                r ^= r << 13;
                r ^= r >> 17;
                r ^= r << 5;
                check((r & 0x807F_FFFF) | exp << 23);
            }
        }
        // exact halves and their neighbours at the printed resolution
        for k in -100_000i32..=100_000 {
            for scale in [1_000.0f32, 10_000.0] {
                let x = (k as f32 + 0.5) / scale;
                for b in [x.to_bits().wrapping_sub(1), x.to_bits(), x.to_bits().wrapping_add(1)] {
                    check(b);
                }
            }
        }
    }

    #[test]
    fn divider() {
        let mut d = FeedbackDivider::default_for(1000);
        assert_eq!(d.every(), 20);
        let due: Vec<bool> = (0..60).map(|_| d.tick()).collect();
        assert_eq!(due.iter().filter(|x| **x).count(), 3);
        assert!(due[0] && due[20] && due[40]);
        let mut d = FeedbackDivider::new(1000, 5000);
        assert!((0..10).all(|_| d.tick()));
        assert_eq!(FeedbackDivider::new(1000, 0).every(), 1000);
    }
}
