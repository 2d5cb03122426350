//! SR-7, SR-8, SR-29, SR-31: what starts a soft stop or a hold, the ramp
//! of a soft stop, and the command timeout.

use kernel::{HomingStatus, MotionKind, Scalar, State};

use crate::facts::TickFacts;
use crate::motion::first_step_over;
use crate::stats::inc;
use crate::violation::{Checked, Sr};
use crate::{f, Monitor};

impl<S: Scalar> Monitor<S> {
    /// SR-7, SR-29, SR-31: what starts a stop, and a hold.
    pub(crate) fn check_stop_causes(&mut self, t: &TickFacts<'_, S>) -> Checked {
        let (out, st, prev) = (t.out, t.st, t.prev);
        let after_stop = t.ev_after_stop;
        // At the command timeout (exactly `timeout` ticks after the last
        // accepted stream sample, armed) the kernel either latches
        // interrupted motion (a soft stop) or holds an arm at rest at its
        // target; a lost link may have stopped it first. Nothing else
        // starts a timeout stop or a hold.
        let waited = self.since_accept.map(|n| n.saturating_add(1));
        let due = prev == State::Operational && self.prev_armed && waited == Some(self.timeout_ticks) && !t.accepted;
        let timing =
            |sr, what| t.fail(sr, what).got(waited.map_or(-1.0, f64::from)).bound(f64::from(self.timeout_ticks));
        if due {
            let n = [t.timeout_stop, t.holding, t.link_stop].iter().filter(|x| **x).count();
            ensure!(n == 1, timing(Sr::Sr29, "not exactly one of soft stop, hold, link stop at the command timeout"));
        } else {
            ensure!(!t.timeout_stop, timing(Sr::Sr7, "a soft stop other than at the command timeout"));
            ensure!(!t.holding, timing(Sr::Sr29, "Holding other than at the command timeout"));
        }
        if t.holding {
            inc(&mut self.stats.holds);
            ensure!(!t.sp_moving, t.fail(Sr::Sr29, "Holding while a set-point still moves"));
            ensure!(
                matches!(st, State::Operational | State::Fault) && !out.status.timeout_armed,
                t.fail(Sr::Sr29, "Holding did not stay Operational with the timeout disarmed")
            );
        }
        if t.timeout_stop {
            // The decision is the set-points' alone: at rest on their
            // targets the arm holds, whatever the outputs' residual.
            ensure!(!t.sp_still, t.fail(Sr::Sr29, "latched at the timeout with every set-point at rest on its target"));
        }
        // SR-31: a lost link stops a moving arm, a homing run, and a stop
        // that was to end in homing, at once; an arm at rest holds.
        let eff_homing = prev == State::Homing || (t.homing_started && prev != State::Stopping);
        let eff_pending = (prev == State::Stopping && self.pending_home) || after_stop;
        let op = prev == State::Operational && !eff_homing && !eff_pending;
        if t.sense.link_lost && (eff_homing || eff_pending || (op && t.surely_moving)) {
            ensure!(t.link_stop, t.fail(Sr::Sr31, "link lost while moving or homing without a soft stop"));
        }
        if t.link_stop {
            inc(&mut self.stats.link_stops);
            ensure!(
                t.sense.link_lost && (eff_homing || eff_pending || (op && !t.surely_still)),
                t.fail(Sr::Sr31, "a link-loss stop without a lost link, or of an arm at rest")
            );
            // (A stop to home whose ramp ends in the same tick latches at once.)
            ensure!(
                matches!(st, State::Stopping | State::Fault) || (prev == State::Stopping && st == State::SoftEstop),
                t.fail(Sr::Sr31, "a link-loss stop did not start the ramp")
            );
            if eff_homing {
                ensure!(
                    out.status.homing == HomingStatus::Failed,
                    t.fail(Sr::Sr31, "homing interrupted by a lost link not reported failed (H3)")
                );
            }
        }
        Ok(())
    }

