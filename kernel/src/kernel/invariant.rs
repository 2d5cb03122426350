//! The kernel's state invariant ([`Kernel::invariant`]) and, for proofs
//! only, kernels built in any state that satisfies it
//! ([`Kernel::from_spec`], feature `proof-states`).
//!
//! The invariant is what every reachable state satisfies and what the
//! safety properties of one tick rest on. Evidence that it is one:
//! it holds in `Kernel::new`'s state; the Kani harnesses of
//! `proofs/src/state_props.rs` check that one tick from **any** state
//! satisfying it (built by `from_spec` from symbolic values), with any
//! sensors and any request, ends in a state satisfying it (induction);
//! the scenario tests, the property tests and the model exploration check
//! it on every tick they run.

use super::params::AxisParams;
use super::supervisor::Mode;
use super::{Kernel, ALL};
use crate::homing::Phase;
use crate::ramp;
use crate::scalar::Scalar;

impl<S: Scalar> Kernel<S> {
    /// The soft-stop envelope's scale at ramp tick `k`: `(N - k) / N`
    /// ([`ramp::stop_scale`]); the ramp and the invariant both use it.
    pub(super) fn stop_scale(&self, k: u32) -> S {
        let left = i32::try_from(self.p.stop_ticks.saturating_sub(k)).unwrap_or(0);
        ramp::stop_scale(self.p.inv_stop, left)
    }

    /// The state invariant. Every state reachable through [`Kernel::new`]
    /// and [`Kernel::tick`] satisfies it:
    ///
    /// 1. a fault is latched exactly in Fault;
    /// 2. the last outputs are finite and within each joint's speed limit;
    ///    exactly zero in Boot, Unhomed, SoftEstop and Fault;
    /// 3. Operational only with every joint homed; no joint is in a homing
    ///    phase outside Homing;
    /// 4. in Stopping at ramp tick `k <= N` from outputs `v0` (finite,
    ///    within the speed limits), each last output lies between zero and
    ///    `v0 (N - k) / N` (the envelope, as the ramp computes it);
    /// 5. outside Fault, every axis that has been read has a plausible
    ///    estimate (finite, inside the kernel's absolute bounds) and fewer
    ///    consecutive invalid samples and following-error ticks than
    ///    fault them;
    /// 6. every set-point is finite, with a finite target and a velocity
    ///    within the joint's speed limit;
    /// 7. the stream's timing: the recent target intervals are all zero
    ///    (none yet) or each within the segment range, and the ticks since
    ///    the last target at most the longest segment.
    pub fn invariant(&self) -> bool {
        let faulted = self.mode == Mode::Fault;
        let latched_ok = faulted == self.fault.is_some();
        let at_rest = matches!(self.mode, Mode::Boot | Mode::Unhomed | Mode::SoftEstop | Mode::Fault);
        let output_ok =
            |(o, p): (&S, &AxisParams<S>)| o.is_finite() && o.abs() <= p.vmax && (!at_rest || *o == S::ZERO);
        let outputs_ok = self.last_out.iter().zip(self.p.axes.iter()).all(output_ok);
        let homed_ok = self.mode != Mode::Operational || self.homed == ALL;
        let phases_ok = self.mode == Mode::Homing || self.axes.iter().all(|a| a.homing.phase() == Phase::Idle);
        let stop_ok = match self.mode {
            Mode::Stopping { k, v0, .. } => {
                let scale = self.stop_scale(k);
                k <= self.p.stop_ticks
                    && v0.iter().zip(self.last_out.iter()).zip(self.p.axes.iter()).all(|((v, o), p)| {
                        let env = v.times(scale);
                        v.is_finite() && v.abs() <= p.vmax && o.clamp_between(S::ZERO, env) == *o
                    })
            }
            _ => true,
        };
        let k = &self.p;
        let axes_ok = self.axes.iter().zip(k.axes.iter()).all(|(a, p)| {
            let (x, v) = (a.obs.x, a.obs.v);
            let plausible = x.is_finite() && v.is_finite() && x.abs() < k.pos_abs && v.abs() < k.vel_abs;
            let estimate_ok = faulted
                || !a.ready
                || a.needs_reinit
                || (plausible && a.invalid <= k.invalid_limit && a.fe_count <= k.fe_ticks);
            let it = &a.interp;
            let interp_ok = it.setpoint().is_finite()
                && it.target().is_finite()
                && it.velocity().is_finite()
                && it.velocity().abs() <= p.vmax;
            estimate_ok && interp_ok
        });
        let (lo, hi) = (k.seg_min, k.seg_max);
        let timing_ok = (self.intervals == [0; 4] || self.intervals.iter().all(|t| (lo..=hi).contains(t)))
            && self.since_target.is_none_or(|t| t <= hi);
        latched_ok && outputs_ok && homed_ok && phases_ok && stop_ok && axes_ok && timing_ok
    }
}

