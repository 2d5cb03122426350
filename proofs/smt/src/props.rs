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
use kernel::homing::{AxisHoming, HomingParams, Phase};
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

// ------------------------------------------------- the SR-2 output gate --
//
// `Kernel::check` (`kernel/src/kernel/supervisor.rs`) faults a candidate
// output that is not finite or above the joint's `vmax`. The candidate is
// one of four (`Kernel::supervise` and `Kernel::motion`, read): zero
// (`[S::ZERO; AXES]`, kept in every state but these three); Operational:
// the control law's command limited to one tick's change from the last
// output (`gate_operational`); Stopping: `ramp::stop_output`
// (`gate_stopping`); Homing: `AxisHoming::step`'s velocity for the joints
// of the group being homed (`gate_homing`). Each property below runs the
// kernel's own per-axis code from that mode's inputs to the candidate and
// proves it finite and within `vmax`, under the preconditions it states:
// the configuration's bounds (`config::check`) and the last output's bound
// (the state invariant's clause 2, SR-32), so the gate's fault branch is
// unreachable per step, given the invariant.

/// Which preconditions a gate property assumes: all of them for the
/// proofs; the tests drop one to show that the property then fails.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pre {
    /// The last output (Operational, Stopping) or the homing ramp's
    /// velocity (Homing) finite and within `[-vmax, vmax]`.
    pub last_output: bool,
    /// The configuration's bounds on the step sizes and homing speeds.
    pub config: bool,
}

impl Pre {
    /// Every precondition.
    pub const ALL: Pre = Pre { last_output: true, config: true };
}

/// The joint's speed limit as `Params::new` builds it
/// (`S::from_f32(max_velocity)`, `config::check`: finite, in `(0, 16]`),
/// any such value.
fn gate_vmax<S: Sym>() -> S {
    let vmax = S::var("vmax");
    B::all(&[within(vmax, S::ZERO, S::from_f32(16.0)), S::ZERO.t_lt(vmax)]).assume();
    vmax
}

/// A control law under proof (`control::control_law`; the tests pass
/// broken ones): `(set-point, feed-forward, estimate, kp, vmax, deadband)
/// -> (command, ok)`.
pub type Law<S> = fn(S, S, S, S, S, S) -> (S, bool);

/// The Operational candidate: `Axis::control`'s command (`law`, for
/// **every** set-point, feed-forward and estimate, so whatever the
/// interpolator's step gives, and every gain and deadband), then
/// `Kernel::motion`'s acceleration clamp to within `accel_step` of the last
/// output `prev`. Preconditions: `prev` finite and `|prev| <= vmax`
/// (invariant clause 2); `accel_step` finite and `>= 0` (`config::check`:
/// `max_acceleration` in `(0, 200]`, divided by `tick_hz`). Proves the
/// candidate finite and `|out| <= vmax`.
///
/// The clamp is written inline in `Kernel::motion`
/// (`kernel/src/kernel/supervisor.rs`, `let followed = ...`), not in a
/// function this crate can call: the line below is a copy of it, the same
/// operations in the same order, read against it, not proved to be it.
pub fn gate_operational<S: Sym>(law: Law<S>, pre: Pre) -> Vec<B> {
    let vmax = gate_vmax::<S>();
    let (prev, accel_step) = (S::var("prev"), S::var("accel_step"));
    if pre.last_output {
        within(prev, vmax.neg(), vmax).assume();
    }
    if pre.config {
        accel_step.t_finite().and(S::ZERO.t_le(accel_step)).assume();
    }
    let (sp, ff, x) = (S::var("setpoint"), S::var("feed_forward"), S::var("estimate"));
    let (kp, deadband) = (S::var("kp"), S::var("deadband"));
    let out = operational_candidate(law, [sp, ff, x, kp, vmax, deadband], prev, accel_step);
    vec![out.t_finite(), out.abs().t_le(vmax)]
}

