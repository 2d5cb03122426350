//! SR-2, SR-18, SR-19, SR-25, SR-27, SR-28 in Operational: what the
//! outputs and set-points of a moving arm may do.

use kernel::config::{ms_to_ticks, AXES};
use kernel::{FaultReason, Scalar, State};

use crate::facts::TickFacts;
use crate::stats::inc;
use crate::violation::{ensure_ok, Checked, Sr};
use crate::{bit, cfg_joints, f, Monitor, ALL, FE_LIVENESS_SLACK, PROFILE_DECEL_MIN};

impl<S: Scalar> Monitor<S> {
    /// SR-2: every output finite and within the joint's max velocity; the
    /// step rate within the step generator's range and the joint's max
    /// velocity in steps, with the velocity's sign.
    pub(crate) fn check_outputs(&self, t: &TickFacts<'_, S>) -> Checked {
        let out = t.out;
        let cfg = &self.cfg;
        let joints = cfg_joints(cfg).zip(self.rate_max.iter());
        for (i, ((j, rmax), (v, r))) in joints.zip(out.act.velocity.iter().zip(out.act.step_rate.iter())).enumerate() {
            let (v, r, rmax) = (*v, *r, *rmax);
            let vmax = f64::from(j.max_velocity);
            if !(v.is_finite() && v.abs() <= S::from_f32(j.max_velocity)) {
                return Err(t.fail(Sr::Sr2, "output not finite or above max velocity").on(i).got(f(v)).bound(vmax));
            }
            let rate = f64::from(r).abs();
            if r.unsigned_abs() > cfg.max_step_rate {
                return Err(t
                    .fail(Sr::Sr2, "step rate above the step generator's limit")
                    .on(i)
                    .got(rate)
                    .bound(f64::from(cfg.max_step_rate)));
            }
            if rate > rmax {
                return Err(t.fail(Sr::Sr2, "step rate above the joint's max velocity").on(i).got(rate).bound(rmax));
            }
            let vf = v.to_f32();
            // A motor wired reversed (`motor_reversed`) steps against the
            // joint's velocity.
            let signed_ok = if vf == 0.0 { r == 0 } else { r == 0 || ((vf > 0.0) == (r > 0)) != j.motor_reversed };
            if !signed_ok {
                return Err(t.fail(Sr::Sr2, "step rate against the velocity's sign").on(i).got(f64::from(r)));
            }
        }
        Ok(())
    }

    /// SR-18: in Operational the set-point moves at most vmax/tick_hz per tick.
    pub(crate) fn check_setpoint_speed(&self, t: &TickFacts<'_, S>) -> Checked {
        let (out, st) = (t.out, t.st);
        if st == State::Operational && t.prev == State::Operational {
            let over =
                first_step_over(&out.status.setpoint, &self.prev_setpoint, 1.001, &self.vel_per_tick, self.fixed);
            if let Some((i, step, bound)) = over {
                return Err(t.fail(Sr::Sr18, "set-point stepped more than vmax/tick_hz").on(i).got(step).bound(bound));
            }
        }
        Ok(())
    }

