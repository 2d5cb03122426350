//! SR-15, SR-17, SR-30: what the kernel accepts and refuses, and how it
//! reports it.

use kernel::config::{ArmConfig, AXES};
use kernel::{MotionKind, MotionTarget, Reject, Scalar, State};

use crate::facts::{Sent, TickFacts};
use crate::stats::inc;
use crate::violation::{Checked, Sr};
use crate::{f, Monitor, PROFILE_DECEL_MIN};

/// The monitor's own verdict on a motion target (SR-17).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Validity {
    /// Finite, inside every limit with room to spare: must be accepted.
    Valid,
    /// Within a rounding distance of a limit: either answer is fine.
    Edge,
    /// Non-finite or clearly outside a limit: must be rejected.
    Invalid,
}

/// Classifies `t` against the configuration's limits (SR-17).
pub fn validity<S: Scalar>(cfg: &ArmConfig, t: &MotionTarget<S>) -> Validity {
    const EPS: f64 = 1e-5;
    let mut edge = false;
    for ((j, p), v) in cfg.joints.iter().zip(t.position.iter()).zip(t.velocity.iter()) {
        if !(p.is_finite() && v.is_finite()) {
            return Validity::Invalid;
        }
        let (p, v) = (f64::from(p.to_f32()), f64::from(v.to_f32()).abs());
        let (lo, hi, vmax) = (f64::from(j.limit_min), f64::from(j.limit_max), f64::from(j.max_velocity));
        if p < lo - EPS || p > hi + EPS || v > vmax + EPS {
            return Validity::Invalid;
        }
        if p < lo + EPS || p > hi - EPS || v > vmax - EPS {
            edge = true;
        }
    }
    if edge {
        Validity::Edge
    } else {
        Validity::Valid
    }
}
/// SR-30's slack (rad) on the jump distance: rounding of the kernel's
/// distances and of its bound (f32 at |x| < 16: 2e-6; I8F24: 6e-8), with
/// a wide margin.
pub const JUMP_SLACK: f64 = 1e-4;

/// SR-30: how far a stream sample may be from the set-point (or the
/// previous target): one longest segment at the speed limit, the braking
/// distance from it, and the configured tolerance (rad), as a band: the
/// set-points brake at `max_acceleration` at most and at
/// [`PROFILE_DECEL_MIN`] of it at least (the kernel may use a share of the
/// output's limit), so the kernel's bound lies in `(low, high)`: a sample
/// farther than `high` must be refused, one nearer than `low` accepted.
pub fn max_jump(cfg: &ArmConfig, j: &kernel::config::JointConfig) -> (f64, f64) {
    let vmax = f64::from(j.max_velocity);
    let a = f64::from(j.max_acceleration);
    let base = vmax * f64::from(cfg.segment_max_ms) / 1000.0 + f64::from(cfg.target_jump_tolerance);
    (base + vmax * vmax / (2.0 * a), base + vmax * vmax / (2.0 * a * PROFILE_DECEL_MIN))
}

impl<S: Scalar> Monitor<S> {
    /// SR-15: refusals are reported against the request that was sent;
    /// no event is lost.
    pub(crate) fn check_reports(&self, t: &TickFacts<'_, S>) -> Checked {
        let out = t.out;
        // SR-15: refusals are reported; none may be lost.
        ensure!(out.events.dropped() == 0, t.fail(Sr::Sr15, "events dropped").got(f64::from(out.events.dropped())));

        // What happened to this tick's request.
        if let Some((k, _)) = t.rejected {
            ensure!(t.sent.map(Sent::kind) == Some(k), t.fail(Sr::Sr15, "a rejection without that request"));
        }
        Ok(())
    }

    /// SR-15: motion is accepted only in Operational. SR-17: accepted
    /// targets are finite and within the limits, and a clearly valid
    /// target in Operational is accepted (or, a stream sample, refused as
    /// a jump: SR-30). SR-30: a stream sample is accepted only within one
    /// segment's travel of the set-point or of the previous target, and
    /// refused as a jump only beyond it.
    pub(crate) fn check_acceptance(&mut self, t: &TickFacts<'_, S>) -> Checked {
        if matches!(t.rejected, Some((_, Reject::Internal))) {
            return Err(t.fail(Sr::Sr15, "a request refused for an internal limit (Reject::Internal)"));
        }
        if let Some(Sent::Motion(m)) = t.sent {
            if t.motion_accepted {
                inc(&mut self.stats.accepted);
                ensure!(t.prev == State::Operational, t.fail(Sr::Sr15, "motion accepted outside Operational"));
            }
            if let Some(m) = m {
                let verdict = validity(&self.cfg, m);
                let reason = t.rejected.map(|r| r.1);
                // (axis, distance, bound) of each axis, when the previous
                // target is known.
                let jump = |i: usize| -> Option<(f64, (f64, f64))> {
                    let (j, p) = (self.cfg.joints.get(i)?, f(*m.position.get(i)?));
                    let from_sp = (p - f(*self.prev_setpoint.get(i)?)).abs();
                    let from_last = (p - f(*t.old_target?.get(i)?)).abs();
                    Some((from_sp.min(from_last), max_jump(&self.cfg, j)))
                };
                let stream = m.kind == MotionKind::Stream;
                if t.motion_accepted {
                    ensure!(verdict != Validity::Invalid, t.fail(Sr::Sr17, "invalid target accepted"));
                    if !stream {
                        inc(&mut self.stats.goto_accepted);
                    }
                    for i in 0..AXES {
                        if let (true, Some((d, (_, b)))) = (stream, jump(i)) {
                            ensure!(
                                d <= b + JUMP_SLACK,
                                t.fail(Sr::Sr30, "stream sample beyond a segment's travel accepted")
                                    .on(i)
                                    .got(d)
                                    .bound(b)
                            );
                        }
                    }
                } else if let Some(Reject::TargetJump { axis }) = reason {
                    inc(&mut self.stats.target_jumps);
                    let i = usize::from(axis);
                    ensure!(
                        stream && t.prev == State::Operational && verdict != Validity::Invalid,
                        t.fail(Sr::Sr30, "TargetJump for a go-to, an invalid target, or outside Operational").on(i)
                    );
                    if let Some((d, (b, _))) = jump(i) {
                        ensure!(
                            d >= b - JUMP_SLACK,
                            t.fail(Sr::Sr30, "stream sample within a segment's travel refused as a jump")
                                .on(i)
                                .got(d)
                                .bound(b)
                        );
                    }
                } else if t.prev == State::Operational && verdict == Validity::Valid {
                    return Err(t.fail(Sr::Sr17, "valid target rejected in Operational"));
                }
            }
        }
        Ok(())
    }
}