#[cfg(feature = "proof-states")]
pub use self::spec::*;

#[cfg(feature = "proof-states")]
mod spec {
    use super::super::axis::Axis;
    use super::super::supervisor::Mode;
    use super::super::Kernel;
    use crate::config::{Validated, AXES};
    use crate::interp::Interpolator;
    use crate::observer::{AlphaBeta, Unwrapper};
    use crate::scalar::Scalar;
    use crate::types::{Authority, Fault, FaultReason, HomingStatus};

    /// The supervisor's mode in a [`StateSpec`] (Boot and Homing are not
    /// offered: their state is a run in progress, reached by replay).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub enum SpecMode<S> {
        /// Homed or not, at rest, no motion accepted.
        Unhomed,
        /// Following set-points.
        Operational,
        /// The soft-stop ramp at tick `k` from outputs `v0`; `track`: the
        /// joints follow their braking set-points inside it.
        Stopping {
            /// Ramp tick.
            k: u32,
            /// Outputs the ramp started from.
            v0: [S; AXES],
            /// Following the braking set-points (entered from Operational).
            track: bool,
        },
        /// Latched soft E-stop.
        SoftEstop,
        /// Latched fault with this first reason.
        Fault(FaultReason),
    }

    /// One axis of a [`StateSpec`].
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct AxisSpec<S> {
        /// The last encoder reading accepted (the unwrapped count starts there).
        pub count: u16,
        /// The zero offset captured by homing (rad).
        pub zero: S,
        /// Observer estimate: position (rad) and velocity (rad/s).
        pub x: S,
        /// See `x`.
        pub v: S,
        /// Set-point, its target, velocity and cruising speed.
        pub setpoint: S,
        /// See `setpoint`.
        pub target: S,
        /// See `setpoint`.
        pub sp_velocity: S,
        /// See `setpoint`.
        pub speed: S,
        /// The output applied last tick (rad/s).
        pub last_out: S,
        /// The commanded path (rad).
        pub path: S,
        /// Consecutive following-error ticks.
        pub fe_count: u32,
        /// Consecutive invalid samples.
        pub invalid: u32,
    }

    /// A kernel state given field by field, for proofs that start from
    /// any state satisfying the invariant rather than a replay from
    /// power-on.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct StateSpec<S> {
        /// The mode.
        pub mode: SpecMode<S>,
        /// Joints homed (bit per joint).
        pub homed: u8,
        /// Per-axis state (every axis has been read).
        pub axes: [AxisSpec<S>; AXES],
        /// The command timeout is armed, and ticks since the last command.
        pub armed: bool,
        /// See `armed`.
        pub since_cmd: u32,
        /// Ticks since the last accepted target (`None` after a resync).
        pub since_target: Option<u32>,
        /// Recent target intervals (ticks).
        pub intervals: [u32; 4],
    }

    impl<S: Scalar> Kernel<S> {
        /// A kernel in the state `spec` describes, and its authority, if
        /// that state satisfies [`Kernel::invariant`]. Only with the
        /// `proof-states` feature, which the firmware and the simulator
        /// never enable.
        pub fn from_spec(config: &Validated, spec: &StateSpec<S>) -> Option<(Self, Authority)> {
            let (mut k, auth) = Kernel::new(config);
            k.mode = match spec.mode {
                SpecMode::Unhomed => Mode::Unhomed,
                SpecMode::Operational => Mode::Operational,
                SpecMode::Stopping { k, v0, track } => Mode::Stopping { k, v0, then_home: 0, track },
                SpecMode::SoftEstop => Mode::SoftEstop,
                SpecMode::Fault(_) => Mode::Fault,
            };
            if let SpecMode::Fault(reason) = spec.mode {
                k.fault = Some(Fault { reason, tick: 0 });
            }
            k.homed = spec.homed & super::ALL;
            k.homing_status = if k.homed == super::ALL { HomingStatus::Complete } else { HomingStatus::NotRequested };
            let axes = k.axes.iter_mut().zip(spec.axes.iter()).zip(k.last_out.iter_mut()).zip(k.p.axes.iter());
            for (((ax, s), out), p) in axes {
                let mut a = Axis::new();
                a.ready = true;
                a.unwrap = Unwrapper::new(s.count);
                a.zero = s.zero;
                a.obs = AlphaBeta { x: s.x, v: s.v };
                a.interp = Interpolator::from_parts(s.setpoint, s.target, s.sp_velocity, s.speed, &p.profile);
                a.path = s.path;
                a.fe_count = s.fe_count;
                a.invalid = s.invalid;
                *ax = a;
                *out = s.last_out;
            }
            k.armed = spec.armed;
            k.since_cmd = spec.since_cmd;
            k.since_target = spec.since_target;
            k.intervals = spec.intervals;
            if k.invariant() {
                Some((k, auth))
            } else {
                None
            }
        }
    }
}