    /// SR-27: set-points in Operational (the set-point velocity is the
    /// difference of consecutive set-points times `tick_hz`, computed here):
    ///
    /// - its change per tick is at most `dv = max_acceleration / tick_hz`
    ///   plus the landing allowance `max(dv / 256, 1e-4)` rad/s, plus the
    ///   rounding of the set-points themselves: 4 units in the last place
    ///   of the larger set-point (f32; at least one I8F24 LSB) times
    ///   `tick_hz` (1.9e-3 rad/s at |x| = 6.3, 1000 Hz; 2.4e-4 at |x| < 1);
    /// - it never crosses the target it moves toward in a tick, and once at
    ///   its (unchanged) target it stays there; given a target inside its
    ///   braking distance ahead (below), it goes at most the braking
    ///   distance from the speed limit (`vmax^2 / 2a' + 2 vmax / tick_hz`
    ///   from where it was) until the next target;
    /// - it stays inside the joint limits, or between them and the
    ///   set-point where Operational was entered (1e-5 rad plus rounding).
    ///
    /// Not judged: the tick Operational is entered (the set-points are
    /// resynchronised to the estimates, at rest: the next tick's change is
    /// judged from zero). For an axis given a target inside its braking
    /// distance in its direction of motion (from its measured set-point
    /// velocity `v`: closer than `v^2 / 2a' + 2 |v| / tick_hz` with
    /// `a' = PROFILE_DECEL_MIN * max_acceleration`) "never past the target"
    /// cannot hold together with the acceleration bound: the acceleration
    /// bound is kept, the passing is bounded as above, until its set-point
    /// has rested at its target for `vmax / dv + 2` ticks; each such target
    /// is counted in [`crate::Stats::infeasible_retargets`].
    pub(crate) fn check_setpoints(&mut self, t: &TickFacts<'_, S>) -> Checked {
        let out = t.out;
        let retargeted = t.accepted_target.is_some();
        let sp = out.status.setpoint;
        if out.status.state != State::Operational {
            self.sp_vel = None;
            self.prev_sp_static = None;
            self.target = None;
            self.infeasible = 0;
            return Ok(());
        }
        if t.prev != State::Operational {
            // Entered with the set-points resynchronised: at rest, each
            // its own target.
            self.sp_vel = Some([0.0; AXES]);
            self.prev_sp_static = Some(true);
            self.target = Some(sp);
            self.anchor = sp.map(f);
            self.infeasible = 0;
            self.rest_ticks = [0; AXES];
            self.reach = [None; AXES];
            return Ok(());
        }
        let hz = f64::from(self.cfg.tick_hz);
        let prev_vel = self.sp_vel;
        let mut vel = [0.0f64; AXES];
        let mut still = true;
        let axes = vel
            .iter_mut()
            .zip(sp.iter().zip(self.prev_setpoint.iter()))
            .zip(self.cfg.joints.iter().zip(self.anchor.iter().zip(self.acc_per_tick.iter())))
            .zip(self.rest_ticks.iter_mut().zip(self.reach.iter_mut()));
        for (i, (((v, (a, b)), (j, (anchor, dv))), (rest, reach))) in axes.enumerate() {
            let (a, b) = (*a, *b);
            let (fa, fb) = (f(a), f(b));
            *v = (fa - fb) * hz;
            if a == b {
                *rest = rest.saturating_add(1);
            } else {
                *rest = 0;
                still = false;
            }
            let amax = f64::from(j.max_acceleration);
            let dv = *dv;
            let ulp = ulp_f32(fa.abs().max(fb.abs())).max(FX_LSB);
            let tol = 1e-5 + 2.0 * ulp;
            let pv = prev_vel.and_then(|p| p.get(i).copied());
            let t_new = t.target_now.and_then(|t| t.get(i).copied());
            let t_old = t.old_target.and_then(|t| t.get(i).copied());
            let changed = retargeted && t_new != t_old;
            // A target inside the braking distance, ahead: the set-point
            // may overshoot it, by at most the braking distance.
            if changed {
                *reach = None;
            }
            if let (true, Some(pv), Some(goal)) = (changed, pv, t_new) {
                let d = f(goal) - fb;
                let a_min = amax * PROFILE_DECEL_MIN;
                let brake = |v: f64| v * v / (2.0 * a_min) + 2.0 * v.abs() / hz;
                if pv * d > 0.0 && d.abs() < brake(pv) {
                    // Bounded by the braking distance from vmax: the
                    // profile's own velocity can exceed the measured one
                    // (a set-point held at a target keeps its velocity),
                    // and a tighter bound from the measured velocity was
                    // exceeded by 0.04 mrad in a replay not yet explained.
                    let v = f64::from(j.max_velocity);
                    inc(&mut self.stats.infeasible_retargets);
                    self.infeasible |= bit(i);
                    let dir = if pv > 0.0 { 1.0 } else { -1.0 };
                    *reach = Some((fb + dir * brake(v), dir));
                }
            }
            if let Some((r, dir)) = *reach {
                ensure_ok((fa - r) * dir <= tol, || {
                    t.fail(Sr::Sr27, "set-point overshot a target inside its braking distance by more than it")
                        .on(i)
                        .got(fa)
                        .bound(r)
                })?;
            }
            if let Some(pv) = pv {
                let bound = dv + (dv / 256.0).max(1e-4) + 4.0 * ulp * hz;
                let change = (*v - pv).abs();
                ensure_ok(change <= bound, || {
                    t.fail(Sr::Sr27, "set-point velocity changed more than max_acceleration/tick_hz")
                        .on(i)
                        .got(change)
                        .bound(bound)
                })?;
            }
            let lo = f64::from(j.limit_min).min(*anchor) - tol;
            let hi = f64::from(j.limit_max).max(*anchor) + tol;
            ensure_ok(fa >= lo && fa <= hi, || {
                t.fail(Sr::Sr27, "set-point outside the joint limits").on(i).got(fa).bound(if fa < lo {
                    lo
                } else {
                    hi
                })
            })?;
            if let Some(goal) = t_new {
                let ft = f(goal);
                let (pa, pb) = (fb - ft, fa - ft);
                let crossed = (pa > 0.0 && pb < -tol) || (pa < 0.0 && pb > tol);
                let left = b == goal && a != goal && !changed;
                ensure_ok(!(crossed || left) || self.infeasible & bit(i) != 0, || {
                    t.fail(Sr::Sr27, "set-point passed the target it approached").on(i).got(fa).bound(ft)
                })?;
                if a == goal && f64::from(*rest) > f64::from(j.max_velocity) / dv + 2.0 {
                    self.infeasible &= !bit(i);
                    *reach = None;
                }
            }
        }
        self.sp_vel = Some(vel);
        self.prev_sp_static = Some(still);
        self.target = t.target_now;
        Ok(())
    }

