//! The properties, stated over the kernel's own generic functions
//! instantiated with a symbolic scalar. Each function declares its inputs
//! (any bit pattern), states its preconditions with [`B::assume`], runs the
//! kernel code, and returns the property as a Boolean term.
//!
//! Constants (gains, limits, profiles) are built by the kernel's own code
//! from `kernel::config::PAROL6`, exactly as `Params::new` does.

use crate::sym::{Sym, B};
use kernel::config::{ArmConfig, PAROL6};
use kernel::control::control_law;
use kernel::interp::{joint_profile as joint_profile_of, Interpolator, Profile};
use kernel::observer::{AlphaBeta, ObserverGains};
use kernel::ramp;
use kernel::Scalar;

/// The configuration the proofs instantiate (the shipped one).
pub const CONFIG: &ArmConfig = &PAROL6;

/// `lo <= x <= hi` and finite.
fn within<S: Sym>(x: S, lo: S, hi: S) -> B {
    B::all(&[x.t_finite(), lo.t_le(x), x.t_le(hi)])
}

/// `Scalar::saturate` (SR-2, SR-3): for every `x` (NaN and infinities
/// included) and every finite `limit >= 0`: the result is finite, within
/// `[-limit, limit]`, equal to `x` when `x` is inside, `+-limit` when a
/// finite `x` is outside, `+0` for a non-finite `x`. `f` is the function
/// under proof (`Scalar::saturate`; the tests pass broken ones).
pub fn saturate<S: Sym>(f: fn(S, S) -> S) -> Vec<B> {
    let x = S::var("x");
    let limit = S::var("limit");
    limit.t_finite().and(S::ZERO.t_le(limit)).assume();
    let y = f(x, limit);
    vec![
        y.t_finite(),
        y.abs().t_le(limit),
        x.t_finite().not().implies(y.t_same(S::ZERO)),
        within(x, limit.neg(), limit).implies(y.t_eq(x)),
        x.t_finite().and(within(x, limit.neg(), limit).not()).implies(y.abs().t_eq(limit)),
    ]
}

/// `Scalar::clamp_between` (the soft-stop ramp, the homing ramp and the
/// output acceleration limit clamp with it): for every `x` (NaN included)
/// and finite `a`, `b` in either order, the result is finite, inside the
/// closed interval they span, and `x` itself when `x` is inside.
pub fn clamp_between<S: Sym>() -> Vec<B> {
    let (x, a, b) = (S::var("x"), S::var("a"), S::var("b"));
    a.t_finite().and(b.t_finite()).assume();
    let y = x.clamp_between(a, b);
    let inside = |v: S| (a.t_le(v).and(v.t_le(b))).or(b.t_le(v).and(v.t_le(a)));
    vec![y.t_finite(), inside(y), x.t_finite().and(inside(x)).implies(y.t_eq(x))]
}

/// The control law's constants for joint `j`.
pub fn control_constants<S: Sym>(j: usize) -> (S, S, S) {
    let jc = &CONFIG.joints[j];
    (S::from_f32(jc.kp), S::from_f32(jc.max_velocity), S::from_f32(CONFIG.deadband))
}

/// `control::control_law` (SR-2, SR-3) with joint `j`'s gain, speed limit
/// and the deadband: for every set-point, feed-forward and estimate (NaN
/// and infinities included) the output is finite and `|v| <= vmax`; any
/// non-finite input gives `ok == false`; `!ok` gives exactly `+0`.
pub fn control<S: Sym>(j: usize) -> Vec<B> {
    let (kp, vmax, deadband) = control_constants::<S>(j);
    let (sp, ff, x) = (S::var("setpoint"), S::var("feed_forward"), S::var("estimate"));
    let (v, ok) = control_law(sp, ff, x, kp, vmax, deadband);
    let ok = if ok { B::TRUE } else { B::FALSE };
    let inputs_finite = B::all(&[sp.t_finite(), ff.t_finite(), x.t_finite()]);
    vec![v.t_finite(), v.abs().t_le(vmax), inputs_finite.not().implies(ok.not()), ok.not().implies(v.t_same(S::ZERO))]
}

/// The observer gains `Params::new` builds.
pub fn gains<S: Sym>() -> ObserverGains<S> {
    ObserverGains {
        alpha: S::from_f32(CONFIG.alpha()),
        beta_hz: S::from_f32(CONFIG.beta() * CONFIG.tick_hz as f32),
        dt: S::from_f32(1.0 / CONFIG.tick_hz as f32),
    }
}

