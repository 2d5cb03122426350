//! One tick of the model: the kernel's tick on the environment's choice,
//! and every transition check on it.

use crate::checks::{Check, Checks};
use crate::config::MODEL_CONFIG;
use crate::environment::{Action, Perturb, Req};
use crate::identity::ModelScalar;
use crate::model::Supervisor;
use crate::state::{St, J1};
use kernel::config::{AXES, HOMING_GROUPS};
use kernel::homing::Phase;
use kernel::{EncoderSample, Event, FaultReason, RequestKind, Scalar, State};
use proofs::setup::{COUNTS, SEED_DEPENDENCIES};

/// The joint angle of count `c` on axis `i` before homing (zero offset 0).
pub(crate) fn angle<S: Scalar>(i: usize, c: u16) -> S {
    let j = &MODEL_CONFIG.joints[i];
    let sign = if j.encoder_reversed { -1 } else { 1 };
    S::from_counts(i32::from(c) * sign, S::wide_from_f64(j.rad_per_count()))
}

/// A value as f64 (to 1e-9: every I8F24 and every f32 the model meets).
pub(crate) fn f64v<S: Scalar>(x: S) -> f64 {
    x.to_scaled_int(1_000_000_000) as f64 / 1e9
}

pub(crate) fn zero<S: Scalar>(o: &[S; AXES]) -> bool {
    o.iter().all(|v| *v == S::ZERO)
}