/// Each clause of the invariant refuses the states it names and admits its
/// boundary (every bound is inclusive or exclusive as documented), for both
/// variants. The scenario tests only see reachable states, where every
/// clause holds; these are the states where one does not.
#[cfg(test)]
mod tests {
    use super::super::supervisor::Mode;
    use super::super::{Kernel, ALL};
    use crate::config::{AXES, PAROL6_VALIDATED};
    use crate::homing::Phase;
    use crate::scalar::{Fx, Scalar};
    use crate::types::{EncoderSample, Fault, FaultReason, Sense};

    /// A kernel past boot, every axis read (Unhomed, at rest).
    fn booted<S: Scalar>() -> Kernel<S> {
        let (mut k, _auth) = Kernel::<S>::new(&PAROL6_VALIDATED);
        let sense =
            Sense { encoders: [EncoderSample::Count(1000); AXES], limits: 0, hardware_fault: None, link_lost: false };
        for _ in 0..5 {
            k.tick(&sense, None);
        }
        assert_eq!(k.mode, Mode::Unhomed);
        assert!(k.axes.iter().all(|a| a.ready && !a.needs_reinit));
        assert!(k.invariant());
        k
    }

    /// Operational, homed, at rest.
    fn operational<S: Scalar>() -> Kernel<S> {
        let mut k = booted::<S>();
        k.mode = Mode::Operational;
        k.homed = ALL;
        assert!(k.invariant());
        k
    }

    fn vmax<S: Scalar>(k: &Kernel<S>, i: usize) -> S {
        k.p.axes.get(i).map_or(S::ZERO, |p| p.vmax)
    }

    /// `f` applied to a fresh kernel from `base` gives `want`.
    fn case<S: Scalar>(base: fn() -> Kernel<S>, want: bool, what: &str, f: impl FnOnce(&mut Kernel<S>)) {
        let mut k = base();
        f(&mut k);
        assert_eq!(k.invariant(), want, "{}: {what}", core::any::type_name::<S>());
    }

