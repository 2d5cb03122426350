//! The per-axis arithmetic of the two velocity ramps, as public generic
//! functions so that `proofs/smt` can prove them on symbolic scalars (the
//! soft-stop ramp of the supervisor and the homing sequencer's ramp call
//! exactly these; moving them here changed no operation and no order).

use crate::scalar::Scalar;

/// The soft-stop envelope's scale with `left` ramp ticks to go:
/// `inv_stop * left`, bounded to `[0, 1]` (for any product: `f32::min` and
/// `max` ignore a NaN, so a NaN product gives 1).
#[inline(always)]
pub fn stop_scale<S: Scalar>(inv_stop: S, left: i32) -> S {
    inv_stop.times_int(left).min(S::ONE).max(S::ZERO)
}

/// One axis's soft-stop output. The envelope is `v0 * scale` clamped
/// between zero and `prev` (the previous output: never above it in
/// magnitude, zero where their signs differ), zero if not finite. With
/// `follow = Some((v, step))` the axis follows its braking command `v`,
/// which may change by at most `step` from `prev` (so the output falls no
/// faster than the ramp itself); with `None` it takes the envelope. The
/// output lies between zero and the envelope, and is exactly zero once the
/// ramp is over (`done`).
#[inline(always)]
pub fn stop_output<S: Scalar>(v0: S, scale: S, prev: S, follow: Option<(S, S)>, done: bool) -> S {
    let env = v0.times(scale).clamp_between(S::ZERO, prev);
    let env = S::select(env.is_finite(), env, S::ZERO);
    // `prev - step <= prev + step` for the kernel's `step >= 0`, so the
    // bounds need no reordering (`clamp_between`'s); for a negative `step`
    // the result lies at `prev + step`, and the last clamp below still
    // bounds the output.
    let follow = match follow {
        Some((v, step)) => v.max(prev.minus(step)).min(prev.plus(step)),
        None => env,
    };
    S::select(done, S::ZERO, follow.clamp_between(S::ZERO, env))
}

/// The homing ramp: from velocity `vel`, toward `want`, changing by at
/// most `dv` (the result lies between `vel - dv` and `vel + dv`).
#[inline(always)]
pub fn toward<S: Scalar>(vel: S, want: S, dv: S) -> S {
    want.clamp_between(vel.minus(dv), vel.plus(dv))
}