    /// SR-7: the ramp never increases or reverses, steps at most vmax/N,
    /// reaches zero in exactly N ticks and latches SoftEstop, or, after
    /// `<HOME>` while moving (`HomingAfterStop`), starts homing.
    pub(crate) fn check_ramp(&mut self, t: &TickFacts<'_, S>) -> Checked {
        let (out, st, prev) = (t.out, t.st, t.prev);
        let after_stop = t.ev_after_stop;
        if st == State::Stopping && prev != State::Stopping {
            ensure!(
                t.timeout_stop || t.link_stop || (after_stop && prev == State::Operational),
                t.fail(Sr::Sr7, "Stopping entered without a soft stop or HomingAfterStop event")
            );
            ensure!(
                prev == State::Operational || t.link_stop,
                t.fail(Sr::Sr7, "Stopping entered from a state other than Operational")
            );
            // From Homing, or from a homing run that started and stopped
            // for a lost link within one tick (its `HomingStarted` is in
            // the same tick's events).
            self.stopping_from_homing = prev != State::Operational || t.homing_started;
        }
        if st == State::Stopping || (prev == State::Stopping && matches!(st, State::SoftEstop | State::Homing)) {
            if prev != State::Stopping {
                self.stopping_ticks = 0;
            }
            self.stopping_ticks = self.stopping_ticks.saturating_add(1);
            for (i, (a, b)) in out.act.velocity.iter().zip(self.prev_out.iter()).enumerate() {
                let (a, b) = (*a, *b);
                ensure!(a.abs() <= b.abs(), t.fail(Sr::Sr7, "soft-stop speed increased").on(i).got(f(a)).bound(f(b)));
                ensure!(
                    a == S::ZERO || (a > S::ZERO) == (b > S::ZERO),
                    t.fail(Sr::Sr7, "soft stop reversed").on(i).got(f(a)).bound(f(b))
                );
            }
            let over = first_step_over(&out.act.velocity, &self.prev_out, 1.001, &self.stop_step, self.fixed);
            if let Some((i, step, bound)) = over {
                return Err(t
                    .fail(Sr::Sr7, "soft stop decelerates more than vmax/N in a tick")
                    .on(i)
                    .got(step)
                    .bound(bound));
            }
            match st {
                State::Stopping => ensure!(
                    self.stopping_ticks < self.stop_ticks,
                    t.fail(Sr::Sr7, "still Stopping after N ticks")
                        .got(f64::from(self.stopping_ticks))
                        .bound(f64::from(self.stop_ticks))
                ),
                State::Homing => {
                    ensure!(
                        self.pending_home && t.all_zero && t.homing_started,
                        t.fail(
                            Sr::Sr7,
                            "Stopping left for Homing without a pending HOME, zero output and HomingStarted"
                        )
                    );
                    ensure!(
                        self.stopping_ticks == self.stop_ticks,
                        t.fail(Sr::Sr7, "the stop before homing did not take exactly N ticks")
                            .got(f64::from(self.stopping_ticks))
                            .bound(f64::from(self.stop_ticks))
                    );
                }
                _ => {
                    ensure!(t.all_zero && t.ev_stopped, t.fail(Sr::Sr7, "ramp end without zero output and Stopped"))
                }
            }
        }
        if prev == State::Stopping
            && !matches!(st, State::Stopping | State::SoftEstop | State::Fault)
            && !(st == State::Homing && self.pending_home)
        {
            return Err(t.fail(Sr::Sr7, "left Stopping other than to SoftEstop, Fault, or Homing after a HOME"));
        }
        if t.ev_stopped {
            // The ramp can end in the tick a fault is detected: the fault
            // then takes the arm to Fault instead of SoftEstop.
            let faulted_now = st == State::Fault && t.n_faults > 0;
            ensure!(
                (st == State::SoftEstop || faulted_now) && prev == State::Stopping,
                t.fail(Sr::Sr7, "Stopped outside the end of a ramp")
            );
            // The ramp's ticks, from the SoftEstop event (k = 1) to the zero
            // (k = N). (The fault tick is not counted above when the fault wins.)
            let took = self.stopping_ticks.saturating_add(u32::from(faulted_now));
            ensure!(
                took == self.stop_ticks,
                t.fail(Sr::Sr7, "the ramp did not take exactly N ticks")
                    .got(f64::from(self.stopping_ticks))
                    .bound(f64::from(self.stop_ticks))
            );
        }
        if after_stop {
            inc(&mut self.stats.homes_after_stop);
            ensure!(
                prev == State::Operational && t.home_sent && t.accepted && matches!(st, State::Stopping | State::Fault),
                t.fail(Sr::Sr7, "HomingAfterStop other than for a HOME accepted while moving")
            );
            ensure!(!t.surely_still, t.fail(Sr::Sr7, "HOME stopped an arm at rest first (it must home at once)"));
        }
        if t.home_sent && t.accepted && prev == State::Operational && t.surely_moving && !t.link_stop {
            ensure!(after_stop, t.fail(Sr::Sr7, "HOME while moving started homing without a stop first"));
        }
        self.pending_home = match st {
            State::Stopping => (self.pending_home || after_stop) && !t.link_stop,
            _ => false,
        };
        Ok(())
    }

    /// SR-8: the timeout is armed only by an accepted stream sample (a
    /// go-to completes without one), and disarmed by homing and enable.
    pub(crate) fn check_timeout(&mut self, t: &TickFacts<'_, S>) -> Checked {
        let (out, st) = (t.out, t.st);
        if out.status.timeout_armed && !self.prev_armed {
            ensure!(t.motion_accepted, t.fail(Sr::Sr8, "timeout armed without an accepted motion command"));
        }
        if t.homing_started || t.ev_after_stop {
            ensure!(!out.status.timeout_armed, t.fail(Sr::Sr8, "timeout armed after homing started or was requested"));
        }
        if let (Some(m), State::Operational) = (t.accepted_target, st) {
            let want = m.kind == MotionKind::Stream;
            ensure!(
                out.status.timeout_armed == want,
                t.fail(
                    Sr::Sr8,
                    if want {
                        "an accepted stream sample did not arm the timeout"
                    } else {
                        "an accepted go-to armed the timeout"
                    }
                )
            );
        }
        self.since_accept = if t.motion_accepted { Some(0) } else { self.since_accept.map(|n| n.saturating_add(1)) };
        Ok(())
    }
}