    /// SR-19: in Operational and Stopping every (homed) axis is within its
    /// limits plus the margin; Stopping after a lost link in homing has
    /// the aborted run's joints unhomed. With the plant's facts: after a
    /// resync inside the limits with nothing injected since, every homed
    /// joint stays within its limits plus `ArmConfig::overrun_bound`
    /// (soft-stop overrun plus the following error), measured at its true
    /// angle (plus 2 mrad for the encoder's quantisation and the
    /// estimate's lag).
    pub(crate) fn check_limits(&mut self, t: &TickFacts<'_, S>) -> Checked {
        let (out, st) = (t.out, t.st);
        if matches!(st, State::Operational | State::Stopping) {
            ensure!(
                out.status.homed == ALL || (st == State::Stopping && self.stopping_from_homing),
                t.fail(Sr::Sr19, "Operational or Stopping with a joint unhomed")
            );
            let m = self.cfg.position_margin;
            for (i, (x, j)) in out.status.position.iter().zip(cfg_joints(&self.cfg)).enumerate() {
                if out.status.homed & bit(i) == 0 {
                    continue;
                }
                let (lo, hi) = (j.limit_min - m, j.limit_max + m);
                ensure!(
                    *x >= S::from_f32(lo) && *x <= S::from_f32(hi),
                    t.fail(Sr::Sr19, "axis outside its limits plus margin without a fault")
                        .on(i)
                        .got(f(*x))
                        .bound(f64::from(if f(*x) < 0.0 { lo } else { hi }))
                );
            }
        }
        if let Some(p) = t.plant {
            let resync = t.enabled.is_some() || t.homing_started || t.homing_done;
            if resync {
                self.dirty = false;
                self.inside_at_resync =
                    out.status.position.iter().zip(cfg_joints(&self.cfg)).enumerate().all(|(i, (x, j))| {
                        out.status.homed & bit(i) == 0
                            || (f(*x) >= f64::from(j.limit_min) && f(*x) <= f64::from(j.limit_max))
                    });
            }
            self.dirty |= p.disturbed;
            if matches!(st, State::Operational | State::Stopping) && !self.dirty && self.inside_at_resync {
                for (i, (q, j)) in p.q.iter().zip(cfg_joints(&self.cfg)).enumerate() {
                    if out.status.homed & bit(i) == 0 {
                        continue;
                    }
                    let ob = f64::from(self.cfg.overrun_bound(j)) + 2e-3;
                    let (lo, hi) = (f64::from(j.limit_min) - ob, f64::from(j.limit_max) + ob);
                    ensure!(
                        *q >= lo && *q <= hi,
                        t.fail(Sr::Sr19, "joint beyond its limits plus the overrun bound on a clean plant")
                            .on(i)
                            .got(*q)
                            .bound(if *q < 0.0 { lo } else { hi })
                    );
                }
            }
        }
        Ok(())
    }

    /// SR-28: following error. With the plant's facts: a `FollowingError`
    /// fault only after something was injected since the set-points were
    /// resynchronised; and a joint whose motor is stalled or reversed, with
    /// its set-point farther than the bound (plus `FE_LIVENESS_SLACK`) from
    /// its true angle for longer than the bound's time (plus slack) in
    /// Operational, has faulted by then.
    pub(crate) fn check_following_error(&mut self, t: &TickFacts<'_, S>) -> Checked {
        let (out, st) = (t.out, t.st);
        if let Some(p) = t.plant {
            if let (true, Some(FaultReason::FollowingError { axis })) = (t.n_faults > 0, t.fault_event) {
                ensure!(
                    self.dirty,
                    t.fail(Sr::Sr28, "following-error fault with nothing injected since the last resync")
                        .on(usize::from(axis))
                );
            }
            let fe = f64::from(self.cfg.following_error) + FE_LIVENESS_SLACK.0;
            let limit = ms_to_ticks(self.cfg.following_error_ms, self.cfg.tick_hz).saturating_add(FE_LIVENESS_SLACK.1);
            for (i, ((n, sp), q)) in self.fe_over.iter_mut().zip(out.status.setpoint.iter()).zip(p.q.iter()).enumerate()
            {
                let broken = p.broken_motor & bit(i) != 0;
                let over =
                    st == State::Operational && t.prev == State::Operational && broken && (f(*sp) - q).abs() > fe;
                *n = if over { n.saturating_add(1) } else { 0 };
                ensure!(
                    *n <= limit,
                    t.fail(Sr::Sr28, "a stalled or reversed joint off its set-point without a fault")
                        .on(i)
                        .got(f64::from(*n))
                        .bound(f64::from(limit))
                );
            }
        }
        Ok(())
    }

