//! Per-axis numeric functions: saturation, control law, unwrapping,
//! observer, interpolator, target validation.

use crate::setup::{target, Sym, PROOF_CONFIG};
use kernel::config::AXES;
use kernel::control::control_law;
use kernel::interp::Interpolator;
use kernel::observer::{wrap_delta, AlphaBeta, ObserverGains, Unwrapper};
use kernel::Fx;

/// A joint index, with a cover so the assumption is not vacuous.
#[cfg_attr(not(kani), kani::loops)]
fn any_joint() -> usize {
    let j: u8 = kani::any::<u8>() % AXES as u8;
    kani::cover!(j == AXES as u8 - 1, "last joint reachable");
    usize::from(j)
}

/// Any value; for sampling, half of the draws are folded into `[lo, hi]`
/// so that in-range cases are common (a sampling hint, no symbolic value:
/// under Kani it is any value, which already includes every folded one).
pub(crate) fn any_mostly_in<S: Sym>(lo: S, hi: S) -> S {
    let v = S::any();
    #[cfg(not(kani))]
    if kani::runner::hint::<bool>() && v.is_finite() {
        return v.clamp_between(lo, hi);
    }
    #[cfg(kani)]
    let _ = (lo, hi);
    v
}

/// Any finite value in `[lo, hi]` (every such value is reachable: finite
/// values inside are kept, those outside are clamped to the ends).
#[cfg_attr(not(kani), kani::loops)]
pub(crate) fn any_in<S: Sym>(lo: S, hi: S) -> S {
    let v = S::any();
    kani::assume(v.is_finite());
    kani::cover!(true, "any_in: a finite draw passes the assumption");
    v.clamp_between(lo, hi)
}

/// The bounds `TargetLimits` accepts for joint `j`: each configured limit
/// widened outward by one f32 ulp before conversion (`next_down(limit_min)`,
/// `next_up(limit_max)`; in fixed point that is up to 2 LSB beyond the
/// converted limit). Exactly what the code guarantees, no tighter.
pub(crate) fn widened_limits<S: Sym>(j: usize) -> (S, S) {
    let c = &PROOF_CONFIG.joints[j];
    (S::from_f32(c.limit_min.next_down()), S::from_f32(c.limit_max.next_up()))
}

/// A target whose values are mostly within each joint's widened limits
/// (see [`any_mostly_in`]: out-of-range draws land on the widened bound
/// itself, the boundary a solver would find); symbolically any target.
#[cfg_attr(not(kani), kani::loops)]
pub(crate) fn any_target<S: Sym>() -> kernel::MotionTarget<S> {
    let mut t = target([S::ZERO; AXES]);
    for i in 0..AXES {
        let (lo, hi) = widened_limits::<S>(i);
        t.position[i] = any_mostly_in(lo, hi);
        let v = S::from_f32(PROOF_CONFIG.joints[i].max_velocity);
        t.velocity[i] = any_mostly_in(v.neg(), v);
    }
    t
}

/// SR-2, SR-3: saturation is finite, bounded, the identity inside the
/// bound, and zero for non-finite inputs. Returns whether the input was
/// non-finite: an antecedent only f32 has (fixed point has no non-finite
/// value), so only the f32 harness covers it.
#[cfg_attr(not(kani), kani::loops)]
fn saturation<S: Sym>() -> bool {
    let x = S::any();
    let limit = S::any();
    kani::assume(limit.is_finite() && limit >= S::ZERO);
    kani::cover!(limit > S::ZERO, "positive limit (the assumption is satisfiable)");
    let y = x.saturate(limit);
    assert!(y.is_finite());
    assert!(y.abs() <= limit);
    if !x.is_finite() {
        assert!(y == S::ZERO);
    } else if x >= limit.neg() && x <= limit {
        kani::cover!(x != S::ZERO, "non-zero input inside the bound");
        assert!(y == x);
    } else {
        kani::cover!(true, "finite input beyond the bound");
        assert!(y.abs() == limit);
    }
    !x.is_finite()
}

/// Footprint: 2 symbolic values, 0 ticks (x and the limit).
#[kani::proof]
fn saturation_is_finite_and_bounded_f32() {
    let non_finite = saturation::<f32>();
    kani::cover!(non_finite, "non-finite input");
}
/// Footprint: 2 symbolic values, 0 ticks (x and the limit).
#[kani::proof]
fn saturation_is_finite_and_bounded_fx() {
    // No non-finite input exists: nothing to cover beyond the helper's.
    saturation::<Fx>();
}

