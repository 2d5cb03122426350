//! MT6816 PWM output and the QuadTimer channel that captures it.
//!
//! Each encoder emits real frames: 4119 PWM clocks of 250 ns (150 CPU cycles
//! at 600 MHz), HIGH for `16 + count` clocks, LOW to the end. The count of a
//! frame is the motor angle at the frame's start.
//! The figures are the HAL's (`hal_imxrt::pure::mt6816`, `pure::clock`).
//!
//! The channel is modelled as the i.MXRT1062 QuadTimer the firmware programs
//! (gated count of the IPG/8 clock, one tick every 32 CPU cycles, while the
//! pin is high; capture of the counter into `CAPT` on every rising edge,
//! setting `SCTRL[IEF]`; `SCTRL[INPUT]` following the pin), read once per
//! control tick into the same [`Snapshot`] the firmware's `FrameCapture`
//! produces. The snapshot then goes through the composition root's
//! [`hal_imxrt::pure::channel::EncoderChannel`]: the decoder that is flashed.
//! The counter is exact: the number of timer edges that fall inside HIGH time.

use hal_imxrt::pure::clock;
use hal_imxrt::pure::encoder::LossReason;
use hal_imxrt::pure::frame::Snapshot;
use hal_imxrt::pure::mt6816::{self, COUNTS_PER_REV, FRAME_CLOCKS, START_CLOCKS};

use crate::rng::Rng;

/// CPU cycles per PWM clock (250 ns at 600 MHz): the HAL's figure.
pub const CYCLES_PER_PWM_CLOCK: f64 = mt6816::CYCLES_PER_PWM_CLOCK as f64;
/// CPU cycles per QuadTimer tick (53.3 ns): the HAL's figure.
pub const CYCLES_PER_QT_TICK: f64 = clock::CYCLES_PER_QTIMER_TICK as f64;
/// CPU frequency: the HAL's figure.
pub const CPU_HZ: u64 = clock::CPU_HZ as u64;
/// CPU cycles a snapshot's register reads span (first `SCTRL` read to the
/// second): an edge inside it makes the snapshot inconsistent, as on the chip.
pub const SNAPSHOT_CYCLES: f64 = 60.0;

/// What the encoder line does, for fault injection.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Line {
    /// Normal PWM output.
    Ok,
    /// Stuck low (cable cut, encoder unpowered: the pad has a pull-down).
    StuckLow,
    /// Stuck high.
    StuckHigh,
}

#[derive(Clone, Copy, Debug)]
struct Frame {
    start: f64,
    high_end: f64,
    /// `ceil(start / 32)` and `ceil(high_end / 32)`: the index of the first
    /// timer edge at or after each (see [`edge_index`]).
    start_edge: i64,
    high_end_edge: i64,
}

/// The last (at most) four frames, oldest first: a frame pushed into a full
/// buffer drops the oldest.
#[derive(Clone, Copy, Debug)]
struct Frames {
    buf: [Frame; 4],
    len: usize,
}

impl Frames {
    const EMPTY: Frames =
        Frames { buf: [Frame { start: 0.0, high_end: 0.0, start_edge: 0, high_end_edge: 0 }; 4], len: 0 };

    fn push_back(&mut self, f: Frame) {
        if self.len == self.buf.len() {
            self.pop_front();
        }
        if let Some(slot) = self.buf.get_mut(self.len) {
            *slot = f;
            self.len += 1;
        }
    }

    fn pop_front(&mut self) {
        if self.len > 0 {
            // A fixed shift of the whole (small) array, not a copy of a
            // variable length (a call to memmove per frame).
            let [_, b, c, d] = self.buf;
            self.buf = [b, c, d, d];
            self.len -= 1;
        }
    }

    fn front(&self) -> Option<&Frame> {
        self.as_slice().first()
    }

    fn as_slice(&self) -> &[Frame] {
        &self.buf[..self.len]
    }

    fn iter(&self) -> core::slice::Iter<'_, Frame> {
        self.as_slice().iter()
    }
}