/// The kernel's plausibility bounds (`POSITION_ABS_MAX`, and
/// `VELOCITY_ABS_MAX` = 64 rad/s): beyond them it faults instead.
fn plausible<S: Sym>(x: S, v: S) -> B {
    let (p, w) = (S::from_f32(kernel::config::POSITION_ABS_MAX), S::from_f32(64.0));
    within(x, p.neg(), p).and(within(v, w.neg(), w))
}

/// `AlphaBeta::step`: the corrected position lies between the prediction
/// `x + v dt` and the measurement `z`, within `slack`, and the new state
/// is finite, for `x`, `z` within the position bound and `v` within the
/// velocity bound (as the Kani harness states it). With `all_inputs`
/// (fixed point: no bound at all, every bit pattern) the precondition is
/// dropped.
pub fn observer_between<S: Sym>(slack: f32, all_inputs: bool) -> Vec<B> {
    let g = gains::<S>();
    let (x, v, z) = (S::var("x"), S::var("v"), S::var("z"));
    if !all_inputs {
        plausible(x, v).and(plausible(z, S::ZERO)).assume();
    }
    let xp = x.plus(v.times(g.dt));
    let mut o = AlphaBeta { x, v };
    o.step(z, &g);
    let slack = S::from_f32(slack);
    let (lo, hi) = (xp.min(z).minus(slack), xp.max(z).plus(slack));
    vec![o.x.t_finite(), o.v.t_finite(), lo.t_le(o.x), o.x.t_le(hi)]
}

/// `AlphaBeta::step` and `coast` never absorb a NaN or an infinity: for
/// every input, if any of `x`, `v`, `z` is not finite then the new `x` or
/// `v` is not (so the kernel's plausibility check sees it).
pub fn observer_non_finite<S: Sym>(coast: bool) -> Vec<B> {
    let g = gains::<S>();
    let (x, v, z) = (S::var("x"), S::var("v"), S::var("z"));
    let mut o = AlphaBeta { x, v };
    let bad = if coast {
        o.coast(&g);
        x.t_finite().and(v.t_finite()).not()
    } else {
        o.step(z, &g);
        B::all(&[x.t_finite(), v.t_finite(), z.t_finite()]).not()
    };
    vec![bad.implies(o.x.t_finite().and(o.v.t_finite()).not())]
}

/// `AlphaBeta::coast`: from a plausible state the prediction is finite,
/// keeps the velocity bit for bit, and moves the position by at most
/// 64 rad/s times one tick (plus `slack` for rounding).
pub fn observer_coast<S: Sym>(slack: f32) -> Vec<B> {
    let g = gains::<S>();
    let (x, v) = (S::var("x"), S::var("v"));
    plausible(x, v).assume();
    let mut o = AlphaBeta { x, v };
    o.coast(&g);
    let bound = S::from_f32(64.0).times(g.dt).plus(S::from_f32(slack));
    vec![o.x.t_finite(), o.v.t_same(v), o.x.minus(x).abs().t_le(bound)]
}

/// Joint `j`'s set-point profile, built as `Params::new` builds it (the
/// kernel's own `profile` at the joint's `setpoint_acceleration`).
pub fn joint_profile<S: Scalar>(j: usize) -> Profile<S> {
    joint_profile_of::<S>(&CONFIG.joints[j], CONFIG.tick_hz)
}

/// A set-point step under proof: `(set-point, target, velocity, cruising
/// speed, profile) -> (new set-point, new velocity)`.
pub type Step<S> = fn(S, S, S, S, &Profile<S>) -> (S, S);

/// The kernel's step: `Interpolator::advance` from that state.
pub fn advance<S: Scalar>(sp: S, to: S, vel: S, speed: S, k: &Profile<S>) -> (S, S) {
    Interpolator::from_parts(sp, to, vel, speed, k).advance(k)
}

/// The slack of the interpolator's bounds: the Kani harness's
/// (`proofs/src/numeric.rs`): `2 eps tick_hz + 1e-5` rad/s.
pub fn interpolator_slack<S: Scalar>(k: &Profile<S>) -> S {
    k.eps.times_int(k.tick_hz).times_int(2).plus(S::from_f32(1e-5))
}

/// Which statement of [`interpolator`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InterpProp {
    /// The new set-point and velocity are finite.
    Finite,
    /// `|vel'| <= vmax + slack`.
    Speed,
    /// `|vel' - vel| <= dv + slack`.
    Acceleration,
    /// A set-point approaching a target it can stop at never passes it.
    NeverPasses,
}