impl<S: ModelScalar> Supervisor<S> {
    /// SR-14: a homing run re-zeroes every axis it homes: an axis of the run
    /// is not homed before its zero is captured (also when it was homed
    /// before the run: re-homing), and a run that ends (not failed) has
    /// homed all of its axes.
    pub(crate) fn rehoming_checks<'e>(
        &self,
        s: &St<S>,
        n: &St<S>,
        events: impl Iterator<Item = &'e Event>,
        c: &mut Checks,
    ) {
        if n.k.state() == State::Homing {
            let phases = n.k.homing_phases();
            for (i, p) in phases.iter().enumerate() {
                let before_capture = matches!(p, Phase::Waiting | Phase::FastSeek | Phase::BackOff | Phase::SlowSeek);
                c.check(Check::HomedBeforeCapture, before_capture, n.k.homed() & (1 << i) == 0);
            }
        }
        for e in events {
            if let Event::HomingStarted { mask } = e {
                c.check(Check::RehomeClears, s.k.homed() & mask != 0, n.k.homed() & mask == 0);
            }
            if let Event::HomingDone { mask } = e {
                // (A fault in the same tick may un-home a joint whose
                // encoder count was lost: SR-11.)
                let ended = s.k.state() == State::Homing && n.k.state() != State::Fault;
                c.check(Check::RunHomes, ended, n.k.homed() & mask == *mask);
            }
        }
    }

    /// SR-14, SR-16: an axis that finished its phases (`Done`) while a
    /// sibling of its group still moves waits for the group: its output is
    /// zero, it stays `Done`, and no homing fault names it (its timeout and
    /// travel bound no longer run). Returns whether this tick completed
    /// such a group: every axis of it `Done`, the run going on.
    pub(crate) fn wait_checks<'e>(
        &self,
        s: &St<S>,
        n: &St<S>,
        out: &[S; AXES],
        events: impl Iterator<Item = &'e Event>,
        c: &mut Checks,
    ) -> bool {
        if s.k.state() != State::Homing {
            return false;
        }
        let (before, after) = (s.k.homing_phases(), n.k.homing_phases());
        let homing = n.k.state() == State::Homing;
        // The axes a homing fault of this tick names.
        let named = events.fold(0u8, |m, e| match e {
            Event::Fault(FaultReason::HomingTimeout { axis, .. } | FaultReason::HomingTravel { axis, .. }) => {
                m | 1u8.checked_shl(u32::from(*axis)).unwrap_or(0)
            }
            _ => m,
        });
        let mut completed = false;
        for g in HOMING_GROUPS {
            let in_group = |i: &usize| g & (1 << i) != 0;
            if !(0..AXES).filter(in_group).any(|i| before[i].is_moving()) {
                continue;
            }
            for i in (0..AXES).filter(in_group).filter(|i| before[*i] == Phase::Done) {
                let done = !homing || after[i] == Phase::Done;
                c.check(Check::WaitAtRest, true, out[i] == S::ZERO && done && named & (1 << i) == 0);
                completed |= homing && (0..AXES).filter(in_group).all(|j| after[j] == Phase::Done);
            }
        }
        completed
    }

    /// The successor of `s` on the environment's choice `a`, with the
    /// transition checks it violated recorded in it.
    pub(crate) fn step(&self, s: &St<S>, a: Action) -> St<S> {
        let mut n = s.clone();
        let Action { req, perturb, pressed } = a;
        let before = s.k.state();
        let sense = self.sense(perturb, pressed);
        let o = n.k.tick(&sense, req.map(|r| self.request(r)));
        if before == State::Homing
            && req.is_none()
            && perturb == Perturb::None
            && crate::coupling::ON.load(std::sync::atomic::Ordering::Relaxed)
        {
            crate::coupling::check(self, &s.k, pressed, &n.k, &o);
        }
        // A switch is a cause on a joint homed after the tick only (SR-6,
        // SR-10: an unhomed joint's switch is its homing input, and an
        // enable unhomes a joint whose encoder count was lost).
        let cause = sense.limits & o.status.homed & 0x3f != 0
            || sense.hardware_fault.is_some()
            || sense.encoders.contains(&EncoderSample::Lost);
        let out = o.act.velocity;
        let st = o.status.state;
        let has = |f: &dyn Fn(&Event) -> bool| o.events.iter().any(f);
        let mut c = Checks::default();
        // Outputs.
        c.check(
            Check::IdleOutput,
            matches!(st, State::Boot | State::Unhomed | State::SoftEstop | State::Fault),
            zero(&out),
        );
        c.check(Check::FaultTickOutput, has(&|e| matches!(e, Event::Fault(_))), zero(&out));
        c.check(Check::Finite, true, out.iter().chain(o.status.position.iter()).all(|x| x.is_finite()));
        if matches!(st, State::Stopping | State::SoftEstop) && matches!(before, State::Stopping | State::SoftEstop) {
            let prev = s.k.last_output();
            let faster = (0..AXES).any(|i| {
                let (a, b) = (out[i], prev[i]);
                a.abs() > b.abs() || (a != S::ZERO && (a > S::ZERO) != (b > S::ZERO))
            });
            c.check(Check::StopMonotone, true, !faster);
        }
        // SR-7: the ramp's envelope is v0 (N - k) / N on every axis (within
        // rounding): every output lies between zero and it (a joint follows
        // its braking set-point inside it, so it may stop earlier), and
        // every axis is exactly zero at k = N.
        let stop_ticks = MODEL_CONFIG.soft_stop_ms * MODEL_CONFIG.tick_hz / 1000;
        n.ramp = match (s.ramp, st) {
            // (A fault in the timeout's tick zeroes everything instead.)
            _ if st == State::Stopping && has(&|e| matches!(e, Event::SoftEstop { .. })) => {
                Some((1, s.k.last_output()))
            }
            (Some((k, v0)), State::Stopping | State::SoftEstop) if before == State::Stopping => Some((k + 1, v0)),
            _ => None,
        };
        if let Some((k, v0)) = n.ramp {
            let left = f64::from(stop_ticks.saturating_sub(k)) / f64::from(stop_ticks);
            let outside = (0..AXES).any(|i| {
                let (want, got) = (f64v(v0[i]) * left, f64v(out[i]));
                got.abs() > want.abs() + 1e-6 * (1.0 + want.abs()) || (got != 0.0 && (got > 0.0) != (want > 0.0))
            });
            c.check(Check::RampEnvelope, true, !outside);
            c.check(Check::RampEnds, true, (k >= stop_ticks) == (st == State::SoftEstop));
            c.check(Check::RampZero, k >= stop_ticks, zero(&out));
        }
        if st == State::Homing {
            let phases = n.k.homing_phases();
            for i in 0..AXES {
                let needs = SEED_DEPENDENCIES[i];
                if phases[i].is_moving() {
                    c.check(Check::HomingOrder, true, n.k.homed() & needs == needs);
                } else {
                    c.check(Check::HomingIdleAxis, true, out[i] == S::ZERO);
                }
            }
        }
        self.rehoming_checks(s, &n, o.events.iter(), &mut c);
        n.group_waited = self.wait_checks(s, &n, &out, o.events.iter(), &mut c);
        // SR-10: a homed joint's pressed switch faults in the same tick in
        // Operational, Stopping, SoftEstop, and during homing at rest (an
        // unhomed joint's switch is its homing input in every state).
        // (Not in the tick a HOME is accepted: the switch is then a homing
        // input of a run that starts before the check.)
        let phases_before = s.k.homing_phases();
        // Nor in the tick a per-joint run ends in Unhomed (SR-10 does not
        // list Unhomed: a homed J6's switch pressed in that tick, or later
        // in Unhomed, does not fault).
        let homing_started = has(&|e| matches!(e, Event::HomingStarted { .. }));
        let ended_unhomed = has(&|e| matches!(e, Event::HomingDone { .. })) && st == State::Unhomed;
        let switch_is_fault = !homing_started
            && !ended_unhomed
            && (0..AXES).any(|i| {
                sense.limits & s.k.homed() & (1 << i) != 0
                    && (matches!(before, State::Operational | State::Stopping | State::SoftEstop)
                        || (before == State::Homing && !phases_before[i].is_moving()))
            });
        c.check(Check::LimitSwitch, switch_is_fault, st == State::Fault);
        // SR-21: a hardware fault faults in the same tick, in every state.
        c.check(Check::HardwareFault, sense.hardware_fault.is_some(), st == State::Fault);
        // SR-11: the (limit + 1)-th consecutive invalid J1 sample (lost, or
        // more than the plausibility window from the count J1 was
        // initialised from) faults in the same tick; fewer are ridden through.
        let limit = MODEL_CONFIG.encoder_invalid_limit as u8;
        let j1 = sense.encoders[0];
        if s.j1.seen && s.j1.run > limit {
            // Faulted: the count is lost until an enable re-initialises J1
            // from its reading (SR-11: the joint must be homed again).
            if has(&|e| matches!(e, Event::Enabled(_))) {
                if let EncoderSample::Count(c) = j1 {
                    n.j1 = J1 { seen: true, reference: c, run: 0 };
                }
            }
        } else if s.j1.seen {
            let valid = j1 == EncoderSample::Count(s.j1.reference);
            n.j1.run = if valid { 0 } else { s.j1.run + 1 };
            let crossed = s.j1.run <= limit && n.j1.run == limit + 1;
            c.check(Check::EncoderFaultInTime, crossed, st == State::Fault);
            let j1_fault = has(&|e| {
                matches!(
                    e,
                    Event::Fault(FaultReason::EncoderLost { axis: 0 } | FaultReason::EncoderJump { axis: 0, .. })
                )
            });
            c.check(Check::EncoderRideThrough, n.j1.run <= limit && !valid, !j1_fault);
        } else if let EncoderSample::Count(c) = j1 {
            n.j1 = J1 { seen: true, reference: c, run: 0 };
        }
        // SR-1: when the kernel leaves Boot, every estimate is at rest at
        // the angle of the axis's first reading (J1's may be this tick's).
        if has(&|e| matches!(e, Event::Ready)) {
            let off = (0..AXES).any(|i| {
                let c = if i == 0 { n.j1.reference } else { COUNTS[i] };
                o.status.position[i] != angle::<S>(i, c) || o.status.velocity[i] != S::ZERO
            });
            c.check(Check::BootAtRest, true, !off);
        }
        // Requests.
        let latched = matches!(before, State::Fault | State::SoftEstop);
        c.check(
            Check::EnableWithCause,
            req == Some(Req::Enable) && latched && cause,
            matches!(st, State::Fault | State::SoftEstop),
        );
        // SR-6: after an accepted enable the set-points are the measured
        // positions.
        let enabled = has(&|e| matches!(e, Event::Enabled(_)));
        c.check(Check::EnableSync, enabled, (0..AXES).all(|i| o.status.setpoint[i] == o.status.position[i]));
        let motion = matches!(req, Some(Req::MotionNear | Req::MotionHere | Req::MotionFar | Req::MotionOutOfLimits));
        let rejected = has(&|e| matches!(e, Event::Rejected { request: RequestKind::Motion, .. }));
        c.check(Check::MotionOutsideOperational, motion && before != State::Operational, rejected);
        c.check(Check::OutOfLimits, req == Some(Req::MotionOutOfLimits), rejected);
        n.far = if motion && !rejected { req == Some(Req::MotionFar) } else { s.far } && !n.k.setpoints_at_rest();
        // SR-8: armed only by an accepted motion, disarmed by homing and
        // enable.
        c.check(Check::ArmedAfterHoming, has(&|e| matches!(e, Event::HomingDone { .. })), !o.status.timeout_armed);
        c.check(Check::ArmedOnlyByMotion, !s.k.status(0).timeout_armed && o.status.timeout_armed, motion && !rejected);
        c.check(Check::DisarmedByEnableOrHoming, enabled || homing_started, !o.status.timeout_armed);
        // SR-5: a latch keeps its first reason and only an accepted enable
        // leaves it.
        c.check(
            Check::LatchReason,
            before == State::Fault && st == State::Fault,
            s.k.fault().map(|f| f.reason) == o.status.fault.map(|f| f.reason),
        );
        c.check(Check::LatchLeftOnlyByEnable, latched, matches!(st, State::Fault | State::SoftEstop) || enabled);
        c.check(Check::FaultReason, true, (st == State::Fault) == o.status.fault.is_some());
        // SR-6/31: recoverability, judged where a latch is entered (or a
        // stop toward one starts; the states that stay latched are the same
        // kernel with one-tick perturbations, which the recovery does not
        // repeat), and for a link lost in every homing state.
        let entering = matches!(st, State::SoftEstop | State::Fault | State::Stopping) && st != before;
        if entering {
            c.check(Check::Recoverable, true, self.recovers(&n.k, pressed));
        }
        if st == State::Homing {
            c.check(Check::Recoverable, true, self.recovers_from_link_loss(&n.k, pressed));
        }
        // The boot's length forgotten (`boot`): an exact merge.
        let merges = !crate::boot::OFF.load(std::sync::atomic::Ordering::Relaxed);
        if merges && before == State::Boot && st != State::Boot {
            if let Some(k) = self.short_boot(&n.k, &sense, req.map(|r| self.request(r))) {
                n.k = k;
            }
        }
        n.violated |= c.violated;
        n.enabled = enabled || (!merges && s.enabled);
        n.ticks = s.ticks.saturating_add(1);
        c.record();
        crate::census::note(&n);
        n
    }
}
