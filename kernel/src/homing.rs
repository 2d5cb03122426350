//! Homing of one axis: fast seek, back-off, slow seek, zero, release,
//! settle.
//!
//! The sequencing across axes (J6; then J5, J4; then J1, J2, J3) is in the
//! kernel; this is the per-axis state machine. It moves toward one of three
//! speeds (fast, slow, zero) in a known direction, changing its velocity by
//! at most the joint's acceleration per tick (the stop at the switch in the
//! seeks is immediate); it reports the tick at which the zero must be taken
//! from the real encoder reading, and it bounds the travel of every phase
//! (a dead switch or a reversed motor faults before the hard stop).

use crate::scalar::Scalar;

/// Phase of one axis's homing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Phase {
    /// Not part of the current homing run.
    Idle,
    /// Part of the run, waiting for the axes it depends on.
    Waiting,
    /// Moving toward the switch at the fast speed.
    FastSeek,
    /// Moving away until the switch releases, then the back-off distance.
    BackOff,
    /// Moving toward the switch at the slow speed.
    SlowSeek,
    /// Zero taken; moving off the switch by the back-off distance.
    Release,
    /// Decelerating to rest, then resting for the settle time.
    Settle,
    /// Finished for this run.
    Done,
}

impl Phase {
    /// True in the phases where the axis moves.
    pub const fn is_moving(self) -> bool {
        matches!(self, Phase::FastSeek | Phase::BackOff | Phase::SlowSeek | Phase::Release | Phase::Settle)
    }
}

/// Homing parameters of one axis, in the kernel's scalar type.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HomingParams<S> {
    /// Fast seek velocity, signed toward the switch.
    pub fast_toward: S,
    /// Slow seek velocity, signed toward the switch.
    pub slow_toward: S,
    /// Back-off distance past the release point (> 0).
    pub backoff: S,
    /// Ticks allowed for the whole sequence of this axis.
    pub timeout_ticks: u32,
    /// Largest velocity change per tick (rad/s).
    pub dv: S,
    /// Largest travel of the fast seek (rad).
    pub max_travel: S,
    /// Largest travel of any other phase (rad).
    pub phase_travel: S,
    /// Ticks at rest before the axis is done.
    pub settle_ticks: u32,
}

/// What one homing tick asks of the kernel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HomingStep<S> {
    /// Velocity to apply this tick.
    pub velocity: S,
    /// Take the zero from the encoder reading of this tick.
    pub capture_zero: bool,
    /// The axis ran out of time in this phase.
    pub timed_out: Option<Phase>,
    /// The axis travelled farther than allowed in this phase.
    pub too_far: Option<Phase>,
}

/// One axis's homing state.
#[derive(Clone, Copy, Debug, PartialEq, Hash)]
pub struct AxisHoming<S> {
    phase: Phase,
    /// Position where the switch released (back-off and release phases).
    anchor: Option<S>,
    ticks: u32,
    /// Velocity of the last tick (rad/s).
    vel: S,
    /// Position where the current phase started (travel bound).
    origin: S,
    /// Ticks at rest in Settle.
    rest: u32,
    /// A tighter fast-seek travel bound for this run (a joint homed
    /// before), if any.
    fast_bound: Option<S>,
}

impl<S: Scalar> Default for AxisHoming<S> {
    fn default() -> Self {
        AxisHoming {
            phase: Phase::Idle,
            anchor: None,
            ticks: 0,
            vel: S::ZERO,
            origin: S::ZERO,
            rest: 0,
            fast_bound: None,
        }
    }
}

