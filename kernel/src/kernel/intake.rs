//! Command intake: at most one [`Request`] per tick, checked and applied
//! after estimation (so it sees this tick's measurements) and before
//! supervision (so its effect is checked in the same tick). Motion targets
//! are validated whole ([`TargetLimits`](super::TargetLimits)) and retarget
//! the interpolators; home and per-joint home start the sequencer; enable
//! needs this kernel's own [`EnableCapability`](crate::EnableCapability) and
//! no fault cause present. Each refusal is a [`Reject`]; the mode changes
//! this causes go through `Kernel::transition`.

use super::params::AxisParams;
use super::supervisor::Edge;
use super::{bit, Kernel, ALL};
use crate::config::AXES;
use crate::interp::Interpolator;
use crate::scalar::Scalar;
use crate::types::{
    EncoderSample, Event, Events, FaultReason, HomingStatus, MotionKind, MotionTarget, Reject, Request, RequestKind,
    Sense, State,
};

/// Longest time (ticks) a sample's distance from the previous one is
/// judged over (a shorter cap only tightens the bound; the PAROL6's command
/// timeout, 100 ms, ends a silent stream long before).
const MAX_SAMPLE_GAP: u32 = 1000;

/// Median of four values (mean of the middle two), with a fixed network of
/// comparisons: bounded, branch-light, no indexing.
fn median4(v: [u32; 4]) -> u32 {
    let [a, b, c, d] = v;
    let (a, b) = (a.min(b), a.max(b));
    let (c, d) = (c.min(d), c.max(d));
    let lo2 = a.max(c); // second smallest is max of the two minima or ...
    let hi2 = b.min(d); // ... together with the min of the two maxima
    let (m1, m2) = (lo2.min(hi2), lo2.max(hi2));
    m1.midpoint(m2)
}

impl<S: Scalar> Kernel<S> {
    /// Handles the tick's request, if any, and reports the outcome:
    /// `Rejected` with the reason, or the request's own event.
    /// `detected`: the fault found so far in this tick (blocks an enable).
    pub(super) fn intake(
        &mut self,
        request: Option<Request<S>>,
        sense: &Sense,
        detected: Option<FaultReason>,
        events: &mut Events,
    ) {
        if let Some(r) = request {
            let kind = r.kind();
            if let Err(reason) = self.handle(r, sense, detected) {
                events.push(Event::Rejected { request: kind, reason });
            } else if let Some(e) = self.request_event(kind) {
                events.push(e);
            }
        }
    }

    fn request_event(&self, kind: RequestKind) -> Option<Event> {
        match kind {
            RequestKind::Home if self.home_queued => Some(Event::HomingQueued),
            RequestKind::Home | RequestKind::HomeJoint(_) if self.state() == State::Stopping => {
                Some(Event::HomingAfterStop)
            }
            RequestKind::Home | RequestKind::HomeJoint(_) => Some(Event::HomingStarted { mask: self.run_mask }),
            RequestKind::Enable => Some(Event::Enabled(self.state())),
            RequestKind::Motion => None,
        }
    }

    fn handle(&mut self, r: Request<S>, sense: &Sense, detected: Option<FaultReason>) -> Result<(), Reject> {
        match r {
            Request::Motion(t) => self.accept_motion(&t),
            Request::Home if self.state() == State::Boot => {
                self.home_queued = true;
                self.homing_status = HomingStatus::InProgress;
                Ok(())
            }
            Request::Home => self.start_homing(ALL),
            Request::HomeJoint(j) => {
                let j = usize::from(j);
                if j >= AXES {
                    return Err(Reject::NoSuchJoint);
                }
                let needs = Self::dependencies(j);
                if self.homed & needs != needs {
                    return Err(Reject::DependencyNotHomed { needs: needs & !self.homed });
                }
                self.start_homing(bit(j))
            }
            Request::Enable(cap) if cap.kernel() != self.id => Err(Reject::ForeignCapability),
            Request::Enable(_) => self.enable(sense, detected),
        }
    }

    /// Validates a target against every joint's limits; the frame is
    /// accepted whole or not at all.
    pub fn validate(&self, t: &MotionTarget<S>) -> Result<(), Reject> {
        self.p.limits.check(t)
    }

