//! SR-15, SR-17, SR-30: what the kernel accepts and refuses, and how it
//! reports it.

use kernel::config::{ArmConfig, AXES};
use kernel::{MotionKind, MotionTarget, Reject, Scalar, State};

use crate::facts::{Sent, TickFacts};
use crate::stats::inc;
use crate::violation::{Checked, Sr};
use crate::{continuity, f, Monitor};

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
    /// a jump: SR-30). SR-30: a stream sample is accepted only within the
    /// previous sample's or the set-point's reach (`continuity`), and
    /// refused as a jump only beyond both.
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
                // SR-30's judgement of each axis (`continuity`).
                let jump = |i: usize| -> Option<continuity::Continuity> {
                    let j = self.cfg.joints.get(i)?;
                    let v = t.prev_sp_vel.and_then(|v| v.get(i).copied()).unwrap_or(0.0);
                    let prev_target = t.old_target.and_then(|o| o.get(i).copied()).map_or(f64::NAN, f);
                    let sample = continuity::Sample {
                        live: self.prev_armed && t.prev == State::Operational,
                        gap_ticks: t.gap,
                        x: f(*m.position.get(i)?),
                        prev: prev_target,
                        sp: f(*self.prev_setpoint.get(i)?),
                        v,
                    };
                    Some(continuity::judge(&self.cfg, j, &sample))
                };
                let stream = m.kind == MotionKind::Stream;
                if t.motion_accepted {
                    ensure!(verdict != Validity::Invalid, t.fail(Sr::Sr17, "invalid target accepted"));
                    if !stream {
                        inc(&mut self.stats.goto_accepted);
                    }
                    for i in 0..AXES {
                        if let (true, Some(c)) = (stream, jump(i)) {
                            ensure!(
                                c.possibly,
                                t.fail(
                                    Sr::Sr30,
                                    "stream sample accepted beyond both the previous sample's and the set-point's reach"
                                )
                                .on(i)
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
                    if let Some(c) = jump(i) {
                        ensure!(
                            !c.surely,
                            t.fail(
                                Sr::Sr30,
                                "stream sample within the previous sample's or the set-point's reach refused"
                            )
                            .on(i)
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