impl<S: Scalar> AxisHoming<S> {
    /// Current phase.
    pub fn phase(&self) -> Phase {
        self.phase
    }
    /// Puts the axis in (`true`) or out of a new run.
    pub fn reset(&mut self, in_run: bool) {
        *self = AxisHoming { phase: if in_run { Phase::Waiting } else { Phase::Idle }, ..AxisHoming::default() };
    }
    /// Starts moving if waiting (the kernel calls this when the axis's
    /// group is reached); `x` is the estimated position.
    pub fn start(&mut self, x: S) {
        if self.phase == Phase::Waiting {
            self.enter(Phase::FastSeek, x);
        }
    }
    /// Bounds this run's fast seek to `bound` (rad) if that is tighter than
    /// the configured bound.
    pub fn limit_travel(&mut self, bound: S) {
        self.fast_bound = Some(bound);
    }
    /// The velocity of the last tick.
    pub fn velocity(&self) -> S {
        self.vel
    }
    fn enter(&mut self, phase: Phase, x: S) {
        self.phase = phase;
        self.anchor = None;
        self.origin = x;
    }
    /// Accelerates toward `want` by at most `dv`.
    fn ramp(&mut self, want: S, dv: S) -> S {
        self.vel = crate::ramp::toward(self.vel, want, dv);
        self.vel
    }

    /// Moves away from the switch until it has released and the axis is
    /// `backoff` past the release point; returns true when finished.
    fn away(&mut self, switch: bool, x: S, backoff: S) -> bool {
        match (switch, self.anchor) {
            (true, _) => {
                self.anchor = None;
                false
            }
            (false, None) => {
                self.anchor = Some(x);
                false
            }
            (false, Some(a)) => x.minus(a).abs() >= backoff,
        }
    }

    /// One tick. `switch` is this axis's debounced limit input, `x` its
    /// estimated position.
    pub fn step(&mut self, switch: bool, x: S, p: &HomingParams<S>) -> HomingStep<S> {
        let mut out = HomingStep { velocity: S::ZERO, capture_zero: false, timed_out: None, too_far: None };
        if !self.phase.is_moving() {
            self.vel = S::ZERO;
            return out;
        }
        self.ticks = self.ticks.saturating_add(1);
        if self.ticks > p.timeout_ticks {
            out.timed_out = Some(self.phase);
            self.vel = S::ZERO;
            return out;
        }
        let fast = self.fast_bound.map_or(p.max_travel, |b| b.min(p.max_travel));
        let bound = if self.phase == Phase::FastSeek { fast } else { p.phase_travel };
        if x.minus(self.origin).abs() > bound {
            out.too_far = Some(self.phase);
            self.vel = S::ZERO;
            return out;
        }
        out.velocity = match self.phase {
            Phase::FastSeek if switch => {
                // Stop at the switch (immediate); reverse from the next tick.
                self.enter(Phase::BackOff, x);
                self.vel = S::ZERO;
                S::ZERO
            }
            Phase::FastSeek => self.ramp(p.fast_toward, p.dv),
            Phase::BackOff => {
                if self.away(switch, x, p.backoff) {
                    self.enter(Phase::SlowSeek, x);
                    self.ramp(p.slow_toward, p.dv)
                } else {
                    self.ramp(p.fast_toward.neg(), p.dv)
                }
            }
            Phase::SlowSeek if switch => {
                out.capture_zero = true;
                self.enter(Phase::Release, x);
                self.vel = S::ZERO;
                S::ZERO
            }
            Phase::SlowSeek => self.ramp(p.slow_toward, p.dv),
            Phase::Release => {
                if self.away(switch, x, p.backoff) {
                    self.enter(Phase::Settle, x);
                    self.ramp(S::ZERO, p.dv)
                } else {
                    self.ramp(p.fast_toward.neg(), p.dv)
                }
            }
            Phase::Settle => {
                let v = self.ramp(S::ZERO, p.dv);
                if v == S::ZERO {
                    self.rest = self.rest.saturating_add(1);
                    if self.rest >= p.settle_ticks {
                        self.phase = Phase::Done;
                    }
                }
                v
            }
            Phase::Idle | Phase::Waiting | Phase::Done => S::ZERO,
        };
        out
    }

