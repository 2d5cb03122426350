//! The frame decoder on `u64` / `i64` divisions: the reference the shipped
//! [`FrameDecoder`](hal::pure::frame::FrameDecoder), which divides only
//! 32-bit numbers (no 64-bit division helper in the tick interrupt), is
//! checked against.
//!
//! Same fields, same names, same control flow as the shipped decoder; only
//! the arithmetic of the edge prediction, the period measurement and the
//! decode differs ([`decode_window`] instead of `decode_frame`). The type
//! and its fields are named as the shipped ones, so the two `Debug`
//! renderings are equal exactly when the two states are.
//!
//! Included by `hal-imxrt/tests/frame_reference.rs` (end-to-end streams) and
//! by the unit tests of `hal-imxrt/src/pure/frame.rs` (per function, from
//! states only the crate can build); each brings the crate into scope as
//! `hal` before declaring this module.

#![allow(dead_code)]

use super::hal::pure::clock::CYCLES_PER_QTIMER_TICK;
use super::hal::pure::encoder::{decode_window, EncoderReading, LossReason};
use super::hal::pure::frame::{
    Snapshot, CALIBRATION_FRAMES, DOUBLE_WINDOW_STAMP_CYCLES, EDGE_MARGIN_CYCLES, FIRST_SPAN_FRAMES, FRAME_DECODE,
    MAX_FRAME_AGE, MAX_PERIOD_CYCLES, MIN_PERIOD_CYCLES, NOMINAL_PERIOD_CYCLES, PERIOD_ANCHOR_FRAMES,
    PREDICTION_FRAMES_PER_SPAN, QUIET_MIN_WINDOW_CYCLES, QUIET_WINDOWS, TICK_CYCLES, UNMEASURED_TOLERANCE_COUNTS,
};

/// A frame's reading while the period is not measured: the nominal decode
/// if the decodes at `shortest` and `MAX_PERIOD_CYCLES` agree within the
/// tolerance, with [`decode_window`].
pub fn decode_unmeasured(high_ticks: u16, period: u32, shortest: u32) -> EncoderReading {
    let decode = |p: u32| decode_window(high_ticks as u32, p, &FRAME_DECODE);
    let nominal = decode(period);
    if nominal.count().is_none() {
        return nominal;
    }
    match (decode(shortest), decode(MAX_PERIOD_CYCLES)) {
        (EncoderReading::Count(hi), EncoderReading::Count(lo)) if hi.abs_diff(lo) <= UNMEASURED_TOLERANCE_COUNTS => {
            nominal
        }
        _ => EncoderReading::Lost(LossReason::Acquiring),
    }
}

/// Why the decoder has no frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoFrame {
    Starting,
    Stale,
}

/// The reference decoder's state (the shipped decoder's fields).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameDecoder {
    pub last_capt: Option<u16>,
    pub edges: u32,
    pub anchor: Option<(u32, u32)>,
    pub quiet_since_anchor: bool,
    pub since_quiet: u16,
    pub slow: bool,
    pub phase: Option<u32>,
    pub stamped: Option<u16>,
    pub last_t: Option<u32>,
    pub period: u32,
    pub span: u32,
    pub measured: bool,
    pub high: Option<u16>,
    pub age: u8,
    pub repeats: u32,
    pub state: NoFrame,
}

impl FrameDecoder {
    /// No frame yet, the nominal period.
    pub const fn new() -> Self {
        Self {
            last_capt: None,
            edges: 0,
            anchor: None,
            quiet_since_anchor: false,
            since_quiet: 0,
            slow: false,
            phase: None,
            stamped: None,
            last_t: None,
            period: NOMINAL_PERIOD_CYCLES,
            span: 0,
            measured: false,
            high: None,
            age: 0,
            repeats: 0,
            state: NoFrame::Starting,
        }
    }

    pub const fn repeated(&self) -> bool {
        self.age > 0 && self.high.is_some()
    }

    pub const fn fast(&self) -> bool {
        self.measured && self.period < TICK_CYCLES + 2 * EDGE_MARGIN_CYCLES
    }