    fn clauses<S: Scalar>() {
        let half = S::from_f32(0.5);
        // 1. a fault latched exactly in Fault.
        case(booted::<S>, false, "fault outside Fault", |k| {
            k.fault = Some(Fault { reason: FaultReason::Runaway { axis: 0 }, tick: 0 })
        });
        case(booted::<S>, false, "Fault without a fault", |k| k.mode = Mode::Fault);
        case(booted::<S>, true, "Fault with its fault", |k| {
            k.mode = Mode::Fault;
            k.fault = Some(Fault { reason: FaultReason::Runaway { axis: 0 }, tick: 0 });
        });
        // 2. outputs within vmax, zero at rest.
        case(operational::<S>, true, "output exactly vmax", |k| k.last_out[1] = vmax(k, 1));
        case(operational::<S>, true, "output exactly -vmax", |k| k.last_out[1] = vmax(k, 1).neg());
        case(operational::<S>, false, "output above vmax", |k| k.last_out[1] = vmax(k, 1).plus(half));
        case(operational::<S>, false, "output below -vmax", |k| k.last_out[5] = vmax(k, 5).plus(half).neg());
        for mode in [Mode::Boot, Mode::Unhomed, Mode::SoftEstop] {
            case(booted::<S>, false, "output at rest", |k| {
                k.mode = mode;
                k.last_out[2] = half;
            });
        }
        case(booted::<S>, false, "output in Fault", |k| {
            k.mode = Mode::Fault;
            k.fault = Some(Fault { reason: FaultReason::Runaway { axis: 0 }, tick: 0 });
            k.last_out[2] = half;
        });
        // 3. Operational only homed; no homing phase outside Homing.
        case(operational::<S>, false, "Operational with a joint unhomed", |k| k.homed = ALL & !(1 << 3));
        case(booted::<S>, false, "a homing phase in Unhomed", |k| k.axes[4].homing.reset(true));
        case(booted::<S>, true, "a homing phase in Homing", |k| {
            k.mode = Mode::Homing;
            k.axes[4].homing.reset(true);
        });
        assert_ne!(booted::<S>().axes[4].homing.phase(), Phase::Waiting);
        // 4. the soft-stop envelope.
        let stopping = |k: &mut Kernel<S>, step: u32, v0: S, out: S| {
            let mut v = [S::ZERO; AXES];
            v[0] = v0;
            k.mode = Mode::Stopping { k: step, v0: v, then_home: 0, track: false };
            k.last_out[0] = out;
        };
        let n = booted::<S>().p.stop_ticks;
        let one = S::ONE;
        case(operational::<S>, true, "stop output on the envelope", |k| {
            let env = one.times(k.stop_scale(3));
            stopping(k, 3, one, env)
        });
        case(operational::<S>, true, "stop output on the envelope, negative", |k| {
            let env = one.neg().times(k.stop_scale(3));
            stopping(k, 3, one.neg(), env)
        });
        case(operational::<S>, false, "stop output just past the envelope", |k| {
            let env = one.times(k.stop_scale(3)).plus(S::from_f32(1e-4));
            stopping(k, 3, one, env)
        });
        case(operational::<S>, true, "stop at k = N, zero", |k| stopping(k, n, one, S::ZERO));
        case(operational::<S>, false, "stop past its end", |k| stopping(k, n + 1, one, S::ZERO));
        case(operational::<S>, false, "stop at k = N, not zero", |k| stopping(k, n, one, S::from_f32(0.01)));
        case(operational::<S>, false, "stop output above the envelope", |k| stopping(k, n / 2, one, S::from_f32(0.6)));
        case(operational::<S>, true, "stop output inside the envelope", |k| stopping(k, n / 2, one, S::from_f32(0.4)));
        case(operational::<S>, false, "stop output reversed", |k| stopping(k, 0, one, S::from_f32(-0.1)));
        case(operational::<S>, false, "stop from above vmax", |k| {
            let v = vmax(k, 0).plus(half);
            stopping(k, 0, v, S::ZERO)
        });
        case(operational::<S>, false, "stop from below -vmax", |k| {
            let v = vmax(k, 0).plus(half).neg();
            stopping(k, 0, v, S::ZERO)
        });
        // 5. plausible estimates and counters below their fault thresholds.
        let pos_abs = booted::<S>().p.pos_abs;
        let vel_abs = booted::<S>().p.vel_abs;
        case(booted::<S>, false, "estimate at the position bound", |k| k.axes[0].obs.x = pos_abs);
        case(booted::<S>, false, "estimate at minus the position bound", |k| k.axes[0].obs.x = pos_abs.neg());
        case(booted::<S>, false, "estimated speed at the bound", |k| k.axes[0].obs.v = vel_abs);
        case(booted::<S>, false, "estimated speed at minus the bound", |k| k.axes[0].obs.v = vel_abs.neg());
        case(booted::<S>, true, "implausible in Fault", |k| {
            k.mode = Mode::Fault;
            k.fault = Some(Fault { reason: FaultReason::Runaway { axis: 0 }, tick: 0 });
            k.axes[0].obs.x = pos_abs;
        });
        case(booted::<S>, true, "implausible before the first reading", |k| {
            k.axes[0].ready = false;
            k.axes[0].obs.x = pos_abs;
        });
        case(booted::<S>, true, "implausible awaiting re-initialisation", |k| {
            k.axes[0].needs_reinit = true;
            k.axes[0].obs.v = vel_abs;
        });
        let (il, fe) = (booted::<S>().p.invalid_limit, booted::<S>().p.fe_ticks);
        case(booted::<S>, true, "invalid count at its limit", |k| k.axes[3].invalid = il);
        case(booted::<S>, false, "invalid count past its limit", |k| k.axes[3].invalid = il + 1);
        case(booted::<S>, true, "following-error count at its limit", |k| k.axes[3].fe_count = fe);
        case(booted::<S>, false, "following-error count past its limit", |k| k.axes[3].fe_count = fe + 1);
        // 6. set-points: velocity within vmax.
        case(booted::<S>, true, "set-point velocity exactly vmax", |k| {
            let v = vmax(k, 2);
            k.axes[2].interp =
                crate::interp::Interpolator::from_parts(S::ZERO, S::ONE, v, S::ZERO, &k.p.axes[2].profile);
        });
        case(booted::<S>, false, "set-point velocity above vmax", |k| {
            let v = vmax(k, 2).plus(half);
            k.axes[2].interp =
                crate::interp::Interpolator::from_parts(S::ZERO, S::ONE, v, S::ZERO, &k.p.axes[2].profile);
        });
        case(booted::<S>, false, "set-point velocity below -vmax", |k| {
            let v = vmax(k, 2).plus(half).neg();
            k.axes[2].interp =
                crate::interp::Interpolator::from_parts(S::ZERO, S::ONE, v, S::ZERO, &k.p.axes[2].profile);
        });
        // 7. stream timing.
        let (lo, hi) = (booted::<S>().p.seg_min, booted::<S>().p.seg_max);
        case(booted::<S>, true, "intervals at the segment bounds", |k| k.intervals = [lo, hi, lo, hi]);
        case(booted::<S>, false, "an interval below the range", |k| k.intervals = [lo, lo - 1, lo, lo]);
        case(booted::<S>, false, "an interval above the range", |k| k.intervals = [hi, hi, hi, hi + 1]);
        case(booted::<S>, false, "a partly filled history", |k| k.intervals = [0, 0, 0, lo]);
        case(booted::<S>, true, "since the last target: the longest segment", |k| k.since_target = Some(hi));
        case(booted::<S>, false, "since the last target: longer", |k| k.since_target = Some(hi + 1));
    }