    /// SR-25 in Operational: the output changes by at most
    /// max_acceleration / tick_hz per tick.
    pub(crate) fn check_output_acceleration(&self, t: &TickFacts<'_, S>) -> Checked {
        let (out, st) = (t.out, t.st);
        if st == State::Operational {
            let over = first_step_over(&out.act.velocity, &self.prev_out, 1.0001, &self.acc_per_tick, self.fixed);
            if let Some((i, dv, bound)) = over {
                return Err(t
                    .fail(Sr::Sr25, "output stepped more than max_acceleration/tick_hz")
                    .on(i)
                    .got(dv)
                    .bound(bound));
            }
        }
        Ok(())
    }
}

/// The first axis whose value moved between two ticks by more than its
/// per-tick bound `limit[axis]` (times `rel`, plus 1e-6 of slack; a NaN
/// step is over): (axis, step, bound). With `fixed` (`S` is I8F24,
/// [`is_fixed_point`]) the step is compared in integer arithmetic on the
/// raw words ([`step_within_words`]: exact, no float operation on a value
/// of the tick); otherwise in `f64` ([`step_within_f64`]).
pub(crate) fn first_step_over<S: Scalar>(
    now: &[S; AXES],
    before: &[S; AXES],
    rel: f64,
    limit: &[f64; AXES],
    fixed: bool,
) -> Option<(usize, f64, f64)> {
    for (i, ((a, b), bound)) in now.iter().zip(before.iter()).zip(limit.iter()).enumerate() {
        let bound = *bound;
        let slack = bound * rel + 1e-6;
        let within = if fixed {
            step_within_words(fx_word(*a), fx_word(*b), slack_words(slack))
        } else {
            step_within_f64(*a, *b, slack)
        };
        if !within {
            return Some((i, (f(*a) - f(*b)).abs(), bound));
        }
    }
    None
}

/// One I8F24 word per unit: 2^24.
const FX_SCALE: i64 = 1 << 24;

/// `S` is the fixed-point variant (I8F24): the one without infinities
/// (`from_f32` of an infinity saturates to a finite value; f32 keeps it).
/// Asked once, by `Monitor::new`.
pub(crate) fn is_fixed_point<S: Scalar>() -> bool {
    S::from_f32(f32::INFINITY).is_finite()
}

/// The raw I8F24 word of `x` (`S` the fixed-point variant).
/// `kernel::Scalar` offers no raw word, so it is read through
/// `Scalar::to_scaled_int` at the word's own scale, 2^24, which for I8F24
/// is exact (`round(word * 2^24 / 2^24)` = the word).
/// (`tests::fx_word_is_the_raw_word`.)
pub(crate) fn fx_word<S: Scalar>(x: S) -> i64 {
    x.to_scaled_int(FX_SCALE)
}

/// The largest step in I8F24 words within `slack` (rad or rad/s; finite,
/// non-negative: the monitor's bounds): `floor(slack * 2^24)`.
pub(crate) fn slack_words(slack: f64) -> u64 {
    // Exact: a power-of-two scale, and `as` truncates toward zero (the
    // floor of a non-negative value), saturating.
    (slack * FX_SCALE as f64) as u64
}

/// The integer path: consecutive I8F24 words `a`, `b` at most `words` apart.
pub(crate) fn step_within_words(a: i64, b: i64, words: u64) -> bool {
    a.abs_diff(b) <= words
}

/// The `f64` path: `|a - b| <= slack` through `f32` (NaN is over).
pub(crate) fn step_within_f64<S: Scalar>(a: S, b: S, slack: f64) -> bool {
    (f(a) - f(b)).abs() <= slack
}

/// One LSB of the fixed-point variant (I8F24).
const FX_LSB: f64 = 1.0 / 16_777_216.0;

/// The spacing of `f32` values at magnitude `m`.
fn ulp_f32(m: f64) -> f64 {
    let x = m.abs() as f32;
    f64::from(x.next_up() - x)
}