/// SR-2, SR-3: the control law's output is finite and within the joint's
/// velocity limit for every input; non-finite anything gives zero, not ok.
/// Returns (a non-finite input, not ok): antecedents only f32 has, covered
/// by its harness.
#[cfg_attr(not(kani), kani::loops)]
fn control<S: Sym>() -> (bool, bool) {
    let j = any_joint();
    let cfg = &PROOF_CONFIG.joints[j];
    let (sp, ff, x) = (S::any(), S::any(), S::any());
    let vmax = S::from_f32(cfg.max_velocity);
    let (v, ok) = control_law(sp, ff, x, S::from_f32(cfg.kp), vmax, S::from_f32(PROOF_CONFIG.deadband));
    assert!(v.is_finite());
    assert!(v.abs() <= vmax);
    let non_finite = !(sp.is_finite() && ff.is_finite() && x.is_finite());
    if non_finite {
        assert!(!ok);
    }
    kani::cover!(ok && v != S::ZERO, "ok and moving");
    if !ok {
        assert!(v == S::ZERO);
    }
    (non_finite, !ok)
}

/// Footprint: 4 symbolic values, 0 ticks (the joint, set-point, feed-forward, estimate).
#[kani::proof]
fn control_law_is_bounded_f32() {
    let (non_finite, not_ok) = control::<f32>();
    kani::cover!(non_finite, "a non-finite input (antecedent)");
    kani::cover!(not_ok, "not ok (antecedent)");
}
/// Footprint: 4 symbolic values, 0 ticks (the joint, set-point, feed-forward, estimate).
#[kani::proof]
fn control_law_is_bounded_fx() {
    // Fixed point has no non-finite value and its law saturates instead of
    // failing: for it these antecedents are empty by construction.
    control::<Fx>();
}

/// SR-12: the unwrapped count moves by exactly the shortest signed
/// difference, so consecutive readings are continuous modulo 4096.
/// Footprint: 2 symbolic values, 0 ticks (two counts).
#[kani::proof]
fn unwrapping_is_exact_and_continuous() {
    let first: u16 = kani::any();
    let next: u16 = kani::any();
    let mut u = Unwrapper::new(first);
    let before = u.total();
    let d = wrap_delta(first & 0xfff, next);
    kani::cover!(d <= -2000, "nearly half a turn backward");
    kani::cover!(d >= 2000, "nearly half a turn forward");
    assert!((-2048..=2047).contains(&d));
    u.update(next);
    assert!(u.total() == before + d);
    assert!((i32::from(first & 0xfff) + d).rem_euclid(4096) == i32::from(next & 0xfff));
    // Starting point is the reading itself (SR-1).
    assert!(before == i32::from(first & 0xfff));
}

/// The observer's corrected position lies between its prediction and the
/// measurement (0 < alpha < 1): a step never amplifies a residual.
#[cfg_attr(not(kani), kani::loops)]
fn observer<S: Sym>() {
    let g = ObserverGains {
        alpha: S::from_f32(PROOF_CONFIG.alpha()),
        beta_hz: S::from_f32(PROOF_CONFIG.beta() * PROOF_CONFIG.tick_hz as f32),
        dt: S::from_f32(1.0 / PROOF_CONFIG.tick_hz as f32),
    };
    let (b32, b64) = (S::from_f32(32.0), S::from_f32(64.0));
    // Inside the kernel's plausibility bounds (|x| < 32 rad, |v| < 64 rad/s);
    // beyond them the kernel faults instead.
    let (x, v, z) = (any_in(b32.neg(), b32), any_in(b64.neg(), b64), any_in(b32.neg(), b32));
    kani::cover!(z != x, "non-zero residual");
    let mut o = AlphaBeta { x, v };
    let xp = x.plus(v.times(g.dt));
    o.step(z, &g);
    assert!(o.x.is_finite() && o.v.is_finite());
    let lo = xp.min(z);
    let hi = xp.max(z);
    // Fixed point is exact to one LSB here; f32 to a few ulps of 32.
    let slack = S::from_f32(1e-5);
    assert!(o.x >= lo.minus(slack) && o.x <= hi.plus(slack));
}

/// Footprint: 3 symbolic values, 0 ticks (x, v, z).
#[kani::proof]
fn observer_correction_is_between_prediction_and_measurement_f32() {
    observer::<f32>();
}
/// Footprint: 3 symbolic values, 0 ticks (x, v, z).
#[kani::proof]
fn observer_correction_is_between_prediction_and_measurement_fx() {
    observer::<Fx>();
}