/// The Operational candidate of [`gate_operational`]: `law` on
/// `[set-point, feed-forward, estimate, kp, vmax, deadband]`, then
/// `Kernel::motion`'s acceleration clamp around `prev` (copied from
/// `kernel/src/kernel/supervisor.rs`: `cmd.max(prev.minus(p.accel_step))
/// .min(prev.plus(p.accel_step))`). Generic, so the tests replay it on the
/// concrete types.
pub fn operational_candidate<S: Scalar>(law: Law<S>, args: [S; 6], prev: S, accel_step: S) -> S {
    let [sp, ff, x, kp, vmax, deadband] = args;
    let (cmd, _ok) = law(sp, ff, x, kp, vmax, deadband);
    cmd.max(prev.minus(accel_step)).min(prev.plus(accel_step))
}

/// The Stopping candidate: `Kernel::motion`'s soft-stop output,
/// `ramp::stop_output` (`f`; the tests pass broken ones) with the scale
/// `ramp::stop_scale` computes (from every product `inv_stop * left`: the
/// input `scaled_left`, times 1, so every scale `Kernel::stop_scale` can
/// give), following its braking command or not, before or at the ramp's
/// end, for **every** starting output `v0`, braking command and stop step
/// (NaN and infinities included). Precondition: the last output `prev`
/// finite and `|prev| <= vmax` (invariant clause 2). Proves the candidate
/// finite and `|out| <= vmax`.
pub fn gate_stopping<S: Sym>(f: StopOutput<S>, pre: Pre) -> Vec<B> {
    let vmax = gate_vmax::<S>();
    let prev = S::var("prev");
    if pre.last_output {
        within(prev, vmax.neg(), vmax).assume();
    }
    let (v0, scaled_left) = (S::var("v0"), S::var("scaled_left"));
    let (brake, stop_step) = (S::var("brake"), S::var("stop_step"));
    let track = B::var("track").decide();
    let done = B::var("done").decide();
    let out = stopping_candidate(f, v0, scaled_left, prev, track.then_some((brake, stop_step)), done);
    vec![out.t_finite(), out.abs().t_le(vmax)]
}

/// The Stopping candidate of [`gate_stopping`]: `f` (`ramp::stop_output`)
/// with the scale `ramp::stop_scale(scaled_left, 1)`. Generic, so the
/// tests replay it on the concrete types.
pub fn stopping_candidate<S: Scalar>(
    f: StopOutput<S>,
    v0: S,
    scaled_left: S,
    prev: S,
    follow: Option<(S, S)>,
    done: bool,
) -> S {
    f(v0, ramp::stop_scale(scaled_left, 1), prev, follow, done)
}

/// Where the homing axis of [`homing_gate_case`] starts: each phase, and
/// the back-off and release phases with and without a release point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HomingStart {
    /// Not in the run.
    Idle,
    /// In the run, waiting for its group.
    Waiting,
    /// Fast seek at velocity `v`.
    FastSeek,
    /// Back-off at `v`, the switch not yet released.
    BackOff,
    /// Back-off at `v`, a release point recorded.
    BackOffAnchored,
    /// Slow seek at `v`.
    SlowSeek,
    /// Release at `v`, the switch not yet released.
    Release,
    /// Release at `v`, a release point recorded.
    ReleaseAnchored,
    /// Settling at `v`.
    Settle,
    /// Finished.
    Done,
}

impl HomingStart {
    /// Every start, in the order [`homing_gate_case`] picks them.
    pub const ALL: [HomingStart; 10] = [
        HomingStart::Idle,
        HomingStart::Waiting,
        HomingStart::FastSeek,
        HomingStart::BackOff,
        HomingStart::BackOffAnchored,
        HomingStart::SlowSeek,
        HomingStart::Release,
        HomingStart::ReleaseAnchored,
        HomingStart::Settle,
        HomingStart::Done,
    ];

    /// The phase the preparation reaches.
    pub fn phase(self) -> Phase {
        match self {
            HomingStart::Idle => Phase::Idle,
            HomingStart::Waiting => Phase::Waiting,
            HomingStart::FastSeek => Phase::FastSeek,
            HomingStart::BackOff | HomingStart::BackOffAnchored => Phase::BackOff,
            HomingStart::SlowSeek => Phase::SlowSeek,
            HomingStart::Release | HomingStart::ReleaseAnchored => Phase::Release,
            HomingStart::Settle => Phase::Settle,
            HomingStart::Done => Phase::Done,
        }
    }