/// Counts of decode outcomes (for the report).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DecodeStats {
    /// Valid counts passed to the kernel.
    pub ok: u64,
    /// Lost, by reason: no signal, stuck high, duty out of range, window,
    /// implausible, inconsistent, acquiring, unrecoverable.
    pub lost: [u64; 8],
}

impl DecodeStats {
    /// Names of the `lost` slots.
    pub const NAMES: [&'static str; 8] = [
        "no-signal",
        "stuck-high",
        "duty-range",
        "window",
        "implausible",
        "inconsistent",
        "acquiring",
        "unrecoverable",
    ];

    /// Counts one reading.
    pub fn add(&mut self, r: hal_imxrt::pure::encoder::EncoderReading) {
        let r = match r {
            hal_imxrt::pure::encoder::EncoderReading::Count(_) => {
                self.ok += 1;
                return;
            }
            hal_imxrt::pure::encoder::EncoderReading::Lost(r) => r,
        };
        let i = match r {
            LossReason::NoSignal => 0,
            LossReason::StuckHigh => 1,
            LossReason::DutyOutOfRange => 2,
            LossReason::WindowTooShort | LossReason::WindowTooLong => 3,
            LossReason::Implausible => 4,
            LossReason::Inconsistent => 5,
            LossReason::Acquiring => 6,
            LossReason::Unrecoverable => 7,
        };
        if let Some(s) = self.lost.get_mut(i) {
            *s += 1;
        }
    }

    /// Total lost samples.
    pub fn lost_total(&self) -> u64 {
        self.lost.iter().sum()
    }
}

/// `x.ceil()` as an integer, for `|x| < 2^62` (every time and count here),
/// without the libm call `f64::ceil` is on a baseline x86-64 build: the
/// conversion truncates toward zero, and one comparison corrects it.
#[inline(always)]
fn ceil_i64(x: f64) -> i64 {
    let i = x as i64;
    if (i as f64) < x {
        i + 1
    } else {
        i
    }
}

/// `x.floor()` as an integer, for `|x| < 2^62`.
#[inline(always)]
fn floor_i64(x: f64) -> i64 {
    let i = x as i64;
    if (i as f64) > x {
        i - 1
    } else {
        i
    }
}

/// `x.round()` (half away from zero) as an integer, for `|x| < 2^52`
/// (`x - trunc(x)` is then exact).
#[inline(always)]
fn round_i64(x: f64) -> i64 {
    let i = x as i64;
    let frac = x - i as f64;
    if frac >= 0.5 {
        i + 1
    } else if frac <= -0.5 {
        i - 1
    } else {
        i
    }
}

/// `ceil(t / 32)`: the index of the first timer edge (every 32 CPU cycles)
/// at or after `t` (the division by a power of two is exact).
#[inline(always)]
fn edge_index(t: f64) -> i64 {
    ceil_i64(t / CYCLES_PER_QT_TICK)
}

/// Timer edges in `(a, b]`, from the edge indices of `a` and `b`:
/// `ceil(b / 32) - ceil(a / 32)`, zero when `b <= a` (the indices are
/// monotonic, so the difference is then not positive).
#[inline(always)]
fn edges(a_edge: i64, b_edge: i64) -> u64 {
    (b_edge - a_edge).max(0) as u64
}

/// One MT6816 and its QuadTimer channel.
#[derive(Clone, Debug)]
pub struct Encoder {
    period: f64,
    next_start: f64,
    /// The frames that can still matter (at most the last four).
    frames: Frames,
    /// Converts nominal PWM clocks (in CPU cycles) to this encoder's.
    clock_scale: f64,
    /// Gated counter (high ticks since power-on) at `last_sample`.
    gated: u64,
    capt: u16,
    ief: bool,
    last_sample: f64,
    /// `edge_index(last_sample)`.
    last_sample_edge: i64,
    /// Gaussian noise on each frame's count (counts, sigma).
    pub noise: f64,
    /// Line state (fault injection).
    pub line: Line,
    /// Pending glitch: offset added to the next `frames` frames.
    pub glitch: Option<(i32, u32)>,
    /// Fault injection: a reversed encoder (a magnet mounted the other way
    /// round): every frame reads the count mirrored about the count of the
    /// first frame after the injection (`Some(mirror)` once that frame is
    /// made), so the reading does not jump but runs the other way.
    pub reversed: Option<Option<i64>>,
    /// Fault injection: a frozen but valid reading (an encoder whose
    /// electronics stopped updating): every frame repeats the count of the
    /// first frame after the injection.
    pub frozen: Option<Option<i64>>,
}

