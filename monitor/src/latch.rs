//! SR-1, SR-4, SR-5, SR-6: zero output while not in control, the latch of
//! a fault or soft stop, and `<ENABLE>`, the one way out of it.

use kernel::{EncoderSample, Event, FaultReason, Reject, Scalar, State};

use crate::facts::{Sent, TickFacts};
use crate::stats::inc;
use crate::violation::{Checked, Sr};
use crate::{bit, cfg_joints, f, is_count, Monitor, ALL, QUIET_TICKS};

impl<S: Scalar> Monitor<S> {
    /// SR-1, SR-4, SR-5: zero output in Boot, Unhomed, SoftEstop, Fault,
    /// and in the tick a fault is raised (for every axis).
    pub(crate) fn check_zero_output(&self, t: &TickFacts<'_, S>) -> Checked {
        if t.n_faults > 0 {
            ensure!(t.all_zero, t.fail(Sr::Sr4, "the tick a fault is raised did not zero every axis"));
        }
        if matches!(t.st, State::Boot | State::Unhomed) {
            ensure!(t.all_zero, t.fail(Sr::Sr1, "non-zero output before homing"));
        }
        if matches!(t.st, State::SoftEstop | State::Fault) {
            ensure!(t.all_zero, t.fail(Sr::Sr5, "non-zero output while latched"));
        }
        Ok(())
    }

    /// SR-1: leaving Boot, each estimate is the encoder's actual reading.
    pub(crate) fn check_ready(&self, t: &TickFacts<'_, S>) -> Checked {
        let out = t.out;
        if t.ev_ready {
            ensure!(t.prev == State::Boot, t.fail(Sr::Sr1, "Ready outside Boot"));
            if t.plant.is_some_and(|p| p.clean_since_start) {
                for (i, ((j, e), (x, v))) in cfg_joints(&self.cfg)
                    .zip(t.sense.encoders.iter())
                    .zip(out.status.position.iter().zip(out.status.velocity.iter()))
                    .enumerate()
                {
                    let EncoderSample::Count(c) = *e else {
                        return Err(t.fail(Sr::Sr1, "Ready with an encoder lost").on(i));
                    };
                    let sign = if j.encoder_reversed { -1.0 } else { 1.0 };
                    let want = sign * f64::from(c) * j.rad_per_count();
                    let got = f(*x);
                    let tol = 2.0 * j.rad_per_count() + 1e-5;
                    ensure!(
                        (got - want).abs() <= tol,
                        t.fail(Sr::Sr1, "estimate does not start at the reading").on(i).got(got).bound(want)
                    );
                    ensure!(*v == S::ZERO, t.fail(Sr::Sr1, "estimate does not start at rest").on(i).got(f(*v)));
                }
            }
        }
        Ok(())
    }

    /// SR-5: a fault latches with its first reason until an accepted
    /// enable; SoftEstop is latched until an accepted enable; `<HOME>` in
    /// SoftEstop or Fault is refused (only `<ENABLE>` clears a latch).
    pub(crate) fn check_latch(&mut self, t: &TickFacts<'_, S>) -> Checked {
        let (out, st) = (t.out, t.st);
        ensure!(
            (st == State::Fault) == out.status.fault.is_some(),
            t.fail(Sr::Sr5, "Fault state and latched fault disagree")
        );
        ensure!(t.n_faults <= 1, t.fail(Sr::Sr5, "several faults in one tick").got(f64::from(t.n_faults)));
        match (t.prev == State::Fault, st == State::Fault) {
            (false, true) => {
                let Some(fl) = out.status.fault else {
                    return Err(t.fail(Sr::Sr5, "Fault without a reason"));
                };
                ensure!(
                    t.n_faults == 1 && t.fault_event == Some(fl.reason),
                    t.fail(Sr::Sr5, "entered Fault without its fault event")
                );
                self.latched = Some(fl);
            }
            (true, true) => {
                ensure!(t.n_faults == 0, t.fail(Sr::Sr5, "a second fault event while latched"));
                ensure!(out.status.fault == self.latched, t.fail(Sr::Sr5, "the latched fault changed"));
            }
            (true, false) => {
                ensure!(
                    t.enable_sent && t.enabled == Some(st),
                    t.fail(Sr::Sr5, "left Fault without an accepted enable")
                );
                self.latched = None;
            }
            (false, false) => ensure!(t.n_faults == 0, t.fail(Sr::Sr5, "a fault event outside Fault")),
        }
        if t.prev == State::SoftEstop && !matches!(st, State::SoftEstop | State::Fault) {
            ensure!(
                t.enable_sent && t.enabled == Some(st),
                t.fail(Sr::Sr5, "left SoftEstop without an accepted enable")
            );
        }
        if t.home_sent && matches!(t.prev, State::SoftEstop | State::Fault) {
            ensure!(!t.accepted, t.fail(Sr::Sr5, "HOME accepted while a soft E-stop or fault is latched"));
            if matches!(t.sent, Some(Sent::Home)) {
                ensure!(
                    matches!(t.rejected, Some((_, Reject::Latched))),
                    t.fail(Sr::Sr5, "HOME while latched refused for a reason other than Latched")
                );
            }
        }
        Ok(())
    }