    /// A moving phase, left at velocity `v` by the preparation.
    pub fn moving(self) -> bool {
        self.phase().is_moving()
    }
}

/// Where [`homing_gate_case`] takes its inputs: symbolic (the proof) or
/// a counterexample's values (the tests' replay on the concrete types).
pub trait Inputs<S> {
    /// The scalar input `name`.
    fn scalar(&mut self, name: &str) -> S;
    /// The Boolean input `name`.
    fn flag(&mut self, name: &str) -> bool;
}

/// The symbolic inputs: each scalar a z3 variable, each flag a decision
/// explored both ways.
#[derive(Clone, Copy, Debug)]
pub struct Symbolic;

impl<S: Sym> Inputs<S> for Symbolic {
    fn scalar(&mut self, name: &str) -> S {
        S::var(name)
    }
    fn flag(&mut self, name: &str) -> bool {
        B::var(name).branch()
    }
}

/// One homing tick of [`homing_gate_case`]: the inputs that matter to the
/// bound and what the step gave.
#[derive(Clone, Copy, Debug)]
pub struct HomingCase<S> {
    /// Where the axis started.
    pub start: HomingStart,
    /// The velocity the preparation aimed at (free).
    pub v: S,
    /// The step's parameters (the joint's `HomingParams`).
    pub params: HomingParams<S>,
    /// The axis's velocity before the step (`AxisHoming::velocity`).
    pub vel: S,
    /// The step's output velocity (the candidate output).
    pub out: S,
    /// The axis's velocity after the step.
    pub vel_after: S,
    /// The preparation reached the phase it aimed at.
    pub reached: bool,
}

/// Brings an axis, through its public interface (`reset`, `start`, `step`
/// with parameters chosen for the purpose, at position 0, the switch as
/// needed), to `start` with velocity `v` (moving phases; zero otherwise),
/// then runs **one** `AxisHoming::step` with the switch, position and
/// parameters from `src`. The preparation's steps ramp with `dv = 64` from
/// rest to `v` (so to exactly `v` for `|v| <= 64`) and, into Settle, with
/// `dv = 0` (keeping `v`); their travel bounds are 64 rad, their back-off
/// zero, their timeouts never reached.
///
/// The step's own branches depend on state the preparation fixes (the
/// phase origin and release point at 0, the tick and rest counts, no
/// tighter fast-seek bound) only through comparisons with the free
/// position `x`, the free bounds and back-off, and the chosen timeout and
/// settle time (`0` or `u32::MAX`, each chosen by `src`), so every branch
/// of the step is taken for some inputs; and its output depends on the
/// state only through its phase and velocity (`homing.rs`, read).
pub fn homing_gate_case<S: Scalar>(src: &mut impl Inputs<S>) -> HomingCase<S> {
    let n = HomingStart::ALL.len();
    let start = HomingStart::ALL
        .iter()
        .enumerate()
        .find(|(i, s)| *i + 1 == n || src.flag(&format!("start {s:?}")))
        .map_or(HomingStart::Done, |(_, s)| *s);
    let v = if start.moving() { src.scalar("v") } else { S::ZERO };
    let wide = S::from_f32(64.0);
    let prep = |fast: S, slow: S, dv: S, settle_ticks: u32| HomingParams {
        fast_toward: fast,
        slow_toward: slow,
        backoff: S::ZERO,
        timeout_ticks: u32::MAX,
        dv,
        max_travel: wide,
        phase_travel: wide,
        settle_ticks,
    };
    let z = S::ZERO;
    let plain = prep(z, z, wide, u32::MAX);
    // Ramps to `v`: in the seeks toward `fast` / `slow`, in the back-off
    // and release away from the switch (`-fast`).
    let seek_v = prep(v, v, wide, u32::MAX);
    let away_v = prep(v.neg(), v, wide, u32::MAX);
    use HomingStart as H;
    // (switch, parameters) of each preparation step after `start(0)`.
    let to_backoff = [(true, plain)];
    let to_backoff_anchored = [(true, plain), (false, plain)];
    let to_release = [(true, plain), (false, plain), (false, plain), (true, plain)];
    let mut steps: Vec<(bool, HomingParams<S>)> = Vec::new();
    match start {
        H::Idle | H::Waiting => {}
        H::FastSeek => steps.push((false, seek_v)),
        H::BackOff => steps.extend(to_backoff.iter().copied().chain([(true, away_v)])),
        H::BackOffAnchored => steps.extend(to_backoff.iter().copied().chain([(false, away_v)])),
        H::SlowSeek => steps.extend(to_backoff_anchored.iter().copied().chain([(false, seek_v)])),
        H::Release => steps.extend(to_release.iter().copied().chain([(true, away_v)])),
        H::ReleaseAnchored => steps.extend(to_release.iter().copied().chain([(false, away_v)])),
        H::Settle => {
            steps.extend(to_release.iter().copied().chain([(false, away_v), (false, prep(z, z, z, u32::MAX))]))
        }
        H::Done => steps.extend(to_release.iter().copied().chain([
            (false, plain),
            (false, plain),
            (false, prep(z, z, wide, 0)),
        ])),
    }
    let mut h = AxisHoming::<S>::default();
    if start != H::Idle {
        h.reset(true);
    }
    if !matches!(start, H::Idle | H::Waiting) {
        h.start(z);
    }
    for (switch, p) in &steps {
        h.step(*switch, z, p);
    }
    let reached = h.phase() == start.phase();
    let vel = h.velocity();
    // The step under proof: the joint's parameters (free; the property
    // states their bounds), every switch and position, the timeout and the
    // settle time reached or not.
    let timed_out = start.moving() && src.flag("timed out");
    let settled = start == H::Settle && src.flag("settled");
    let params = HomingParams {
        fast_toward: src.scalar("fast_toward"),
        slow_toward: src.scalar("slow_toward"),
        backoff: src.scalar("backoff"),
        timeout_ticks: if timed_out { 0 } else { u32::MAX },
        dv: src.scalar("dv"),
        max_travel: src.scalar("max_travel"),
        phase_travel: src.scalar("phase_travel"),
        settle_ticks: if settled { 0 } else { u32::MAX },
    };
    let switch = src.flag("switch");
    let x = src.scalar("x");
    let out = h.step(switch, x, &params).velocity;
    HomingCase { start, v, params, vel, out, vel_after: h.velocity(), reached }
}