    /// Predicted rising edges in `(t0, t1]`, on `i64` `div_euclid` /
    /// `rem_euclid`.
    pub fn predicted_edges(&self, t0: u32, t1: u32) -> Option<u32> {
        let ph = self.phase?;
        if !self.measured || self.period == 0 {
            return None;
        }
        let p = self.period as i64;
        let rel = |t: u32| t.wrapping_sub(ph) as i32 as i64;
        let (d0, d1) = (rel(t0), rel(t1));
        // a phase older than the horizon: prediction error too large
        let horizon = self.horizon() as i64;
        if d0.abs() > horizon * p || d1.abs() > horizon * p || d1 < d0 {
            return None;
        }
        let m = EDGE_MARGIN_CYCLES as i64;
        let clear = |d: i64| {
            let r = d.rem_euclid(p);
            r >= m && r <= p - m
        };
        if !clear(d0) || !clear(d1) {
            return None;
        }
        Some((d1.div_euclid(p) - d0.div_euclid(p)) as u32)
    }

    /// Frames past the phase the prediction reaches.
    pub const fn horizon(&self) -> u32 {
        let h = self.span.saturating_mul(PREDICTION_FRAMES_PER_SPAN);
        if h < 2_000 {
            h
        } else {
            2_000
        }
    }

    /// A new estimate over `frames` frames replaces the current one.
    pub const fn keeps(&self, frames: u32) -> bool {
        let need = if self.span < PERIOD_ANCHOR_FRAMES { self.span } else { PERIOD_ANCHOR_FRAMES };
        !self.measured || frames >= need
    }

    /// The phase from a window predicted to hold two edges, on `i64`
    /// `rem_euclid`.
    pub fn refresh_phase(&mut self, s: Snapshot) {
        let (Some(ph), Some(h)) = (self.phase, self.high) else {
            return;
        };
        let p = self.period as i64;
        let d = s.cycles.wrapping_sub(ph) as i32 as i64;
        let r = d.rem_euclid(p) as u32;
        let since = s.cntr.wrapping_sub(s.capt) as u32 * CYCLES_PER_QTIMER_TICK;
        let first_high = h as u32 * CYCLES_PER_QTIMER_TICK;
        let overwritten = since.abs_diff(r) <= DOUBLE_WINDOW_STAMP_CYCLES;
        let inhibited = since >= first_high && (since - first_high).abs_diff(r) <= DOUBLE_WINDOW_STAMP_CYCLES;
        if overwritten {
            self.phase = Some(s.cycles.wrapping_sub(since));
        } else if inhibited {
            self.phase = Some(s.cycles.wrapping_sub(since - first_high));
        }
    }

    /// A period measured outside the decoder and an edge as the phase.
    pub fn calibrate(&mut self, period: u32, edge_cycles: u32) {
        if (NOMINAL_PERIOD_CYCLES / 2..=MAX_PERIOD_CYCLES + MAX_PERIOD_CYCLES / 2).contains(&period) {
            self.period = period;
            self.span = CALIBRATION_FRAMES;
            self.measured = true;
            self.phase = Some(edge_cycles);
            self.anchor = None;
            self.quiet_since_anchor = false;
        }
    }

    /// Rising edge number `edge` timestamped at `t`, on `u64` divisions.
    pub fn timestamp(&mut self, edge: u32, t: u32) {
        self.phase = Some(t);
        let quiet = core::mem::take(&mut self.quiet_since_anchor);
        let Some((n0, t0)) = self.anchor else {
            self.anchor = Some((edge, t));
            return;
        };
        let span = t.wrapping_sub(t0) as u64;
        let by_index = edge.wrapping_sub(n0) as u64;
        if quiet && by_index > 0 && !self.fast() {
            let est = (span + by_index / 2) / by_index;
            if (TICK_CYCLES as u64..=MAX_PERIOD_CYCLES as u64).contains(&est) {
                if self.keeps(by_index as u32) {
                    self.period = est as u32;
                    self.span = by_index as u32;
                }
                self.measured = true;
                if by_index >= PERIOD_ANCHOR_FRAMES as u64 {
                    self.anchor = Some((edge, t));
                } else {
                    self.quiet_since_anchor = true;
                }
                return;
            }
        }
        let p = self.period as u64;
        let frames = (span + p / 2) / p;
        let max_frames = if self.measured { 2 * PERIOD_ANCHOR_FRAMES as u64 } else { FIRST_SPAN_FRAMES as u64 };
        // |span / p - frames| in thousandths of a frame
        let off = (span * 1000).abs_diff(frames * p * 1000) / p;
        if frames == 0 || frames > max_frames || off > 200 {
            self.anchor = Some((edge, t));
            return;
        }
        let est = ((span + frames / 2) / frames) as u32;
        if (NOMINAL_PERIOD_CYCLES / 2..=MAX_PERIOD_CYCLES + MAX_PERIOD_CYCLES / 2).contains(&est) {
            if self.keeps(frames as u32) {
                self.period = est;
                self.span = frames as u32;
            }
            self.measured = true;
            if frames >= PERIOD_ANCHOR_FRAMES as u64 {
                self.anchor = Some((edge, t));
            } else {
                self.quiet_since_anchor = quiet;
            }
        } else {
            self.anchor = Some((edge, t));
        }
    }