    /// SR-6: enable is refused while a cause is present in this tick's
    /// sensors or state; after it, set-points are the measured positions
    /// and the timeout is disarmed.
    pub(crate) fn check_enable(&mut self, t: &TickFacts<'_, S>) -> Checked {
        let (out, st) = (t.out, t.st);
        // SR-6, liveness: a cause named by a refusal is real. After the arm
        // has rested with nothing injected for `QUIET_TICKS` the estimates
        // have settled, so no speed is a cause, and a lost encoder, a switch
        // or a hardware fault must be in this tick's sensors (this catches
        // a frozen estimate of a lost encoder that blocks enable for good).
        if let (true, Some(p)) = (t.enable_sent, t.plant) {
            if p.quiet_ticks >= QUIET_TICKS {
                if matches!(t.prev, State::Fault | State::SoftEstop) {
                    inc(&mut self.stats.quiet_enables);
                }
                for e in out.events.iter() {
                    if let Event::Rejected { reason: Reject::CauseActive(c), .. } = e {
                        let real = match *c {
                            FaultReason::Runaway { .. } => false,
                            FaultReason::EncoderLost { axis } => {
                                !t.sense.encoders.get(usize::from(axis)).is_some_and(is_count)
                            }
                            FaultReason::LimitSwitch { axis } => {
                                t.sense.limits & out.status.homed & bit(usize::from(axis)) != 0
                            }
                            FaultReason::Hardware(_) => t.sense.hardware_fault.is_some(),
                            _ => true,
                        };
                        ensure!(
                            real,
                            t.fail(Sr::Sr6, "enable refused for a cause not present after the arm rested")
                                .got(f64::from(p.quiet_ticks))
                        );
                    }
                }
            }
        }
        if t.enable_sent {
            if matches!(t.prev, State::Fault | State::SoftEstop) && t.sensed_cause {
                ensure!(t.enabled.is_none(), t.fail(Sr::Sr6, "enable accepted with a cause in the sensors"));
            }
            if !matches!(t.prev, State::Fault | State::SoftEstop) {
                ensure!(t.enabled.is_none(), t.fail(Sr::Sr6, "enable accepted with nothing latched"));
            }
        }
        if let Some(s) = t.enabled {
            ensure!(t.enable_sent, t.fail(Sr::Sr6, "Enabled without an enable request"));
            ensure!(
                matches!(t.prev, State::Fault | State::SoftEstop),
                t.fail(Sr::Sr6, "enabled from a state not latched")
            );
            ensure!(!t.sensed_cause, t.fail(Sr::Sr6, "enabled with a cause in the sensors"));
            ensure!(t.n_faults == 0, t.fail(Sr::Sr6, "enabled and faulted in the same tick"));
            ensure!(
                s == st && matches!(st, State::Operational | State::Unhomed),
                t.fail(Sr::Sr6, "enabled into a state other than Operational or Unhomed")
            );
            ensure!(!out.status.timeout_armed, t.fail(Sr::Sr6, "timeout armed after enable"));
            for (i, ((sp, x), (v, j))) in out
                .status
                .setpoint
                .iter()
                .zip(out.status.position.iter())
                .zip(out.status.velocity.iter().zip(cfg_joints(&self.cfg)))
                .enumerate()
            {
                ensure!(
                    sp == x,
                    t.fail(Sr::Sr6, "set-point differs from the position after enable").on(i).got(f(*sp)).bound(f(*x))
                );
                ensure!(
                    v.abs() <= S::from_f32(j.max_velocity),
                    t.fail(Sr::Sr6, "enabled while the axis moves above vmax")
                        .on(i)
                        .got(f(*v))
                        .bound(f64::from(j.max_velocity))
                );
            }
            if st == State::Operational {
                ensure!(out.status.homed == ALL, t.fail(Sr::Sr6, "Operational after enable but not every joint homed"));
            }
        }
        Ok(())
    }
}
