//! The f32 and fixed-point kernels in lockstep on one plant ([`Pair`]).

use kernel::config::{AXES, PAROL6};
use kernel::{Fx, Scalar, State};

use monitor::plant::Plant;

use super::{Driver, Req, Start, Sut};

/// The f32 and fixed-point kernels driven in lockstep with the same requests
/// on the same plant: every tick both sense the same arm; the f32 kernel's
/// outputs move it (the fixed-point kernel's are compared, then dropped).
#[derive(Debug)]
pub struct Pair {
    /// The f32 kernel.
    pub a: Sut<f32>,
    /// The fixed-point kernel.
    pub b: Sut<Fx>,
    /// Largest output difference seen (rad/s).
    pub worst_v: f64,
    /// Largest difference of the set-points (rad).
    pub worst_q: f64,
    /// Largest difference of the position estimates (rad).
    pub worst_est: f64,
    /// Output bound asserted (rad/s).
    pub bound_v: f64,
    /// Position bound asserted (rad).
    pub bound_q: f64,
    /// Consecutive ticks (so far) the two kernels' homing phases differ.
    pub skew: u32,
    /// Longest such run.
    pub worst_skew: u32,
    /// Ticks whose homing phases differed (outputs not compared).
    pub skew_ticks: u64,
    /// The set-point profiles of the two kernels took a discrete decision
    /// (accelerate, cruise, brake, land) a tick apart (see
    /// [`PROFILE_SPLIT`]): outputs and set-points are not compared until
    /// they realign ([`RESYNC_TICKS`]) or both kernels resynchronise their
    /// set-points (entering Homing or Fault, or an enable).
    pub split: bool,
    /// How many times that happened.
    pub splits: u32,
    /// Ticks not compared because of a split.
    pub split_ticks: u64,
    /// Consecutive realigned ticks during a split.
    calm: u32,
    /// The tick at which the states differed during a split (a hold versus
    /// latch decided a tick apart, say): the case's comparison ended there.
    /// States differing outside a split fail the test.
    pub diverged: Option<u64>,
    /// The case ended because the fixed-point kernel, which does not drive
    /// the arm, faulted FOLLOWING_ERROR after a split (its path and the arm
    /// drifted apart).
    pub follower_fe: bool,
    /// Ticks whose outputs and set-points were compared.
    pub compared_ticks: u64,
    /// Largest set-point velocity difference seen while compared (rad/s).
    pub worst_sp_vel: f64,
    prev_sp: Option<([f64; AXES], [f64; AXES])>,
    prev_state: State,
}

/// Set-point velocities (from consecutive set-points) of the two variants
/// that differ by more than this fraction of a joint's `dv` (its
/// acceleration per tick) mean the profile took a discrete decision a tick
/// apart (its braking test or landing test fell on the other side of its
/// rounding allowance): one variant's set-point then runs a whole `dv`
/// ahead, and its output with it (by up to `dv` plus the control
/// correction). The monitors still judge every tick of both.
pub const PROFILE_SPLIT: f64 = 0.25;

/// Consecutive ticks with set-points within `BOUND_Q / 10` and set-point
/// velocities within [`PROFILE_SPLIT`] `dv` after which a split ends and
/// the comparison resumes (the acceleration-limited outputs need a few
/// tens of ticks to realign).
pub const RESYNC_TICKS: u32 = 100;

/// Longest run of ticks the homing phases may differ. A phase that ends
/// when the estimate crosses a distance (the back-off) can end a tick apart
/// in the two variants when the crossing falls within their rounding
/// difference (about 5e-6 rad): the later one realigns at the next sensor
/// edge or phase. Everything else must agree at every tick.
pub const MAX_SKEW: u32 = 3;

impl Pair {
    /// Both from `start`.
    pub fn new(start: &Start, bound_v: f64, bound_q: f64) -> Self {
        let mut b = Sut::new(start);
        b.follower = true;
        Pair {
            a: Sut::new(start),
            b,
            worst_v: 0.0,
            worst_q: 0.0,
            worst_est: 0.0,
            bound_v,
            bound_q,
            skew: 0,
            worst_skew: 0,
            skew_ticks: 0,
            split: false,
            splits: 0,
            split_ticks: 0,
            calm: 0,
            diverged: None,
            follower_fe: false,
            compared_ticks: 0,
            worst_sp_vel: 0.0,
            prev_sp: None,
            prev_state: State::Boot,
        }
    }
}