/// The Homing candidate: one `AxisHoming::step` (the kernel's own, through
/// [`homing_gate_case`]) from every phase at every velocity
/// `|vel| <= vmax`. Preconditions: that velocity bound (the homing ramp's
/// own: an axis's velocity is zero after `reset` and `Default`, and only
/// `step` changes it, which this property shows keeps the bound);
/// `|fast_toward| <= vmax`, `|slow_toward| <= vmax`, `dv` finite and
/// `>= 0` (`config::check`: `0 < slow <= fast <= max_velocity`,
/// `max_acceleration > 0`; each a signed `S::from_f32` of those). Proves
/// the output and the new velocity finite and within `vmax`, and that the
/// preparation reached its phase with velocity `v` for every
/// `|v| <= vmax` (zeros of either sign compared equal).
pub fn gate_homing<S: Sym>(pre: Pre) -> Vec<B> {
    let vmax = gate_vmax::<S>();
    let c = homing_gate_case::<S>(&mut Symbolic);
    let p = &c.params;
    if pre.last_output {
        within(c.vel, vmax.neg(), vmax).assume();
    }
    if pre.config {
        B::all(&[
            within(p.fast_toward, vmax.neg(), vmax),
            within(p.slow_toward, vmax.neg(), vmax),
            p.dv.t_finite(),
            S::ZERO.t_le(p.dv),
        ])
        .assume();
    }
    let mut props = vec![within(c.out, vmax.neg(), vmax)];
    // (The new velocity is mostly the output's own term: checked once.)
    if c.vel_after.id() != c.out.id() {
        props.push(within(c.vel_after, vmax.neg(), vmax));
    }
    if c.start.moving() {
        props.push(within(c.v, vmax.neg(), vmax).implies(c.vel.t_eq(c.v)));
    }
    if !c.reached {
        props.push(B::FALSE);
    }
    props
}
