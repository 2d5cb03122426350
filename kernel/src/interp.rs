//! Linear interpolation of 25-125 Hz targets into per-tick set-points.
//!
//! A new target starts a segment from the current set-point. Its length `n`
//! (ticks) is the *typical* interval between targets (the kernel passes the
//! median of recent intervals, bounded to the configured range), not the
//! interval that just elapsed: after a dropped packet the C++ firmware used
//! the doubled interval and stretched the next motion. The per-tick step is
//! saturated to the joint's speed limit, and every set-point is clamped into
//! the segment `[start, target]`, so the set-point never overshoots the target
//! (the f32 form `x + a (z - x)` can, by rounding) and reaches it exactly.
//! The feed-forward velocity is the set-point's actual displacement this tick
//! times the tick rate: it is zero once the target is reached.
//!
//! Arrival: a segment of `n` ticks over `d` reaches its target exactly within
//! `2 max(n, ceil(|d| / max_step)) + 2` ticks (the factor 2 covers the step's
//! rounding when `|d| / n` is a few LSB).

use crate::scalar::Scalar;

/// One axis's interpolator.
#[derive(Clone, Copy, Debug, PartialEq, Hash)]
pub struct Interpolator<S> {
    sp: S,
    start: S,
    target: S,
    step: S,
}

impl<S: Scalar> Interpolator<S> {
    /// Holds position `p` (re-synchronisation to a measured position).
    pub fn hold(p: S) -> Self {
        Interpolator { sp: p, start: p, target: p, step: S::ZERO }
    }
    /// Starts a segment to `target`, covered in `1 / inv_n` ticks, with the
    /// per-tick step limited to `max_step` (>= 0).
    pub fn retarget(&mut self, target: S, inv_n: S, max_step: S) {
        let delta = target.minus(self.sp);
        self.step = delta.times(inv_n).saturate(max_step);
        self.start = self.sp;
        self.target = target;
    }
    /// Advances one tick; returns `(set-point, feed-forward displacement
    /// this tick)`.
    #[inline]
    pub fn advance(&mut self) -> (S, S) {
        let stepped = self.sp.plus(self.step).clamp_between(self.start, self.target);
        // A step too small to change the set-point (it rounds to zero in
        // fixed point, or is under half an ulp of the set-point in f32) would
        // never arrive: snap to the target. Such a remainder is below
        // `n` ulps (about 1e-4 rad at 16 rad with n = 64), far below one
        // tick's speed limit.
        let next = S::select(stepped == self.sp, self.target, stepped);
        let moved = next.minus(self.sp);
        self.sp = next;
        (next, moved)
    }
    /// The current set-point.
    pub fn setpoint(&self) -> S {
        self.sp
    }
    /// The target of the current segment.
    pub fn target(&self) -> S {
        self.target
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scalar::Fx;

    fn run<S: Scalar>(from: f32, to: f32, n: u32, max_step: f32) -> (u32, f32) {
        let mut it = Interpolator::hold(S::from_f32(from));
        it.retarget(S::from_f32(to), S::from_f32(1.0 / n as f32), S::from_f32(max_step));
        let target = S::from_f32(to);
        let (lo, hi) = (from.min(to), from.max(to));
        for k in 1..=10_000u32 {
            let (sp, _) = it.advance();
            let f = sp.to_f32();
            assert!(f >= lo - 1e-6 && f <= hi + 1e-6, "overshoot {f}");
            if sp == target {
                return (k, f);
            }
        }
        panic!("never arrived");
    }

    #[test]
    fn reaches_target_exactly_in_n_or_n_plus_one_ticks() {
        for (a, b) in [(0.0, 0.1), (0.3, -0.7), (1.0, 1.0), (-2.0, -1.999_9)] {
            let (k, _) = run::<f32>(a, b, 10, 1.0);
            assert!(k <= 11, "f32 {a}->{b}: {k}");
            let (k, _) = run::<Fx>(a, b, 10, 1.0);
            assert!(k <= 11, "fx {a}->{b}: {k}");
        }
    }

    #[test]
    fn a_step_below_half_an_ulp_still_arrives() {
        // sp = 10: ulp 9.5e-7; a 1e-6 move in 10 ticks is 1e-7 per tick.
        let (k, f) = run::<f32>(10.0, 10.000_001, 10, 1.0);
        assert!(k <= 2, "{k}");
        assert_eq!(f, 10.000_001);
        let (k, _) = run::<Fx>(0.0, 0.000_000_1, 64, 1.0);
        assert!(k <= 2 * 64 + 2, "{k}");
    }

    #[test]
    fn step_is_limited_to_max_velocity() {
        // 1 rad at 3 mrad/tick takes ~334 ticks instead of 10.
        let (k, _) = run::<f32>(0.0, 1.0, 10, 0.003);
        assert!((333..=335).contains(&k), "{k}");
    }

    #[test]
    fn feed_forward_is_the_displacement_and_zero_at_rest() {
        let mut it = Interpolator::hold(0.0f32);
        it.retarget(0.01, 0.1, 1.0);
        let (_, ff) = it.advance();
        assert!((ff - 0.001).abs() < 1e-7);
        for _ in 0..20 {
            it.advance();
        }
        assert_eq!(it.advance(), (0.01, 0.0));
    }
}