impl Driver for Pair {
    fn q(&self) -> [f64; AXES] {
        self.a.plant.q
    }
    fn env(&mut self, f: &dyn Fn(&mut Plant)) {
        Driver::env(&mut self.a, f);
        Driver::env(&mut self.b, f);
    }
    fn tick(&mut self, req: Option<Req>) {
        // One plant: the fixed-point kernel senses exactly what the f32
        // kernel senses (the f32 kernel's outputs drive the arm).
        self.b.plant = self.a.plant.clone();
        let oa = self.a.tick(req);
        let ob = self.b.tick(req);
        let t = self.a.ticks;
        if self.diverged.is_some() {
            return;
        }
        // A discrete profile decision a tick apart: a split (see `split`).
        let both_op = oa.status.state == State::Operational && ob.status.state == State::Operational;
        let sp_a = oa.status.setpoint.map(f64::from);
        let sp_b = ob.status.setpoint.map(|x| f64::from(x.to_f32()));
        let mut apart = false;
        let mut calm = both_op;
        if let (true, Some((pa, pb))) = (both_op, self.prev_sp) {
            let hz = f64::from(PAROL6.tick_hz);
            for i in 0..AXES {
                let (va, vb) = ((sp_a[i] - pa[i]) * hz, (sp_b[i] - pb[i]) * hz);
                let dv = f64::from(PAROL6.joints[i].max_acceleration) / hz;
                if (va - vb).abs() > PROFILE_SPLIT * dv {
                    apart = true;
                } else if !self.split {
                    self.worst_sp_vel = self.worst_sp_vel.max((va - vb).abs());
                }
                calm &= (sp_a[i] - sp_b[i]).abs() <= self.bound_q / 10.0;
            }
        }
        self.prev_sp = if both_op { Some((sp_a, sp_b)) } else { None };
        if apart {
            if !self.split {
                self.splits += 1;
            }
            self.split = true;
            self.calm = 0;
        } else if self.split {
            let same = oa.status.state == ob.status.state;
            // Entering Homing or Fault, or leaving a latch (enable),
            // resynchronises the set-points to the estimates and restarts
            // the outputs from zero in both kernels. (SoftEstop zeroes the
            // outputs but keeps the set-points where they stopped.)
            let reset = same
                && oa.status.state != self.prev_state
                && (matches!(oa.status.state, State::Homing | State::Fault)
                    || matches!(self.prev_state, State::SoftEstop | State::Fault));
            self.calm = if calm { self.calm + 1 } else { 0 };
            if reset || self.calm >= RESYNC_TICKS {
                self.split = false;
            }
        }
        self.prev_state = oa.status.state;
        if self.split {
            self.split_ticks += 1;
            if oa.status.state != ob.status.state {
                let fe = |o: &Option<kernel::Fault>| matches!(o, Some(f) if matches!(f.reason, kernel::FaultReason::FollowingError { .. }));
                self.follower_fe = fe(&ob.status.fault) && !fe(&oa.status.fault);
                self.diverged = Some(t);
            }
            return;
        }
        self.compared_ticks += 1;
        // The fixed-point kernel does not drive the arm: after a split its
        // path and the arm (driven by the f32 kernel) can drift apart by
        // more than the following-error bound. That ends the case too.
        let fe = |o: &Option<kernel::Fault>| matches!(o, Some(f) if matches!(f.reason, kernel::FaultReason::FollowingError { .. }));
        if self.splits > 0 && oa.status.state != ob.status.state && fe(&ob.status.fault) && !fe(&oa.status.fault) {
            self.diverged = Some(t);
            self.follower_fe = true;
            return;
        }
        assert_eq!(
            oa.status.state, ob.status.state,
            "differential: states differ at tick {t}: f32 {:?} fx {:?}\n f32 events {:?}\n fx events {:?}",
            oa, ob, oa.events, ob.events
        );
        assert_eq!(oa.status.homed, ob.status.homed, "differential: homed differs at tick {t}");
        let kind = |o: &Option<kernel::Fault>| o.map(|f| monitor::fault_kind(&f.reason));
        assert_eq!(kind(&oa.status.fault), kind(&ob.status.fault), "differential: fault kinds differ at tick {t}");
        let differ = self.a.k.homing_phases() != self.b.k.homing_phases();
        // The tick after realigning too: the later kernel's first tick in
        // the new phase.
        let skewed = differ || self.skew > 0;
        if differ {
            self.skew += 1;
            self.skew_ticks += 1;
            self.worst_skew = self.worst_skew.max(self.skew);
            assert!(
                self.skew <= MAX_SKEW,
                "differential: homing phases differ for {} ticks at tick {t}: f32 {:?} fx {:?}",
                self.skew,
                self.a.k.homing_phases(),
                self.b.k.homing_phases()
            );
        } else {
            self.skew = 0;
        }
        for i in 0..AXES {
            let dv = f64::from((oa.act.velocity[i] - ob.act.velocity[i].to_f32()).abs());
            let dq = f64::from((oa.status.setpoint[i] - ob.status.setpoint[i].to_f32()).abs());
            let de = f64::from((oa.status.position[i] - ob.status.position[i].to_f32()).abs());
            if !skewed {
                self.worst_v = self.worst_v.max(dv);
            }
            self.worst_q = self.worst_q.max(dq);
            self.worst_est = self.worst_est.max(de);
            assert!(
                skewed || dv <= self.bound_v,
                "differential: axis {i} outputs differ by {dv} rad/s at tick {t}\n f32 {oa:?}\n fx {ob:?}\n phases f32 {:?} fx {:?}",
                self.a.k.homing_phases(),
                self.b.k.homing_phases()
            );
            assert!(dq <= self.bound_q, "differential: axis {i} set-points differ by {dq} rad at tick {t}");
            assert!(de <= self.bound_q, "differential: axis {i} estimates differ by {de} rad at tick {t}");
        }
    }
    fn state(&self) -> State {
        self.a.k.state()
    }
    fn phases(&self) -> [kernel::homing::Phase; AXES] {
        self.a.k.homing_phases()
    }
}
