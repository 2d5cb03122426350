//! The per-axis pipeline: the state of one axis ([`Axis`]) and what is done
//! to each axis every tick: **sense** (is the encoder sample valid and
//! plausible?), **estimate** (exact unwrap, alpha-beta observer) and
//! **control** (interpolate, control law; computed in every mode, kept in
//! Operational and the soft stop by `Kernel::motion`). The kernel runs
//! these for all six axes in a fixed order; nothing here changes the
//! supervisor's mode.

use super::params::{AxisParams, Params};
use super::Kernel;
use crate::config::COUNTS_PER_REV;
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
    /// Following error against the commanded path `path`: farther than
    /// `fe`, or more than half of it off while moving against the command
    /// applied last tick (`cmd`), for more than `fe_ticks` ticks is a
    /// fault. Returns the count of consecutive ticks with an error and
    /// whether it is a fault; changes nothing.
    fn following(&self, path: S, cmd: S, p: &AxisParams<S>, k: &Params<S>) -> (u32, bool) {
        let e = path.minus(self.obs.x);
        let v = self.obs.v;
        let min = p.dir_speed;
        let against = (cmd > min && v < min.neg()) || (cmd < min.neg() && v > min);
        let away = e.abs() > k.fe_half && against;
        let bad = e.abs() > k.fe || away;
        let count = if bad { self.fe_count.saturating_add(1) } else { 0 };
        (count, count > k.fe_ticks)
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

    /// This axis's set-point step and control-law command, computed and
    /// not kept: the interpolator after its step, the set-point of this
    /// tick (where the joint should be now), the command (the feed-forward
    /// is the set-point's velocity, which takes it to the next one, so the
    /// joint does not lag by a tick) and whether every input of the law was
    /// finite.
    pub(super) fn control(&self, p: &AxisParams<S>, k: &Params<S>) -> (Interpolator<S>, S, S, bool) {
        let mut interp = self.interp;
        let sp = interp.setpoint();
        let (_, ff) = interp.advance(&p.profile);
        let (v, ok) = control_law(sp, ff, self.obs.x, p.kp, p.vmax, k.deadband);
        (interp, sp, v, ok)
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

    /// Following error of every axis, computed in every mode and kept in
    /// a moving one (`checked = Some(integrate)`). With `integrate` (Stopping
    /// and Homing) the commanded path first advances by last tick's output
    /// (Operational set it to the set-point in [`Kernel::motion`]).
    pub(super) fn following(&mut self, checked: Option<bool>, fault: &mut Option<FaultReason>) {
        let k = &self.p;
        let integrate = checked == Some(true);
        for (i, ((ax, prev), p)) in self.axes.iter_mut().zip(self.last_out.iter()).zip(k.axes.iter()).enumerate() {
            let path = S::select(integrate, ax.path.plus(prev.times(k.gains.dt)), ax.path);
            // Computed in every mode (`black_box`: the compiler may not move
            // it under the condition that keeps it).
            let (count, bad) = core::hint::black_box(ax.following(path, *prev, p, k));
            if checked.is_some() {
                ax.path = path;
                if ax.ready && !ax.needs_reinit {
                    ax.fe_count = count;
                    if bad {
                        fault.get_or_insert(FaultReason::FollowingError { axis: i as u8 });
                    }
                }
            }
        }
    }
}
