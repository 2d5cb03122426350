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
    push_scaled(out, v.to_scaled_int(d.scale()), d.decimals())
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