/// One `Interpolator::advance` (`step`: the kernel's [`advance`]; the
/// tests pass broken ones) from any state with set-point and target in
/// +-16 rad, velocity within the speed limit and any cruising speed (every
/// bit pattern: the invariant does not bound it), for joint `j`'s
/// profile, one statement `which` of: the new state is finite; the new
/// velocity is within `vmax + slack`; it changes by at most `dv + slack`;
/// a set-point approaching a target it can stop at (the braking distance
/// from its speed plus one tick's travel inside the distance left, or at
/// rest) never passes it. The statements and the slack are
/// `proofs/src/numeric.rs`'s `interpolator` (the Kani harness).
pub fn interpolator<S: Sym>(j: usize, which: InterpProp, step: Step<S>) -> Vec<B> {
    let k = joint_profile::<S>(j);
    let lim = S::from_f32(16.0);
    let (sp, to, vel, speed) = (S::var("setpoint"), S::var("target"), S::var("velocity"), S::var("speed"));
    B::all(&[within(sp, lim.neg(), lim), within(to, lim.neg(), lim), within(vel, k.vmax.neg(), k.vmax)]).assume();
    // Any cruising speed: every bit pattern (NaN, infinities, negative
    // values, above vmax); the invariant does not bound it.
    let (sp2, vel2) = step(sp, to, vel, speed, &k);
    let slack = interpolator_slack(&k);
    match which {
        InterpProp::Finite => vec![sp2.t_finite(), vel2.t_finite()],
        InterpProp::Speed => vec![vel2.abs().t_le(k.vmax.plus(slack))],
        InterpProp::Acceleration => vec![vel2.minus(vel).abs().t_le(k.dv.plus(slack))],
        InterpProp::NeverPasses => {
            let dist = to.minus(sp).abs();
            let approaching = B::all(&[to.t_gt(sp), vel.t_ge(S::ZERO)])
                .or(B::all(&[to.t_lt(sp), vel.t_le(S::ZERO)]))
                .or(B::all(&[to.t_eq(sp), vel.t_eq(S::ZERO)]));
            let reach = vel.times(vel).times(k.inv_2a).plus(vel.abs().times(k.dt)).plus(k.eps).t_le(dist);
            vec![approaching.and(reach.or(vel.t_eq(S::ZERO))).implies(sp2.minus(sp).abs().t_le(dist))]
        }
    }
}

/// Which half of the set-point guarantee's one-tick lemma.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Guarantee {
    /// One tick keeps the set-point inside its interval.
    Advance,
    /// Accepting a target gives an interval holding the set-point and the
    /// target, inside the span of the old interval and the target.
    Retarget,
}

/// The set-point guarantee's one-tick lemma (SR-18; the Kani harness
/// `setpoint_guarantee_one_tick_*` asserts the same): for **every**
/// profile (each constant a free variable but the tick rate, the PAROL6's;
/// so every joint's profile, `joint_profile`, is an instance), from any
/// state whose interval `[lo, hi]` lies in +-16 rad and holds the set-point
/// and the target, with velocity and cruising speed within the speed limit
/// `vmax >= 0`: `Advance`: `Interpolator::advance` keeps the set-point in
/// `[lo, hi]`; `Retarget`: `Interpolator::retarget` to any `x` in +-16 rad
/// gives `[lo', hi']` with `lo' <= sp, x <= hi'` and `min(lo, x) <= lo'`,
/// `hi' <= max(hi, x)`. By induction over ticks and accepted targets: G1
/// and G2 of `SAFETY.md`.
pub fn setpoint_guarantee<S: Sym>(which: Guarantee) -> Vec<B> {
    let k = Profile {
        dv: S::var("dv"),
        inv_2a: S::var("inv_2a"),
        dt: S::var("dt"),
        half_dt: S::var("half_dt"),
        brake_slack: S::var("brake_slack"),
        tick_hz: i32::try_from(CONFIG.tick_hz).unwrap_or(1000),
        vmax: S::var("vmax"),
        eps: S::var("eps"),
        land_slack: S::var("land_slack"),
    };
    let lim = S::from_f32(16.0);
    let (lo, hi) = (S::var("lo"), S::var("hi"));
    let (sp, to, vel, speed) = (S::var("setpoint"), S::var("target"), S::var("velocity"), S::var("speed"));
    B::all(&[
        within(lo, lim.neg(), lim),
        within(hi, lim.neg(), lim),
        within(sp, lo, hi),
        within(to, lo, hi),
        within(k.vmax, S::ZERO, lim),
        within(vel, k.vmax.neg(), k.vmax),
        within(speed, S::ZERO, k.vmax),
    ])
    .assume();
    let mut it = Interpolator::from_parts_within(sp, to, vel, speed, lo, hi, &k);
    match which {
        Guarantee::Advance => {
            let (sp2, _) = it.advance(&k);
            vec![lo.t_le(sp2), sp2.t_le(hi)]
        }
        Guarantee::Retarget => {
            let x = S::var("x");
            within(x, lim.neg(), lim).assume();
            it.retarget(x, speed, &k);
            let (lo2, hi2) = it.bounds();
            vec![lo2.t_le(sp), sp.t_le(hi2), lo2.t_le(x), x.t_le(hi2), lo.min(x).t_le(lo2), hi2.t_le(hi.max(x))]
        }
    }
}

