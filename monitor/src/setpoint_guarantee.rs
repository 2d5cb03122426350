//! SR-18, the set-point guarantee, written from `SAFETY.md`: in
//! Operational, each joint's set-point stays
//!
//! - (G1) inside the interval spanned by its position when Operational was
//!   entered (the set-points resynchronised, at rest) and every target
//!   accepted since;
//! - (G2) inside the interval spanned by the set-point when the current
//!   target was accepted, that target, and the set-point's stopping point
//!   then ([`crate::continuity::stop_point`]): it passes its target only
//!   when the target lay inside the stopping distance, and then by at most
//!   the stopping point's excess over it.
//!
//! The monitor knows every accepted target; its stopping point comes from
//! the set-point velocity of consecutive set-points, within
//! [`crate::continuity::REACH_SLACK`] of the kernel's.

use crate::continuity::{stop_point, REACH_SLACK};
use crate::facts::TickFacts;
use crate::violation::Sr;
use crate::{f, Checked, Monitor};
use kernel::config::{ArmConfig, AXES};
use kernel::{Scalar, State};

impl<S: Scalar> Monitor<S> {
    /// SR-18: the set-point guarantee, with the set-point velocity of the
    /// tick before.
    pub(crate) fn check_guarantee(&mut self, t: &TickFacts<'_, S>) -> Checked {
        let accepted = t.accepted_target.map(|m| m.position.map(f));
        let tick = Tick {
            operational: t.st == State::Operational,
            was_operational: t.prev == State::Operational,
            prev_setpoint: &self.prev_setpoint.map(f),
            prev_velocity: t.prev_sp_vel.as_ref(),
            accepted: accepted.as_ref(),
            setpoint: &t.out.status.setpoint.map(f),
        };
        match self.guarantee.check(&self.cfg, &tick) {
            Ok(()) => Ok(()),
            Err(b) => Err(t.fail(Sr::Sr18, b.what).on(b.axis).got(b.got).bound(b.bound)),
        }
    }
}

/// One joint's intervals: G1's span and G2's span of the current target.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Spans {
    rest: (f64, f64),
    target: (f64, f64),
}

/// The guarantee's memory between ticks.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Guarantee {
    spans: Option<[Spans; AXES]>,
}

/// A set-point outside one of its intervals.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Breach {
    /// The joint (0..=5).
    pub axis: usize,
    /// Which half of the guarantee.
    pub what: &'static str,
    /// The set-point (rad).
    pub got: f64,
    /// The end of the interval it passed (rad).
    pub bound: f64,
}

/// What one tick tells the guarantee, every position in rad.
#[derive(Clone, Copy, Debug)]
pub struct Tick<'a> {
    /// Operational after the tick.
    pub operational: bool,
    /// Operational before the tick too (else the set-points were just
    /// resynchronised).
    pub was_operational: bool,
    /// The set-points before the tick.
    pub prev_setpoint: &'a [f64; AXES],
    /// Their velocity over the tick before (rad/s), when known.
    pub prev_velocity: Option<&'a [f64; AXES]>,
    /// The target accepted in this tick.
    pub accepted: Option<&'a [f64; AXES]>,
    /// The set-points after the tick.
    pub setpoint: &'a [f64; AXES],
}

fn span3(a: f64, b: f64, c: f64) -> (f64, f64) {
    (a.min(b).min(c), a.max(b).max(c))
}

impl Guarantee {
    /// Judges one tick of configuration `cfg`.
    pub fn check(&mut self, cfg: &ArmConfig, t: &Tick<'_>) -> Result<(), Breach> {
        if !t.operational {
            self.spans = None;
            return Ok(());
        }
        let spans = match (t.was_operational, self.spans.as_mut()) {
            (true, Some(s)) => s,
            _ => {
                self.spans = Some(t.setpoint.map(|x| Spans { rest: (x, x), target: (x, x) }));
                return Ok(());
            }
        };
        for (i, (s, j)) in spans.iter_mut().zip(cfg.joints.iter()).enumerate() {
            let at = |a: &[f64; AXES]| a.get(i).copied().unwrap_or(0.0);
            if let Some(accepted) = t.accepted {
                let x = at(accepted);
                let (p, v) = (at(t.prev_setpoint), t.prev_velocity.map_or(0.0, at));
                s.target = span3(p, stop_point(cfg, j, p, v), x);
                s.rest = (s.rest.0.min(x), s.rest.1.max(x));
            }
            let sp = at(t.setpoint);
            let breach = |what, bound| Err(Breach { axis: i, what, got: sp, bound });
            if sp < s.rest.0 - REACH_SLACK {
                return breach("set-point below its rest position and every accepted target (G1)", s.rest.0);
            }
            if sp > s.rest.1 + REACH_SLACK {
                return breach("set-point above its rest position and every accepted target (G1)", s.rest.1);
            }
            if sp < s.target.0 - REACH_SLACK {
                return breach("set-point below its target's interval (G2)", s.target.0);
            }
            if sp > s.target.1 + REACH_SLACK {
                return breach("set-point above its target's interval (G2)", s.target.1);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kernel::config::PAROL6;

    /// J6 (index 5) runs `path` (one set-point a tick, the other joints at
    /// 0) from rest at 0, with `target` accepted on the first tick.
    fn run(target: f64, path: &[f64]) -> Result<(), Breach> {
        let mut g = Guarantee::default();
        let zero = [0.0; AXES];
        let enter = Tick {
            operational: true,
            was_operational: false,
            prev_setpoint: &zero,
            prev_velocity: None,
            accepted: None,
            setpoint: &zero,
        };
        g.check(&PAROL6, &enter)?;
        let (mut prev, mut vel) = (zero, zero);
        let mut x = zero;
        x[5] = target;
        for (n, p) in path.iter().enumerate() {
            let mut sp = prev;
            sp[5] = *p;
            let t = Tick {
                operational: true,
                was_operational: true,
                prev_setpoint: &prev,
                prev_velocity: Some(&vel),
                accepted: if n == 0 { Some(&x) } else { None },
                setpoint: &sp,
            };
            g.check(&PAROL6, &t)?;
            vel[5] = (sp[5] - prev[5]) * 1000.0;
            prev = sp;
        }
        Ok(())
    }

    #[test]
    fn a_set_point_that_stops_on_its_target_keeps_the_guarantee() {
        let path: std::vec::Vec<f64> = (1..=100).map(|n| 0.001 * f64::from(n)).collect();
        assert_eq!(run(0.1, &path), Ok(()));
    }

    /// A set-point that runs past a target it accepted at rest (so with no
    /// stopping distance): G2, or G1 where both apply.
    #[test]
    fn a_set_point_past_a_target_accepted_at_rest_breaks_it() {
        let path: std::vec::Vec<f64> = (1..=120).map(|n| 0.001 * f64::from(n)).collect();
        let b = run(0.1, &path).expect_err("past its target");
        assert_eq!(b.axis, 5);
        assert!(b.got > 0.101 && b.bound <= 0.1 + 1e-9, "{b:?}");
        // Backwards, beyond where it rested: G1.
        let b = run(0.1, &[-0.002]).expect_err("behind its rest position");
        assert!(b.what.contains("G1"), "{b:?}");
    }
}