impl Encoder {
    /// An encoder whose frames start `phase` (0..1 of a frame) after t = 0
    /// and whose clock is off by `clock_ppm`.
    pub fn new(phase: f64, clock_ppm: f64, noise: f64) -> Self {
        let period = f64::from(FRAME_CLOCKS) * CYCLES_PER_PWM_CLOCK * (1.0 + clock_ppm * 1e-6);
        Encoder {
            period,
            next_start: phase.rem_euclid(1.0) * period,
            frames: Frames::EMPTY,
            clock_scale: period / (f64::from(FRAME_CLOCKS) * CYCLES_PER_PWM_CLOCK),
            gated: 0,
            capt: 0,
            ief: false,
            last_sample: 0.0,
            last_sample_edge: 0,
            noise,
            line: Line::Ok,
            glitch: None,
            reversed: None,
            frozen: None,
        }
    }

    /// Timer edges in `(a, b]` while the pin is high, from the edge indices
    /// of `a` and `b`: per frame, the edges in `(max(start, a), min(high_end,
    /// b)]`, whose edge indices are the max and min of the ends' (`ceil` is
    /// monotonic).
    fn high_ticks(&self, a_edge: i64, b_edge: i64) -> u64 {
        match self.line {
            Line::StuckLow => 0,
            Line::StuckHigh => edges(a_edge, b_edge),
            Line::Ok => self.frames.iter().map(|f| edges(f.start_edge.max(a_edge), f.high_end_edge.min(b_edge))).sum(),
        }
    }

    fn pin_high(&self, t: f64) -> bool {
        match self.line {
            Line::StuckLow => false,
            Line::StuckHigh => true,
            Line::Ok => self.frames.iter().any(|f| f.start <= t && t < f.high_end),
        }
    }

    /// [`Encoder::read`] as first written (a pass over the frames per
    /// question), the reference the one-pass read is tested against.
    #[cfg(test)]
    fn read_reference(&mut self, t_now: f64) -> Snapshot {
        let t_prev = self.last_sample;
        let horizon = t_now + SNAPSHOT_CYCLES;
        let (prev_edge, now_edge) = (self.last_sample_edge, edge_index(t_now));
        if self.line == Line::Ok {
            for f in self.frames.iter().filter(|f| f.start > t_prev && f.start <= t_now) {
                self.capt = self.gated.wrapping_add(self.high_ticks(prev_edge, f.start_edge)) as u16;
                self.ief = true;
            }
        }
        self.gated = self.gated.wrapping_add(self.high_ticks(prev_edge, now_edge));
        self.last_sample = t_now;
        self.last_sample_edge = now_edge;
        let input_high = self.pin_high(t_now);
        let edge_during_read = self.line == Line::Ok
            && self
                .frames
                .iter()
                .any(|f| (f.start > t_now && f.start <= horizon) || (f.high_end > t_now && f.high_end <= horizon));
        let s = Snapshot {
            ief: self.ief,
            input_high,
            capt: self.capt,
            cntr: self.gated as u16,
            cycles: round_i64(t_now) as u64 as u32,
            consistent: !edge_during_read,
        };
        self.ief = false;
        while self.frames.front().is_some_and(|f| f.high_end <= t_now) {
            self.frames.pop_front();
        }
        s
    }

    /// Advances the signal to `t_now` (CPU cycles) and reads the channel as
    /// the firmware does (then clears `IEF`). The motor angle, in counts
    /// (continuous, unwrapped), is `c_prev` at the previous read and `c_now`
    /// at `t_now`, linear in between.
    pub fn sample(&mut self, t_now: f64, c_prev: f64, c_now: f64, rng: &mut Rng) -> Snapshot {
        self.generate(t_now, c_prev, c_now, rng);
        self.read(t_now)
    }

