//! The per-axis pipeline: the state of one axis ([`Axis`]) and what is done
//! to each axis every tick: **sense** (is the encoder sample valid and
//! plausible?), **estimate** (exact unwrap, alpha-beta observer) and
//! **control** in Operational (interpolate, control law, acceleration
//! limit). The kernel runs these for all six axes in a fixed order; nothing
//! here changes the supervisor's mode.

use super::params::{AxisParams, Params};
use super::Kernel;
use crate::config::{AXES, COUNTS_PER_REV};
use crate::control::control_law;
use crate::homing::AxisHoming;
use crate::interp::Interpolator;
use crate::observer::{AlphaBeta, Unwrapper};
use crate::scalar::Scalar;
use crate::types::{EncoderSample, FaultReason, Sense};

/// Per-axis state.
#[derive(Clone, Copy, Debug, PartialEq, Hash)]
pub(crate) struct Axis<S: Scalar> {
    pub ready: bool,
    pub unwrap: Unwrapper,
    pub obs: AlphaBeta<S>,
    pub interp: Interpolator<S>,
    pub zero: S,
    pub homing: AxisHoming<S>,
    /// The unwrapped count can no longer be trusted (encoder fault).
    pub needs_reinit: bool,
    /// Consecutive invalid or implausible samples (the observer coasts).
    pub invalid: u32,
    /// The commanded path (rad): the set-point in Operational, the integral
    /// of the applied commands in Stopping and Homing.
    pub path: S,
    /// Consecutive ticks with a following error.
    pub fe_count: u32,
}

impl<S: Scalar> Axis<S> {
    pub(super) fn new() -> Self {
        Axis {
            ready: false,
            unwrap: Unwrapper::new(0),
            obs: AlphaBeta::at(S::ZERO),
            interp: Interpolator::hold(S::ZERO),
            zero: S::ZERO,
            homing: AxisHoming::default(),
            needs_reinit: false,
            invalid: 0,
            path: S::ZERO,
            fe_count: 0,
        }
    }
    /// Holds the measured position: set-point and commanded path at the
    /// estimate, no following-error history.
    pub(super) fn resync(&mut self) {
        self.interp = Interpolator::hold(self.obs.x);
        self.path = self.obs.x;
        self.fe_count = 0;
    }
    /// Following error against the commanded path: farther than `fe`, or
    /// more than half of it off while moving against the command applied
    /// last tick (`cmd`), for more than `fe_ticks` ticks is a fault.
    fn following(&mut self, axis: u8, cmd: S, p: &AxisParams<S>, k: &Params<S>, fault: &mut Option<FaultReason>) {
        let e = self.path.minus(self.obs.x);
        let v = self.obs.v;
        let min = p.dir_speed;
        let against = (cmd > min && v < min.neg()) || (cmd < min.neg() && v > min);
        let away = e.abs() > k.fe_half && against;
        let bad = e.abs() > k.fe || away;
        self.fe_count = if bad { self.fe_count.saturating_add(1) } else { 0 };
        if self.fe_count > k.fe_ticks {
            fault.get_or_insert(FaultReason::FollowingError { axis });
        }
    }
    /// The measured joint angle from the unwrapped count.
    fn measured(&self, p: &AxisParams<S>) -> S {
        S::from_counts(self.unwrap.total().saturating_mul(p.enc_sign), p.k_count).plus(self.zero)
    }
    /// (Re)starts from a real reading: observer at rest on it.
    pub(super) fn init_from(&mut self, count: u16, p: &AxisParams<S>) {
        self.unwrap = Unwrapper::new(count);
        self.ready = true;
        self.needs_reinit = false;
        self.invalid = 0;
        self.obs = AlphaBeta::at(self.measured(p));
        self.resync();
    }

