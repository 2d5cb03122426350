//! SR-13, SR-14, SR-16, and SR-25 and SR-28 in Homing: the homing order,
//! where homing puts the zero, which phases move, and how far and how
//! sharply they move.

use kernel::config::AXES;
use kernel::homing::Phase;
use kernel::{Event, Scalar, State};

use crate::facts::{Sent, TickFacts};
use crate::violation::{Checked, Sr};
use crate::{bit, f, Monitor, HOLD_SPEED, SEED_DEPENDENCIES};

impl<S: Scalar> Monitor<S> {
    /// SR-13, SR-16: during homing, an axis moves only in a moving phase,
    /// and only after every axis of the earlier groups is homed and still;
    /// per-joint homing is refused while its dependencies are unhomed.
    pub(crate) fn check_homing_order(&self, t: &TickFacts<'_, S>) -> Checked {
        let (out, st) = (t.out, t.st);
        if st == State::Homing {
            for (i, (v, deps)) in out.act.velocity.iter().zip(SEED_DEPENDENCIES.iter()).enumerate() {
                let deps = *deps;
                let moving = *v != S::ZERO;
                let phase_moving = t.phases.and_then(|p| p.get(i)).is_some_and(|p| p.is_moving());
                if moving && t.phases.is_some() {
                    ensure!(phase_moving, t.fail(Sr::Sr16, "axis moves in a homing phase that does not move").on(i));
                }
                if moving || phase_moving {
                    ensure!(
                        out.status.homed & deps == deps,
                        t.fail(Sr::Sr13, "axis moves in homing with earlier joints unhomed")
                            .on(i)
                            .got(f64::from(deps & !out.status.homed))
                    );
                    if let Some(ph) = t.phases {
                        for (d, p) in ph.iter().enumerate() {
                            ensure!(
                                deps & bit(d) == 0 || !p.is_moving(),
                                t.fail(Sr::Sr13, "axis moves while an earlier axis is still homing")
                                    .on(i)
                                    .got(d as f64)
                            );
                        }
                    }
                }
            }
        } else if let Some(ph) = t.phases {
            ensure!(ph.iter().all(|p| !p.is_moving()), t.fail(Sr::Sr16, "a homing phase moves outside Homing"));
        }
        // SR-13: per-joint homing is refused while its dependencies are unhomed.
        if let (Some(Sent::HomeJoint(j)), true) = (t.sent, t.accepted) {
            let Some(deps) = SEED_DEPENDENCIES.get(usize::from(*j)) else {
                return Err(t.fail(Sr::Sr13, "HomeJoint of a joint that does not exist accepted").got(f64::from(*j)));
            };
            // `homed` before the tick: sensing does not change it.
            ensure!(
                self.prev_homed & deps == *deps,
                t.fail(Sr::Sr13, "HomeJoint accepted with its dependencies unhomed").on(usize::from(*j))
            );
        }
        Ok(())
    }

    /// SR-14: a homing run on a clean plant zeroes every homed axis at its
    /// true angle.
    pub(crate) fn check_homing_zero(&self, t: &TickFacts<'_, S>) -> Checked {
        let out = t.out;
        if let Some(p) = t.plant.filter(|p| p.clean_homing) {
            for e in out.events.iter() {
                if let Event::HomingDone { mask } = e {
                    for (i, (x, q)) in out.status.position.iter().zip(p.q.iter()).enumerate() {
                        if mask & bit(i) != 0 && out.status.homed & bit(i) != 0 {
                            let err = f(*x) - q;
                            // The estimate may still lag the release move by
                            // a few mrad (alpha-beta transient); a zero taken
                            // from anything but the reading at the switch is
                            // off by far more.
                            ensure!(
                                err.abs() < 2e-2,
                                t.fail(Sr::Sr14, "homed off the true angle").on(i).got(err).bound(2e-2)
                            );
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// SR-28: homing travel. The fast seek moves at most
    /// `homing.max_travel` from where it began, every other phase at most
    /// `JointConfig::homing_phase_travel()`; beyond, the kernel has
    /// faulted (HomingTravel) by that tick.
    pub(crate) fn check_homing_travel(&mut self, t: &TickFacts<'_, S>) -> Checked {
        let (out, st) = (t.out, t.st);
        match (st, t.phases) {
            (State::Homing, Some(ph)) => {
                let travel = self.fast_seek_travel.iter().zip(self.phase_travel.iter());
                for (i, (((p, last), origin), (x, (fast, other)))) in ph
                    .iter()
                    .zip(self.home_phase.iter())
                    .zip(self.home_origin.iter_mut())
                    .zip(out.status.position.iter().zip(travel))
                    .enumerate()
                {
                    if *p != *last || t.prev != State::Homing {
                        *origin = f(*x);
                    } else if p.is_moving() {
                        let bound = if *p == Phase::FastSeek { *fast } else { *other };
                        let d = (f(*x) - *origin).abs();
                        ensure!(
                            d <= bound * 1.0001 + 1e-5,
                            t.fail(Sr::Sr28, "homing phase travelled beyond its bound without a fault")
                                .on(i)
                                .got(d)
                                .bound(bound)
                        );
                    }
                }
                self.home_phase = *ph;
            }
            _ => self.home_phase = [Phase::Idle; AXES],
        }
        Ok(())
    }

    /// SR-25 in Homing: the output changes by at most max_acceleration /
    /// tick_hz per tick, but a stop to zero at the axis's switch may be
    /// immediate (a stop on a fault is the Fault state's, SR-4). Its first
    /// tick may add the holding speed (`HOLD_SPEED`) of an arm at rest in
    /// Operational.
    pub(crate) fn check_homing_acceleration(&self, t: &TickFacts<'_, S>) -> Checked {
        let (out, st) = (t.out, t.st);
        if st == State::Homing {
            for (i, ((a, b), dv)) in
                out.act.velocity.iter().zip(self.prev_out.iter()).zip(self.acc_per_tick.iter()).enumerate()
            {
                let (step, bound) = ((f(*a) - f(*b)).abs(), *dv);
                let at_switch = *a == S::ZERO && t.sense.limits & bit(i) != 0;
                // Homing starts from rest, and rest allows a holding output.
                let from_rest = if t.prev == State::Homing { 0.0 } else { HOLD_SPEED };
                ensure!(
                    step <= bound * 1.0001 + 1e-6 + from_rest || at_switch,
                    t.fail(Sr::Sr25, "homing output stepped more than max_acceleration/tick_hz")
                        .on(i)
                        .got(step)
                        .bound(bound)
                );
            }
        }
        Ok(())
    }
}
