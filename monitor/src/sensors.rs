//! SR-9, SR-10, SR-11: what the sensors report must stop the arm: a
//! runaway estimate, a pressed switch, an encoder invalid for too long.

use kernel::{Event, Scalar, State};

use crate::facts::TickFacts;
use crate::violation::{Checked, Sr};
use crate::{bit, cfg_joints, f, is_count, Monitor, ALL};

impl<S: Scalar> Monitor<S> {
    /// SR-9, SR-10, SR-11.
    pub(crate) fn check_sensors(&mut self, t: &TickFacts<'_, S>) -> Checked {
        let (out, st) = (t.out, t.st);
        // SR-9: a speed estimate above the runaway threshold is a fault.
        for (i, (v, j)) in out.status.velocity.iter().zip(cfg_joints(&self.cfg)).enumerate() {
            if v.abs() > S::from_f32(j.runaway_velocity) {
                ensure!(
                    st == State::Fault,
                    t.fail(Sr::Sr9, "estimate above the runaway threshold without a fault")
                        .on(i)
                        .got(f(*v))
                        .bound(f64::from(j.runaway_velocity))
                );
            }
        }

        // SR-10: a homed joint's pressed switch outside homing is a fault;
        // during homing, on a homed axis at rest. An unhomed joint's switch
        // is its homing input in every state.
        let pressed = t.sense.limits & ALL;
        if pressed & out.status.homed != 0 {
            ensure!(
                !matches!(st, State::Operational | State::Stopping | State::SoftEstop),
                t.fail(Sr::Sr10, "a switch pressed on a homed joint without a fault").got(f64::from(pressed))
            );
        }
        if let (State::Homing, Some(ph)) = (st, t.phases) {
            for (i, p) in ph.iter().enumerate() {
                let still_homed = out.status.homed & bit(i) != 0 && !p.is_moving();
                ensure!(
                    !(pressed & bit(i) != 0 && still_homed),
                    t.fail(Sr::Sr10, "switch pressed on a homed axis at rest during homing").on(i)
                );
            }
        }

        // SR-11: more than `encoder_invalid_limit` invalid samples in a row
        // (outside Boot) is a fault, and that joint must be homed again.
        let limit = self.cfg.encoder_invalid_limit;
        for (i, (streak, e)) in self.lost_streak.iter_mut().zip(t.sense.encoders.iter()).enumerate() {
            *streak = if is_count(e) { 0 } else { streak.saturating_add(1) };
            if *streak > limit && t.prev != State::Boot {
                ensure!(
                    st == State::Fault,
                    t.fail(Sr::Sr11, "encoder invalid too long without a fault")
                        .on(i)
                        .got(f64::from(*streak))
                        .bound(f64::from(limit))
                );
                self.must_rehome |= bit(i);
            }
        }
        for e in out.events.iter() {
            if let Event::HomingStarted { mask } = e {
                self.must_rehome &= !mask;
            }
        }
        if st != State::Fault {
            ensure!(
                out.status.homed & self.must_rehome == 0,
                t.fail(Sr::Sr11, "a joint counted as homed after losing its encoder")
                    .got(f64::from(out.status.homed & self.must_rehome))
            );
        }
        Ok(())
    }
}