    /// Step 1 of [`Encoder::sample`]: the frames that start before the end
    /// of the read at `t_now`.
    fn generate(&mut self, t_now: f64, c_prev: f64, c_now: f64, rng: &mut Rng) {
        let t_prev = self.last_sample;
        let angle_at = |t: f64| -> f64 {
            if t_now > t_prev {
                c_prev + (c_now - c_prev) * ((t - t_prev) / (t_now - t_prev)).clamp(0.0, 1.0)
            } else {
                c_now
            }
        };
        // 1. Frames that start before the end of this read.
        let horizon = t_now + SNAPSHOT_CYCLES;
        while self.next_start < horizon {
            let start = self.next_start;
            let mut c = floor_i64(angle_at(start));
            if let Some(m) = self.reversed.as_mut() {
                let m = *m.get_or_insert(c);
                c = 2 * m - c;
            }
            if self.noise > 0.0 {
                c += round_i64(rng.normal() * self.noise);
            }
            if let Some((off, n)) = self.glitch {
                c += i64::from(off);
                self.glitch = if n > 1 { Some((off, n - 1)) } else { None };
            }
            if let Some(f) = self.frozen.as_mut() {
                c = *f.get_or_insert(c);
            }
            let count = c.rem_euclid(i64::from(COUNTS_PER_REV)) as f64;
            let high_end = start + (f64::from(START_CLOCKS) + count) * CYCLES_PER_PWM_CLOCK * self.clock_scale;
            self.frames.push_back(Frame {
                start,
                high_end,
                start_edge: edge_index(start),
                high_end_edge: edge_index(high_end),
            });
            self.next_start += self.period;
        }
        // (Only the last four frames are kept: `push_back` drops the oldest.
        // Frames whose HIGH time ended by the previous read were dropped at
        // its end, below: they count nothing, raise no edge and are no
        // longer the pin's level.)
    }