/// SR-18, SR-27: one set-point step from any state (set-point and target
/// in +-16 rad, velocity and cruising speed within the joint's limit):
/// the velocity stays within the limit and changes by at most one tick's
/// acceleration (plus the landing allowance), and a set-point moving toward
/// its target never passes it. A one-step invariant: no loop, no unwinding.
#[cfg_attr(not(kani), kani::loops)]
fn interpolator<S: Sym>() {
    let j = any_joint();
    let jc = &PROOF_CONFIG.joints[j];
    let k = kernel::interp::joint_profile::<S>(jc, PROOF_CONFIG.tick_hz);
    let lim = S::from_f32(16.0);
    let (sp, to) = (any_in(lim.neg(), lim), any_in(lim.neg(), lim));
    let vel = any_in(k.vmax.neg(), k.vmax);
    let speed = any_in(S::ZERO, k.vmax);
    kani::cover!(sp.abs() == lim, "set-point at the edge of the range");
    kani::cover!(sp != to && vel == S::ZERO, "a move from rest");
    kani::cover!(vel.abs() == k.vmax, "at full speed");
    kani::cover!((to > sp && vel < S::ZERO) || (to < sp && vel > S::ZERO), "moving away from the target");
    let mut it = Interpolator::from_parts(sp, to, vel, speed, &k);
    let (sp2, vel2) = it.advance(&k);
    // The landing may change the velocity by dv plus 2 eps per tick.
    let slack = k.eps.times_int(k.tick_hz).times_int(2).plus(S::from_f32(1e-5));
    assert!(vel2.abs() <= k.vmax.plus(slack), "speed above the limit");
    assert!(vel2.minus(vel).abs() <= k.dv.plus(slack), "acceleration above the limit");
    // Approaching a target it can stop at: moving toward it (or at rest on
    // it) with the braking distance from its speed (plus one tick's travel)
    // inside the distance left. Such a set-point never passes the target.
    // (A target placed inside the braking distance is passed and met again
    // from the other side: that overshoot stays inside the earlier target's
    // braking distance; the kernel's tests bound it.)
    let dist = to.minus(sp).abs();
    let approaching = (to > sp && vel >= S::ZERO) || (to < sp && vel <= S::ZERO) || (to == sp && vel == S::ZERO);
    let reach = vel.times(vel).times(k.inv_2a).plus(vel.abs().times(k.dt)).plus(k.eps) <= dist;
    kani::cover!(approaching && !reach, "a target inside the braking distance");
    if approaching && (reach || vel == S::ZERO) {
        kani::cover!(sp2 == to, "lands exactly");
        assert!(sp2.minus(sp).abs() <= dist, "passed the target");
    }
}

/// SR-18, the set-point guarantee's one-tick lemma (the SMT step proves
/// the same statement): from any state whose set-point lies in its interval
/// `[lo, hi]` (set-point, target, interval in +-16 rad, velocity and
/// cruising speed within the joint's limits), one tick keeps the set-point
/// in `[lo, hi]`; and accepting a target `x` there gives an interval that
/// holds the set-point and `x` and lies inside the span of `[lo, hi]` and
/// `x`.
#[cfg_attr(not(kani), kani::loops)]
fn setpoint_guarantee<S: Sym>() {
    let j = any_joint();
    let k = kernel::interp::joint_profile::<S>(&PROOF_CONFIG.joints[j], PROOF_CONFIG.tick_hz);
    let lim = S::from_f32(16.0);
    let (lo, hi) = (any_in(lim.neg(), lim), any_in(lim.neg(), lim));
    kani::assume(lo <= hi);
    kani::cover!(lo == hi, "at rest on its interval");
    let (sp, to, x) = (any_in(lo, hi), any_in(lo, hi), any_in(lim.neg(), lim));
    let vel = any_in(k.vmax.neg(), k.vmax);
    let speed = any_in(S::ZERO, k.vmax);
    let mut it = Interpolator::from_parts_within(sp, to, vel, speed, lo, hi, &k);
    let mut moved = it;
    let (sp2, _) = moved.advance(&k);
    assert!(sp2 >= lo && sp2 <= hi, "the set-point left its interval");
    it.retarget(x, speed, &k);
    let (lo2, hi2) = it.bounds();
    assert!(lo2 <= sp && sp <= hi2 && lo2 <= x && x <= hi2, "the new interval misses the set-point or the target");
    assert!(lo2 >= lo.min(x) && hi2 <= hi.max(x), "the new interval reaches beyond the old one and the target");
}

/// Footprint: 8 symbolic values, 0 ticks (the joint, the interval's ends, set-point, target, estimate, velocity, speed).
#[kani::proof]
fn setpoint_guarantee_one_tick_f32() {
    setpoint_guarantee::<f32>();
}
/// Footprint: 8 symbolic values, 0 ticks (the joint, the interval's ends, set-point, target, estimate, velocity, speed).
#[kani::proof]
fn setpoint_guarantee_one_tick_fx() {
    setpoint_guarantee::<Fx>();
}

/// Footprint: 5 symbolic values, 0 ticks (the joint, set-point, target, velocity, speed).
#[kani::proof]
fn interpolator_step_is_acceleration_limited_and_never_passes_f32() {
    interpolator::<f32>();
}
/// Footprint: 5 symbolic values, 0 ticks (the joint, set-point, target, velocity, speed).
#[kani::proof]
fn interpolator_step_is_acceleration_limited_and_never_passes_fx() {
    interpolator::<Fx>();
}