/// `y` lies in the closed interval between `a` and `b` (either order).
fn between<S: Sym>(y: S, a: S, b: S) -> B {
    (a.t_le(y).and(y.t_le(b))).or(b.t_le(y).and(y.t_le(a)))
}

/// `ramp::stop_scale` for every `inv_stop` (NaN and infinities included):
/// finite and in `[0, 1]`. With `left == 1` the product `inv_stop * left`
/// takes every value of the type, so the bound holds for every `left`.
pub fn stop_scale<S: Sym>(left: i32) -> Vec<B> {
    let y = ramp::stop_scale(S::var("inv_stop"), left);
    vec![within(y, S::ZERO, S::ONE)]
}

/// A soft-stop output function under proof (the kernel's
/// `ramp::stop_output`; the tests pass broken ones).
pub type StopOutput<S> = fn(S, S, S, Option<(S, S)>, bool) -> S;

/// The soft-stop ramp's per-axis output (`ramp::stop_output`, as
/// `Supervisor::ramp` calls it), following (`track`) or not, before or
/// after the ramp's end, for every `v0`, previous output `prev`, braking
/// command and follow step (NaN and infinities included) and every scale
/// in `[0, 1]` (what `stop_scale` returns): the output is finite; exactly
/// `+0` once the ramp is over; between zero and `prev` when `prev` is
/// finite (never above it in magnitude, never of the other sign); between
/// zero and the envelope `v0 * scale` (rounded) unless that is NaN (so of
/// `v0`'s sign or zero); and for a finite `v0` no larger than `|v0|`.
pub fn stop_output<S: Sym>(f: StopOutput<S>) -> Vec<B> {
    let (v0, scale, prev) = (S::var("v0"), S::var("scale"), S::var("prev"));
    let (brake, step) = (S::var("brake"), S::var("step"));
    within(scale, S::ZERO, S::ONE).assume();
    let track = B::var("track").decide();
    let done = B::var("done").decide();
    let out = f(v0, scale, prev, if track { Some((brake, step)) } else { None }, done);
    let x = v0.times(scale);
    vec![
        out.t_finite(),
        if done { out.t_same(S::ZERO) } else { B::TRUE },
        prev.t_finite().implies(between(out, S::ZERO, prev)),
        x.t_eq(x).implies(between(out, S::ZERO, x)),
        v0.t_finite().implies(out.abs().t_le(v0.abs())),
    ]
}

/// A homing ramp under proof (the kernel's `ramp::toward`).
pub type Toward<S> = fn(S, S, S) -> S;

/// The homing ramp (`ramp::toward`): from a velocity within the kernel's
/// plausibility bound (64 rad/s) with a step `dv` in `[0, 1]` rad/s (the
/// joints' `max_acceleration / tick_hz` is far below), toward any `want`
/// (NaN and infinities included): the new velocity is finite, between the
/// computed (rounded) `vel - dv` and `vel + dv`, and `want` itself when
/// `want` is inside. In I8F24 (exact here: no saturation within
/// +-65 rad/s) also `|v - vel| <= dv`. (In f32, `|v - vel| <= dv + 2e-5`,
/// the rounding of `vel +- dv` included, is not stated: z3 did not decide
/// it within 120 s.)
pub fn homing_ramp<S: Sym>(f: Toward<S>) -> Vec<B> {
    let (vel, want, dv) = (S::var("vel"), S::var("want"), S::var("dv"));
    let w = S::from_f32(64.0);
    within(vel, w.neg(), w).and(within(dv, S::ZERO, S::ONE)).assume();
    let v = f(vel, want, dv);
    let (lo, hi) = (vel.minus(dv), vel.plus(dv));
    vec![
        v.t_finite(),
        within(v, lo, hi),
        within(want, lo, hi).implies(v.t_eq(want)),
        if S::VARIANT == "I8F24" { v.minus(vel).abs().t_le(dv) } else { B::TRUE },
    ]
}