    /// Shifts the positions this axis remembers by `d` (the zero was taken:
    /// the estimate moved by `d`).
    pub fn shift(&mut self, d: S) {
        self.origin = self.origin.plus(d);
        self.anchor = self.anchor.map(|a| a.plus(d));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A one-axis plant: the switch is pressed at x <= -1.0 (negative seek).
    fn simulate(start: f32) -> (Vec<Phase>, u32, f32) {
        let p = params(-0.5, -0.05, 20_000);
        let mut h = AxisHoming::default();
        h.reset(true);
        h.start(start);
        let mut x = start;
        let mut phases = vec![h.phase()];
        let mut captured = 0;
        let mut zero_at = f32::NAN;
        for _ in 0..20_000 {
            let s = h.step(x <= -1.0, x, &p);
            assert!(s.timed_out.is_none());
            if s.capture_zero {
                captured += 1;
                zero_at = x;
            }
            x += s.velocity * 0.001;
            if phases.last() != Some(&h.phase()) {
                phases.push(h.phase());
            }
            if h.phase() == Phase::Done {
                break;
            }
        }
        (phases, captured, zero_at)
    }

    #[test]
    fn full_sequence_in_order_with_one_zero_capture() {
        let (phases, captured, zero_at) = simulate(0.3);
        use Phase::*;
        assert_eq!(phases, vec![FastSeek, BackOff, SlowSeek, Release, Settle, Done]);
        assert_eq!(captured, 1);
        assert!((zero_at + 1.0).abs() < 1e-3, "{zero_at}");
    }

    #[test]
    fn starting_on_the_switch_backs_off_first() {
        let (phases, captured, _) = simulate(-1.01);
        use Phase::*;
        assert_eq!(phases, vec![FastSeek, BackOff, SlowSeek, Release, Settle, Done]);
        assert_eq!(captured, 1);
    }

    fn params(fast: f32, slow: f32, timeout_ticks: u32) -> HomingParams<f32> {
        HomingParams {
            fast_toward: fast,
            slow_toward: slow,
            backoff: 0.05,
            timeout_ticks,
            dv: 0.06,
            max_travel: 3.0,
            phase_travel: 0.3,
            settle_ticks: 50,
        }
    }

    #[test]
    fn times_out_when_the_switch_never_comes() {
        let p = params(1.0, 0.1, 10);
        let mut h = AxisHoming::default();
        h.reset(true);
        h.start(0.0);
        for _ in 0..10 {
            assert!(h.step(false, 0.0, &p).velocity > 0.0);
        }
        let s = h.step(false, 0.0, &p);
        assert_eq!(s.timed_out, Some(Phase::FastSeek));
        assert_eq!(s.velocity, 0.0);
    }

    #[test]
    fn the_seek_accelerates_gradually_and_its_travel_is_bounded() {
        let p = params(2.0, 0.1, 100_000);
        let mut h = AxisHoming::default();
        h.reset(true);
        h.start(0.0);
        let (mut x, mut prev) = (0.0f32, 0.0f32);
        for n in 0.. {
            let s = h.step(false, x, &p);
            if let Some(phase) = s.too_far {
                // A fault: the kernel zeroes every output at once.
                assert_eq!(phase, Phase::FastSeek);
                assert!(x > 3.0 && x < 3.01, "{x}");
                assert_eq!(s.velocity, 0.0);
                break;
            }
            assert!((s.velocity - prev).abs() <= 0.0601, "{prev} -> {}", s.velocity);
            assert!(n < 10_000);
            prev = s.velocity;
            x += s.velocity * 0.001;
        }
    }

    #[test]
    fn idle_and_waiting_axes_output_zero() {
        let p = params(1.0, 0.1, 10);
        let mut h = AxisHoming::default();
        assert_eq!(h.step(true, 0.0, &p).velocity, 0.0);
        h.reset(true);
        assert_eq!(h.step(false, 0.0, &p).velocity, 0.0);
    }
}