/// SR-17: a target the kernel accepts is finite, inside every joint's
/// limits as `TargetLimits` widens them (one f32 ulp outward: see
/// [`widened_limits`]; the widening is drawn by
/// `tests::the_widened_limit_is_the_exact_boundary`), with every velocity
/// within its limit.
#[cfg_attr(not(kani), kani::loops)]
fn validation<S: Sym>() {
    // Validation reads the configuration's limits only (`TargetLimits`,
    // built by `Kernel::new`), not the state: a fresh kernel, no tick.
    let (k, _) = crate::setup::new_kernel::<S>(&crate::setup::PROOF_VALIDATED);
    let t = any_target::<S>();
    let ok = k.validate(&t).is_ok();
    kani::cover!(ok, "some target accepted (antecedent)");
    kani::cover!(!ok, "some target rejected");
    let below = (0..AXES).any(|i| t.position[i] < S::from_f32(PROOF_CONFIG.joints[i].limit_min));
    kani::cover!(ok && below, "accepted below a configured limit: the widening is reachable");
    if ok {
        for i in 0..AXES {
            let j = &PROOF_CONFIG.joints[i];
            let (lo, hi) = widened_limits::<S>(i);
            assert!(t.position[i].is_finite() && t.velocity[i].is_finite());
            assert!(t.position[i] >= lo && t.position[i] <= hi);
            assert!(t.velocity[i].abs() <= S::from_f32(j.max_velocity));
        }
    }
}

/// Footprint: 12 symbolic values, 0 ticks (a target (12 values)).
#[kani::proof]
#[kani::unwind(7)] // Kernel::new, any_target and the checks: 6 axes
fn accepted_targets_are_within_limits_f32() {
    validation::<f32>();
}
/// Footprint: 12 symbolic values, 0 ticks (a target (12 values)).
#[kani::proof]
#[kani::unwind(7)] // as the f32 harness
fn accepted_targets_are_within_limits_fx() {
    validation::<Fx>();
}

#[cfg(all(test, not(kani)))]
mod tests {
    use super::*;
    use kernel::{MotionTarget, Scalar, TargetLimits};

    fn accepted<S: Scalar>(axis: usize, p: S) -> bool {
        let mut t: MotionTarget<S> = target([S::ZERO; AXES]);
        t.position[axis] = p;
        TargetLimits::<S>::new(&crate::setup::PROOF_VALIDATED).check(&t).is_ok()
    }

    /// The boundary the harness asserts, drawn: for every joint the widened
    /// bound is accepted and the next value beyond it is not. f32: exactly
    /// one ulp beyond the configured limit. Fixed point: one f32 ulp of the
    /// limit in LSB (2 LSB for |limit| in [1, 2), 4 in [2, 4), 8 in [4, 8)),
    /// +-1 LSB of conversion rounding, beyond the converted limit.
    #[test]
    fn the_widened_limit_is_the_exact_boundary() {
        for (i, j) in PROOF_CONFIG.joints.iter().enumerate() {
            let (lo, hi) = (j.limit_min, j.limit_max);
            assert!(accepted(i, lo.next_down()) && !accepted(i, lo.next_down().next_down()), "J{} f32 low", i + 1);
            assert!(accepted(i, hi.next_up()) && !accepted(i, hi.next_up().next_up()), "J{} f32 high", i + 1);
            let (flo, fhi) = widened_limits::<Fx>(i);
            let lsb = Fx::from_bits(1);
            assert!(accepted(i, flo) && !accepted(i, flo - lsb), "J{} fixed low", i + 1);
            assert!(accepted(i, fhi) && !accepted(i, fhi + lsb), "J{} fixed high", i + 1);
            let beyond_lo = (Fx::from_f32(lo) - flo).to_bits();
            let beyond_hi = (fhi - Fx::from_f32(hi)).to_bits();
            let ulp_lsb = |a: f32, b: f32| ((f64::from(a) - f64::from(b)).abs() * f64::from(1u32 << 24)).round() as i32;
            let (ulo, uhi) = (ulp_lsb(lo, lo.next_down()), ulp_lsb(hi, hi.next_up()));
            assert!(
                (beyond_lo - ulo).abs() <= 1 && (beyond_hi - uhi).abs() <= 1,
                "J{}: {beyond_lo}/{beyond_hi} LSB vs {ulo}/{uhi}",
                i + 1
            );
            println!(
                "J{}: accepted f32 [{:e}, {:e}], fixed point {beyond_lo}/{beyond_hi} LSB beyond",
                i + 1,
                lo.next_down(),
                hi.next_up()
            );
        }
    }
}
