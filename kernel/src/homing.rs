//! Homing of one axis: fast seek, back-off, slow seek, zero, release.
//!
//! The sequencing across axes (J6; then J5, J4; then J1, J2, J3) is in the
//! kernel; this is the per-axis state machine. It only ever produces one of
//! three speeds (fast, slow, zero) in a known direction, and it reports the
//! tick at which the zero must be taken from the real encoder reading.

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
    /// Finished for this run.
    Done,
}

impl Phase {
    /// True in the phases where the axis moves.
    pub const fn is_moving(self) -> bool {
        matches!(self, Phase::FastSeek | Phase::BackOff | Phase::SlowSeek | Phase::Release)
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
}

/// One axis's homing state.
#[derive(Clone, Copy, Debug, PartialEq, Hash)]
pub struct AxisHoming<S> {
    phase: Phase,
    /// Position where the switch released (back-off and release phases).
    anchor: Option<S>,
    ticks: u32,
}

impl<S: Scalar> Default for AxisHoming<S> {
    fn default() -> Self {
        AxisHoming { phase: Phase::Idle, anchor: None, ticks: 0 }
    }
}

impl<S: Scalar> AxisHoming<S> {
    /// Current phase.
    pub fn phase(&self) -> Phase {
        self.phase
    }
    /// Puts the axis in (`true`) or out of a new run.
    pub fn reset(&mut self, in_run: bool) {
        *self = AxisHoming { phase: if in_run { Phase::Waiting } else { Phase::Idle }, anchor: None, ticks: 0 };
    }
    /// Starts moving if waiting (the kernel calls this when the axis's
    /// group is reached).
    pub fn start(&mut self) {
        if self.phase == Phase::Waiting {
            self.phase = Phase::FastSeek;
        }
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
        let mut out = HomingStep { velocity: S::ZERO, capture_zero: false, timed_out: None };
        if !self.phase.is_moving() {
            return out;
        }
        self.ticks = self.ticks.saturating_add(1);
        if self.ticks > p.timeout_ticks {
            out.timed_out = Some(self.phase);
            return out;
        }
        match self.phase {
            Phase::FastSeek => {
                if switch {
                    // Stop for this tick; reverse from the next one.
                    self.phase = Phase::BackOff;
                    self.anchor = None;
                } else {
                    out.velocity = p.fast_toward;
                }
            }
            Phase::BackOff => {
                if self.away(switch, x, p.backoff) {
                    self.phase = Phase::SlowSeek;
                } else {
                    out.velocity = p.fast_toward.neg();
                }
            }
            Phase::SlowSeek => {
                if switch {
                    out.capture_zero = true;
                    self.phase = Phase::Release;
                    self.anchor = None;
                } else {
                    out.velocity = p.slow_toward;
                }
            }
            Phase::Release => {
                if self.away(switch, x, p.backoff) {
                    self.phase = Phase::Done;
                } else {
                    out.velocity = p.fast_toward.neg();
                }
            }
            Phase::Idle | Phase::Waiting | Phase::Done => {}
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A one-axis plant: the switch is pressed at x <= -1.0 (negative seek).
    fn simulate(start: f32) -> (Vec<Phase>, u32, f32) {
        let p = HomingParams { fast_toward: -0.5f32, slow_toward: -0.05, backoff: 0.05, timeout_ticks: 20_000 };
        let mut h = AxisHoming::default();
        h.reset(true);
        h.start();
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
        assert_eq!(phases, vec![FastSeek, BackOff, SlowSeek, Release, Done]);
        assert_eq!(captured, 1);
        assert!((zero_at + 1.0).abs() < 1e-3, "{zero_at}");
    }

    #[test]
    fn starting_on_the_switch_backs_off_first() {
        let (phases, captured, _) = simulate(-1.01);
        use Phase::*;
        assert_eq!(phases, vec![FastSeek, BackOff, SlowSeek, Release, Done]);
        assert_eq!(captured, 1);
    }

    #[test]
    fn times_out_when_the_switch_never_comes() {
        let p = HomingParams { fast_toward: 1.0f32, slow_toward: 0.1, backoff: 0.05, timeout_ticks: 10 };
        let mut h = AxisHoming::default();
        h.reset(true);
        h.start();
        for _ in 0..10 {
            assert_eq!(h.step(false, 0.0, &p).velocity, 1.0);
        }
        let s = h.step(false, 0.0, &p);
        assert_eq!(s.timed_out, Some(Phase::FastSeek));
        assert_eq!(s.velocity, 0.0);
    }

    #[test]
    fn idle_and_waiting_axes_output_zero() {
        let p = HomingParams { fast_toward: 1.0f32, slow_toward: 0.1, backoff: 0.05, timeout_ticks: 10 };
        let mut h = AxisHoming::default();
        assert_eq!(h.step(true, 0.0, &p).velocity, 0.0);
        h.reset(true);
        assert_eq!(h.step(false, 0.0, &p).velocity, 0.0);
    }
}