    /// Non-finite values (f32 only: I8F24 has none).
    #[test]
    fn non_finite_values_are_refused() {
        let nan = f32::NAN;
        case(operational::<f32>, false, "NaN output", |k| k.last_out[0] = nan);
        case(operational::<f32>, false, "NaN stop origin", |k| {
            k.mode = Mode::Stopping { k: 0, v0: [nan; AXES], then_home: 0, track: false }
        });
        case(booted::<f32>, false, "NaN estimate", |k| k.axes[1].obs.x = nan);
        case(booted::<f32>, false, "NaN estimated speed", |k| k.axes[1].obs.v = nan);
        for (sp, t, v) in [(nan, 0.0, 0.0), (0.0, nan, 0.0), (0.0, 0.0, nan), (f32::INFINITY, 0.0, 0.0)] {
            case(booted::<f32>, false, "non-finite set-point", |k| {
                k.axes[1].interp = crate::interp::Interpolator::from_parts(sp, t, v, 0.0, &k.p.axes[1].profile)
            });
        }
        case(booted::<f32>, false, "infinite target", |k| {
            k.axes[1].interp =
                crate::interp::Interpolator::from_parts(0.0, f32::NEG_INFINITY, 0.0, 0.0, &k.p.axes[1].profile)
        });
    }

    #[test]
    fn each_clause_refuses_its_states_f32() {
        clauses::<f32>();
    }

    #[test]
    fn each_clause_refuses_its_states_fx() {
        clauses::<Fx>();
    }
}