    /// One snapshot: the shipped `FrameDecoder::update`'s control flow.
    pub fn update(&mut self, s: Snapshot) -> EncoderReading {
        let prev_t = self.last_t.replace(s.cycles);
        let mut fresh = false;
        let quiet = !s.ief && prev_t.is_some_and(|t0| s.cycles.wrapping_sub(t0) >= QUIET_MIN_WINDOW_CYCLES);
        if s.consistent {
            self.since_quiet = if quiet { 0 } else { self.since_quiet.saturating_add(1) };
            self.slow |= quiet;
        }
        let clean = if self.fast() {
            match prev_t.and_then(|t0| self.predicted_edges(t0, s.cycles)) {
                Some(n) => n == u32::from(s.ief),
                None => false,
            }
        } else {
            self.measured || self.since_quiet <= QUIET_WINDOWS
        };
        if !s.consistent {
            self.anchor = None;
            self.quiet_since_anchor = false;
        } else if quiet && self.anchor.is_some() {
            self.quiet_since_anchor = true;
        }
        if !s.consistent || !clean {
            self.last_capt = None;
            if s.consistent && s.ief {
                let predicted = prev_t.and_then(|t0| self.predicted_edges(t0, s.cycles));
                if predicted == Some(1) {
                    self.last_capt = Some(s.capt);
                }
                if predicted == Some(2) && s.input_high {
                    self.refresh_phase(s);
                }
                self.edges = self.edges.wrapping_add(1);
            }
        } else if s.ief {
            if let Some(prev) = self.last_capt {
                self.high = Some(s.capt.wrapping_sub(prev));
                self.age = 0;
                fresh = true;
            }
            self.last_capt = Some(s.capt);
            self.edges = self.edges.wrapping_add(1);
        }
        if s.consistent && clean && s.input_high && self.last_capt == Some(s.capt) {
            let since = s.cntr.wrapping_sub(s.capt) as u32 * CYCLES_PER_QTIMER_TICK;
            if since < self.period.min(MIN_PERIOD_CYCLES) && self.stamped != Some(s.capt) {
                self.stamped = Some(s.capt);
                self.timestamp(self.edges, s.cycles.wrapping_sub(since));
            }
        }
        if !fresh {
            self.age = self.age.saturating_add(1);
        }
        if self.repeated() {
            self.repeats = self.repeats.saturating_add(1);
        }
        if self.period < MIN_PERIOD_CYCLES {
            return EncoderReading::Lost(LossReason::WindowTooShort);
        }
        match self.high {
            Some(_) if self.age > MAX_FRAME_AGE => {
                self.state = NoFrame::Stale;
                self.high = None;
                self.last_capt = None;
                EncoderReading::Lost(if s.input_high { LossReason::StuckHigh } else { LossReason::NoSignal })
            }
            Some(h) if !self.measured => {
                let shortest = if self.slow { QUIET_MIN_WINDOW_CYCLES } else { MIN_PERIOD_CYCLES };
                decode_unmeasured(h, self.period, shortest)
            }
            Some(h) => decode_window(h as u32, self.period, &FRAME_DECODE),
            None => {
                if self.age > MAX_FRAME_AGE && self.state == NoFrame::Starting {
                    self.state = NoFrame::Stale;
                }
                match self.state {
                    NoFrame::Starting => EncoderReading::Lost(LossReason::Acquiring),
                    NoFrame::Stale => {
                        EncoderReading::Lost(if s.input_high { LossReason::StuckHigh } else { LossReason::NoSignal })
                    }
                }
            }
        }
    }
}