    /// Steps 2 to 4 of [`Encoder::sample`], once the frames up to the end of
    /// the read are known.
    fn read(&mut self, t_now: f64) -> Snapshot {
        let t_prev = self.last_sample;
        let horizon = t_now + SNAPSHOT_CYCLES;
        // 2. Rising edges in (t_prev, t_now]: CAPT := counter at the edge.
        // 3. The gated counter at t_now.
        // 4. The read: SCTRL, CAPT, CNTR + CYCCNT, clear IEF, SCTRL again.
        let (prev_edge, now_edge) = (self.last_sample_edge, edge_index(t_now));
        let (input_high, edge_during_read) = match self.line {
            Line::Ok => {
                // One pass over the frames (oldest first). A frame's HIGH
                // time ends before the next frame starts, so at a frame's
                // rising edge the counter has gained exactly what the frames
                // before it gained since `t_prev` (`high`), and nothing from
                // it or later ones.
                let mut high = 0u64;
                let (mut input_high, mut edge_during_read) = (false, false);
                for f in self.frames.iter() {
                    if f.start > t_prev && f.start <= t_now {
                        self.capt = self.gated.wrapping_add(high) as u16;
                        self.ief = true;
                    }
                    high += edges(f.start_edge.max(prev_edge), f.high_end_edge.min(now_edge));
                    input_high |= f.start <= t_now && t_now < f.high_end;
                    edge_during_read |=
                        (f.start > t_now && f.start <= horizon) || (f.high_end > t_now && f.high_end <= horizon);
                }
                self.gated = self.gated.wrapping_add(high);
                (input_high, edge_during_read)
            }
            Line::StuckLow | Line::StuckHigh => {
                self.gated = self.gated.wrapping_add(self.high_ticks(prev_edge, now_edge));
                (self.pin_high(t_now), false)
            }
        };
        self.last_sample = t_now;
        self.last_sample_edge = now_edge;
        let s = Snapshot {
            ief: self.ief,
            input_high,
            capt: self.capt,
            cntr: self.gated as u16,
            cycles: round_i64(t_now) as u64 as u32,
            consistent: !edge_during_read,
        };
        self.ief = false;
        // Every later read is after `t_now`: a frame whose HIGH time ended
        // by now contributes nothing to it (no count, no edge, not the
        // pin's level). Frames are ordered, so those are at the front.
        while self.frames.front().is_some_and(|f| f.high_end <= t_now) {
            self.frames.pop_front();
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hal_imxrt::pure::channel::EncoderChannel;
    use hal_imxrt::pure::encoder::EncoderReading;

    fn run(count: f64, speed_counts_per_ms: f64, ticks: usize) -> Vec<EncoderReading> {
        let mut e = Encoder::new(0.37, 0.0, 0.0);
        let mut ch = EncoderChannel::new();
        let mut rng = Rng::new(1);
        let mut c = count;
        (1..=ticks)
            .map(|k| {
                let prev = c;
                c += speed_counts_per_ms;
                ch.update(e.sample(k as f64 * 600_000.0, prev, c, &mut rng))
            })
            .collect()
    }

    #[test]
    fn shipped_decoder_is_exact_at_rest() {
        for count in [0.0, 1.0, 17.0, 2048.0, 4000.0, 4095.0] {
            let s = run(count, 0.0, 40);
            assert_eq!(s[39], EncoderReading::Count(count as u16), "count {count}");
        }
    }

    #[test]
    fn shipped_decoder_crosses_the_wrap() {
        let s = run(4000.0, 20.0, 60);
        let counts: Vec<u16> = s.iter().filter_map(|x| x.count()).collect();
        assert!(counts.len() >= 40, "{}", counts.len());
        assert!(counts.iter().any(|c| *c > 4000) && counts.iter().any(|c| *c < 400));
        for w in counts.windows(2) {
            assert!(hal_imxrt::pure::encoder::circular_distance(w[0], w[1]) <= 45, "{w:?}");
        }
    }

    /// The one-pass read equals the reference read (a pass per question)
    /// at every sample: moving and resting angles across the wrap, noise,
    /// glitches, stuck lines, clock errors, jittered sampling.
    #[test]
    fn one_pass_read_equals_the_reference() {
        let mut rng = Rng::new(11);
        for k in 0..24 {
            let mut e = Encoder::new(rng.uniform(), (rng.uniform() - 0.5) * 400.0, 0.5 * (k % 3) as f64);
            let mut draws = Rng::new(100 + k);
            let mut noise = Rng::new(200 + k);
            let (mut c, mut v) = (rng.uniform() * 4096.0, 0.0);
            for tick in 1..20_000u64 {
                let t = tick as f64 * 600_000.0 + (draws.uniform() * 2.0 - 1.0) * 600.0;
                let prev = c;
                if draws.uniform() < 0.01 {
                    v = (draws.uniform() - 0.5) * 80.0;
                }
                c += v;
                if draws.uniform() < 0.002 {
                    e.glitch = Some(((draws.uniform() * 600.0) as i32 - 300, 1 + (draws.uniform() * 6.0) as u32));
                }
                if draws.uniform() < 0.001 {
                    e.line = [Line::Ok, Line::StuckLow, Line::StuckHigh][(draws.uniform() * 3.0) as usize % 3];
                }
                if draws.uniform() < 0.002 {
                    e.line = Line::Ok;
                }
                e.generate(t, prev, c, &mut noise);
                let mut r = e.clone();
                let (got, want) = (e.read(t), r.read_reference(t));
                assert_eq!(got, want, "encoder {k}, tick {tick}");
                assert_eq!((e.gated, e.capt, e.ief), (r.gated, r.capt, r.ief), "encoder {k}, tick {tick}");
            }
        }
    }

    #[test]
    fn stuck_low_is_lost() {
        let mut e = Encoder::new(0.1, 0.0, 0.0);
        let mut ch = EncoderChannel::new();
        let mut rng = Rng::new(1);
        e.line = Line::StuckLow;
        for k in 1..10 {
            let r = ch.update(e.sample(k as f64 * 600_000.0, 100.0, 100.0, &mut rng));
            assert!(matches!(r, EncoderReading::Lost(_)), "{r:?}");
        }
    }
}
