//! Estimate: integer 2 pi unwrapping and the alpha-beta observer.
//!
//! The seed's filter compares float angles with `M_PI` to detect the wrap.
//! Here the wrap is removed where it is exact: on the encoder's 12-bit count.
//! The difference of two readings is reduced modulo 4096 into
//! `[-2048, 2047]`, so a joint that crosses the 0 / 2 pi point keeps a
//! continuous multi-turn count with no rounding at all. The continuous joint
//! angle (count times a per-count scale, plus the homing zero) then feeds a
//! textbook alpha-beta filter.

use crate::config::COUNTS_PER_REV;
use crate::scalar::Scalar;

/// Mask of a 12-bit reading.
const MASK: u16 = 0x0fff;

/// Shortest signed difference `now - prev` of two 12-bit readings, in
/// `[-2048, 2047]`. Inputs are reduced modulo 4096 first, so it is total.
#[inline]
pub const fn wrap_delta(prev: u16, now: u16) -> i32 {
    let d = (now as i32).wrapping_sub(prev as i32);
    // (d + 2048) mod 4096 - 2048, for any d: `&` is a non-negative modulo.
    (d.wrapping_add(2048) & (COUNTS_PER_REV - 1)).wrapping_sub(2048)
}

/// Multi-turn count of one encoder, initialised from a real reading.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Unwrapper {
    last: u16,
    total: i32,
}

impl Unwrapper {
    /// Starts at the reading itself (never at 0, never at an offset alone:
    /// C++ defects 1 and 10).
    pub const fn new(count: u16) -> Self {
        let c = count & MASK;
        Unwrapper { last: c, total: c as i32 }
    }
    /// The step a new reading would make, without committing it.
    pub const fn delta(&self, count: u16) -> i32 {
        wrap_delta(self.last, count)
    }
    /// Accepts a reading; returns the step taken.
    pub fn update(&mut self, count: u16) -> i32 {
        let d = self.delta(count);
        self.last = count & MASK;
        self.total = self.total.saturating_add(d);
        d
    }
    /// Continuous count since power-on (reading at power-on included).
    pub const fn total(&self) -> i32 {
        self.total
    }
    /// The last accepted reading.
    pub const fn last(&self) -> u16 {
        self.last
    }
}

/// Gains of the alpha-beta observer, pre-scaled for one tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObserverGains<S> {
    /// Position correction gain.
    pub alpha: S,
    /// Velocity correction gain divided by the tick period (beta * tick_hz).
    pub beta_hz: S,
    /// Tick period (s).
    pub dt: S,
}

/// Alpha-beta observer state: position (rad) and velocity (rad/s).
#[derive(Clone, Copy, Debug, PartialEq, Hash)]
pub struct AlphaBeta<S> {
    /// Estimated position.
    pub x: S,
    /// Estimated velocity.
    pub v: S,
}

impl<S: Scalar> AlphaBeta<S> {
    /// At rest at the measured position.
    pub fn at(z: S) -> Self {
        AlphaBeta { x: z, v: S::ZERO }
    }
    /// One predict/correct step with measurement `z`; returns the residual.
    #[inline]
    pub fn step(&mut self, z: S, g: &ObserverGains<S>) -> S {
        let xp = self.x.plus(self.v.times(g.dt));
        let r = z.minus(xp);
        self.x = xp.plus(g.alpha.times(r));
        self.v = self.v.plus(g.beta_hz.times(r));
        r
    }
    /// Prediction only, for a tick without a valid measurement.
    #[inline]
    pub fn coast(&mut self, g: &ObserverGains<S>) {
        self.x = self.x.plus(self.v.times(g.dt));
    }
    /// Moves the estimate by `d` (a new homing zero) without a residual.
    pub fn shift(&mut self, d: S) {
        self.x = self.x.plus(d);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scalar::Fx;

    #[test]
    fn wrap_delta_is_shortest_path() {
        assert_eq!(wrap_delta(4095, 0), 1);
        assert_eq!(wrap_delta(0, 4095), -1);
        assert_eq!(wrap_delta(10, 20), 10);
        assert_eq!(wrap_delta(0, 2048), -2048);
        assert_eq!(wrap_delta(0, 2047), 2047);
        assert_eq!(wrap_delta(u16::MAX, 0), 1);
    }

    #[test]
    fn coast_predicts_and_last_is_the_reading() {
        let g = ObserverGains { alpha: 0.1f32, beta_hz: 5.0, dt: 0.001 };
        let mut o = AlphaBeta { x: 1.0f32, v: 2.0 };
        o.coast(&g);
        o.coast(&g);
        assert!((o.x - 1.004).abs() < 1e-6, "{}", o.x);
        assert_eq!(o.v, 2.0);
        let mut u = Unwrapper::new(4000);
        assert_eq!(u.last(), 4000);
        u.update(7);
        assert_eq!(u.last(), 7);
        assert_eq!(u.total(), 4103);
    }

    #[test]
    fn unwrapping_is_continuous_over_many_turns() {
        let mut u = Unwrapper::new(4000);
        let mut truth: i32 = 4000;
        for _ in 0..20_000 {
            truth += 37;
            u.update((truth.rem_euclid(4096)) as u16);
            assert_eq!(u.total(), truth);
        }
        for _ in 0..40_000 {
            truth -= 53;
            u.update((truth.rem_euclid(4096)) as u16);
            assert_eq!(u.total(), truth);
        }
    }

    fn converge<S: Scalar>() -> (f32, f32) {
        let g = ObserverGains { alpha: S::from_f32(0.1), beta_hz: S::from_f32(5.0), dt: S::from_f32(0.001) };
        let mut o = AlphaBeta::at(S::from_f32(0.5));
        // Ramp at 1 rad/s for 2 s.
        for k in 0..2000 {
            let z = 0.5 + k as f32 * 0.001;
            o.step(S::from_f32(z), &g);
        }
        (o.x.to_f32(), o.v.to_f32())
    }

    #[test]
    fn observer_tracks_a_ramp_in_both_variants() {
        for (x, v) in [converge::<f32>(), converge::<Fx>()] {
            assert!((x - 2.499).abs() < 1e-3, "x {x}");
            assert!((v - 1.0).abs() < 1e-2, "v {v}");
        }
    }

    #[test]
    fn observer_starts_at_rest_on_the_reading() {
        let o = AlphaBeta::at(1.25f32);
        assert_eq!((o.x, o.v), (1.25, 0.0));
    }
}