    /// Sense and estimate for this axis (index `axis`): start from the first
    /// real reading, or check the sample and step (or coast) the observer;
    /// the first fault found is kept in `fault`.
    fn sense_and_estimate(
        &mut self,
        axis: u8,
        sample: EncoderSample,
        p: &AxisParams<S>,
        k: &Params<S>,
        fault: &mut Option<FaultReason>,
    ) {
        let count = match sample {
            EncoderSample::Count(c) if i32::from(c) < COUNTS_PER_REV => Some(c),
            _ => None,
        };
        if !self.ready {
            // Boot (or after a boot timeout): start from the first real reading.
            if let Some(c) = count {
                self.init_from(c, p);
            }
        } else if self.needs_reinit {
            // Count lost under a latched fault; enable re-initialises it.
        } else {
            // A lost or implausible sample is skipped and the observer
            // coasts; more than `invalid_limit` in a row is a fault. The
            // plausibility window grows with the samples skipped.
            // The window is multiplied by the samples skipped plus one (not
            // grown by one tick each): the twin showed the encoder decoder's
            // readings off by up to 10 % of the count until it has measured
            // a fast MT6816's frame period (127 counts on J1 at 5 % fast, at
            // rest, at boot); the wider window rides through them (the
            // decoder does not yet report them as lost: SAFETY.md section 8).
            let window = p.max_jump.unsigned_abs().saturating_mul(self.invalid.saturating_add(1));
            let delta = count.map(|c| (c, self.unwrap.delta(c)));
            match delta {
                Some((c, d)) if d.unsigned_abs() <= window => {
                    self.invalid = 0;
                    self.unwrap.update(c);
                    let z = self.measured(p);
                    self.obs.step(z, &k.gains);
                }
                _ => {
                    self.invalid = self.invalid.saturating_add(1);
                    self.obs.coast(&k.gains);
                    if self.invalid > k.invalid_limit {
                        let reason = match delta {
                            Some((_, d)) => FaultReason::EncoderJump { axis, delta: d },
                            None => FaultReason::EncoderLost { axis },
                        };
                        fault.get_or_insert(reason);
                        self.needs_reinit = true;
                    }
                }
            }
        }
        let x = self.obs.x;
        let v = self.obs.v;
        let plausible = x.is_finite() && v.is_finite() && x.abs() < k.pos_abs && v.abs() < k.vel_abs;
        if self.ready && !plausible {
            fault.get_or_insert(FaultReason::Numeric { axis });
        }
    }

    /// Control for this axis in Stopping: the set-point keeps braking to
    /// its target; the control law's command, which the ramp envelope then
    /// bounds. The commanded path is the integral of the outputs here.
    pub(super) fn brake(&mut self, axis: u8, p: &AxisParams<S>, k: &Params<S>, fault: &mut Option<FaultReason>) -> S {
        let sp = self.interp.setpoint();
        let (_, ff) = self.interp.advance(&p.profile);
        let (v, ok) = control_law(sp, ff, self.obs.x, p.kp, p.vmax, k.deadband);
        if !ok {
            fault.get_or_insert(FaultReason::Numeric { axis });
        }
        v
    }

    /// Control for this axis in Operational: interpolate, control law,
    /// saturate, then limit the change from `prev` (last tick's output).
    fn follow(&mut self, axis: u8, p: &AxisParams<S>, prev: S, k: &Params<S>, fault: &mut Option<FaultReason>) -> S {
        // The set-point of this tick is where the joint should be now; the
        // feed-forward is the velocity that takes it to the next one (so the
        // joint does not lag the set-point by a tick).
        let sp = self.interp.setpoint();
        let (_, ff) = self.interp.advance(&p.profile);
        self.path = sp;
        let (v, ok) = control_law(sp, ff, self.obs.x, p.kp, p.vmax, k.deadband);
        if !ok {
            fault.get_or_insert(FaultReason::Numeric { axis });
        }
        // Acceleration limit: within one tick's change of the last
        // output (which is within +-vmax, so the result is too). The bounds
        // are ordered (`accel_step >= 0`: `config::check`), so no
        // reordering (`clamp_between`'s): the same value, two minNum /
        // maxNum fewer.
        v.max(prev.minus(p.accel_step)).min(prev.plus(p.accel_step))
    }
}

impl<S: Scalar> Kernel<S> {
    /// Steps 1-2 for every axis: sense and estimate.
    pub(super) fn sense_and_estimate(&mut self, sense: &Sense, fault: &mut Option<FaultReason>) {
        let k = &self.p;
        for (i, ((ax, p), sample)) in self.axes.iter_mut().zip(k.axes.iter()).zip(sense.encoders.iter()).enumerate() {
            ax.sense_and_estimate(i as u8, *sample, p, k, fault);
        }
    }

    /// Following error of every axis in a moving mode. In Stopping and
    /// Homing the commanded path first advances by last tick's output
    /// (Operational set it to the set-point in `follow`).
    pub(super) fn following(&mut self, integrate: bool, fault: &mut Option<FaultReason>) {
        let k = &self.p;
        for (i, ((ax, prev), p)) in self.axes.iter_mut().zip(self.last_out.iter()).zip(k.axes.iter()).enumerate() {
            if integrate {
                ax.path = ax.path.plus(prev.times(k.gains.dt));
            }
            if ax.ready && !ax.needs_reinit {
                ax.following(i as u8, *prev, p, k, fault);
            }
        }
    }

    /// Operational: interpolate, control law, saturate, for every axis.
    pub(super) fn follow(&mut self, out: &mut [S; AXES], fault: &mut Option<FaultReason>) {
        let k = &self.p;
        let axes = self.axes.iter_mut().zip(k.axes.iter()).zip(out.iter_mut()).zip(self.last_out.iter());
        for (i, (((ax, p), o), prev)) in axes.enumerate() {
            *o = ax.follow(i as u8, p, *prev, k, fault);
        }
    }
}