    fn accept_motion(&mut self, t: &MotionTarget<S>) -> Result<(), Reject> {
        if let Some(r) = self.mode_refusal() {
            return Err(r);
        }
        self.validate(t)?;
        if t.kind == MotionKind::Stream {
            // Stream continuity (SR-30): every axis's sample continues its
            // stream, or lies where the set-point can be within one
            // segment. The stream is live (its previous sample is every
            // interpolator's target) while the timeout is armed: a hold or
            // latch at the timeout, an enable, homing and a go-to forget it.
            let live = self.armed;
            // Samples in a burst arrive closer than they were sampled: the
            // time between two is at least one longest segment.
            let ticks = i32::try_from(self.since_cmd.max(self.p.seg_max).min(MAX_SAMPLE_GAP)).unwrap_or(0);
            for (i, ((ax, p), x)) in self.axes.iter().zip(self.p.axes.iter()).zip(t.position.iter()).enumerate() {
                let from_last = x.minus(ax.interp.target()).abs();
                let continues = live && from_last <= p.sample_step.times_int(ticks).plus(p.jump_tol);
                if !(continues || Self::within_reach(&ax.interp, *x, p)) {
                    return Err(Reject::TargetJump { axis: i as u8 });
                }
            }
        }
        let n = match (t.kind, self.since_target) {
            (MotionKind::GoTo, _) => 0,
            (MotionKind::Stream, None) => self.p.seg_max,
            (MotionKind::Stream, Some(gap)) => {
                // Segment length: median of recent target intervals,
                // bounded. max/min rather than `clamp`, which panics if
                // min > max: the tick must have no panic path even for a
                // bad configuration.
                let gap = gap.max(self.p.seg_min).min(self.p.seg_max);
                let [_, a, b, c] = self.intervals;
                self.intervals = if self.intervals == [0; 4] { [gap; 4] } else { [a, b, c, gap] };
                median4(self.intervals)
            }
        };
        let n = i32::try_from(n).map_err(|_| Reject::Internal)?;
        let hz = self.p.tick_hz;
        for ((ax, p), target) in self.axes.iter_mut().zip(self.p.axes.iter()).zip(t.position.iter()) {
            // Go-to: the speed limit; stream: the distance over the typical
            // interval (the profile bounds it to the speed limit).
            let speed = S::select(n == 0, p.vmax, target.minus(ax.interp.setpoint()).abs().times_int(hz).div_int(n));
            ax.interp.retarget(*target, speed, &p.profile);
        }
        if t.kind == MotionKind::Stream {
            self.since_target = Some(0);
            self.armed = true;
        } else {
            // A go-to completes without further commands: no timeout, and
            // the next stream starts a fresh interval history.
            self.since_target = None;
            self.intervals = [0; 4];
            self.armed = false;
        }
        self.since_cmd = 0;
        Ok(())
    }

    /// Where the set-point can be within one longest segment `T` from its
    /// velocity `v` (at the joint's acceleration `a`): between the
    /// set-point and `sp + v T +- a T^2 / 2`, plus the tolerance; and no
    /// farther inside its stopping distance than the tolerance (a sample
    /// it would run past, or away from, by more is refused).
    fn within_reach(it: &Interpolator<S>, x: S, p: &AxisParams<S>) -> bool {
        let (sp, v) = (it.setpoint(), it.velocity());
        let drift = sp.plus(v.times(p.reach_period));
        let lo = sp.min(drift.minus(p.reach_accel)).minus(p.jump_tol);
        let hi = sp.max(drift.plus(p.reach_accel)).plus(p.jump_tol);
        // How far the stopping point lies beyond both the set-point and the
        // sample, along the velocity.
        let stop = it.stop_point(&p.profile);
        let neg = v < S::ZERO;
        let ahead = |y: S| S::select(neg, y.neg(), y);
        let excursion = ahead(stop).minus(ahead(sp).max(ahead(x)));
        x >= lo && x <= hi && excursion <= p.jump_tol
    }

    /// `detected`: a fault condition found earlier in this same tick (it is
    /// latched at the end of the tick, so it must block the enable too).
    fn enable(&mut self, sense: &Sense, detected: Option<FaultReason>) -> Result<(), Reject> {
        if let Some(r) = self.enable_refusal() {
            return Err(r);
        }
        if let Some(cause) = detected.or_else(|| self.present_cause(sense)) {
            return Err(Reject::CauseActive(cause));
        }
        // Encoders whose count was lost restart from their reading; their
        // joints must be homed again.
        for (i, ((ax, p), s)) in self.axes.iter_mut().zip(self.p.axes.iter()).zip(sense.encoders.iter()).enumerate() {
            if let (true, EncoderSample::Count(c)) = (ax.needs_reinit || !ax.ready, *s) {
                ax.init_from(c, p);
                self.homed &= !bit(i);
            }
        }
        self.fault = None;
        self.resync();
        self.transition(Edge::Enable);
        if self.homed != ALL && self.homing_status == HomingStatus::Complete {
            self.homing_status = HomingStatus::NotRequested;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::median4;

    #[test]
    fn median_of_four() {
        assert_eq!(median4([10, 10, 10, 10]), 10);
        assert_eq!(median4([10, 20, 10, 10]), 10);
        assert_eq!(median4([20, 10, 10, 20]), 15);
        assert_eq!(median4([8, 40, 9, 11]), 10);
        assert_eq!(median4([u32::MAX, u32::MAX, 1, 1]), u32::MAX / 2 + 1);
    }
}
