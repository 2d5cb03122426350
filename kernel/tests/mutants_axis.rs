//! Tests written for the survivors of a cargo-mutants run on the kernel's
//! logic files (`ci/mutants.sh`, `docs/MUTANTS.md`): each asserts the
//! behaviour SAFETY.md or docs/PROTOCOL.md specify, for both numeric
//! variants, every tick checked by the safety monitor (the common rig).
//! This file: the per-axis pipeline (`kernel/src/kernel/axis.rs`).
#![allow(clippy::needless_range_loop)] // six axes: indices read best

mod common;

use common::{both, Rig};
use kernel::config::{ms_to_ticks, ArmConfig, Validated, AXES, PAROL6, POSITION_ABS_MAX};
use kernel::{FaultReason, Scalar, State, TickOutput};

const START: [f64; AXES] = [0.3, 0.2, -0.4, 0.5, -0.3, 1.0];

both!(
    a_motor_reversed_mid_motion_faults_on_the_direction_rule,
    a_joint_lagging_while_moving_with_the_command_is_no_fault,
    an_estimate_beyond_the_absolute_bound_is_a_numeric_fault,
);

/// The following-error rule of PROTOCOL.md 6.7, evaluated from outside on
/// one joint's reported status: the joint is "bad" in a tick when its
/// estimate is more than `fe` from its commanded path, or more than half of
/// that while moving against the command applied last tick (both faster
/// than half the speed limit); the fault comes on the first tick with more
/// than `fe_ticks` bad ticks in a row. In Operational the commanded path of
/// a tick is the set-point the tick starts from (the previous status's).
struct FollowingRule<S> {
    fe: S,
    half: S,
    dir: S,
    fe_ticks: u32,
    count: u32,
}

impl<S: Scalar> FollowingRule<S> {
    fn new(cfg: &ArmConfig, j: usize) -> Self {
        FollowingRule {
            fe: S::from_f32(cfg.following_error),
            half: S::from_f32(cfg.following_error * 0.5),
            dir: S::from_f32(0.5 * cfg.joints[j].max_velocity),
            fe_ticks: ms_to_ticks(cfg.following_error_ms, cfg.tick_hz),
            count: 0,
        }
    }
    /// One tick: `prev` the tick before, `now` this tick; true when the
    /// rule says this tick faults.
    fn step(&mut self, j: usize, prev: &TickOutput<S>, now: &TickOutput<S>) -> bool {
        let e = prev.status.setpoint[j].minus(now.status.position[j]).abs();
        let (cmd, v, h) = (prev.act.velocity[j], now.status.velocity[j], self.dir);
        let against = (cmd > h && v < h.neg()) || (cmd < h.neg() && v > h);
        let bad = e > self.fe || (e > self.half && against);
        self.count = if bad { self.count + 1 } else { 0 };
        self.count > self.fe_ticks
    }
}

/// PROTOCOL.md 6.7: "more than half of that behind while moving against the
/// command" is a following error too (it catches an inverted DIR line
/// early). With the PAROL6's 0.05 rad bound the distance alone fires within
/// a few ticks of it; with a wider bound (0.3 rad, which `config::check`
/// allows with a 0.6 rad margin) the half-bound-and-against rule is what
/// fires first. J1 is sent 1.5 rad either way; at speed, its motor turns
/// the wrong way from then on. The fault comes on exactly the tick the rule,
/// evaluated on the reported status, says. Survivors: every comparison of
/// the direction rule (`against`, `away`).
fn a_motor_reversed_mid_motion_faults_on_the_direction_rule<S: Scalar>() {
    let cfg = ArmConfig { following_error: 0.3, position_margin: 0.6, ..PAROL6 };
    let v = Validated::new(cfg).expect("valid");
    let j = 0;
    for (d, at) in [(1.5, 150), (-1.5, 150), (1.5, 30), (-1.5, 30)] {
        let mut r = Rig::<S>::with_config(START, &v);
        r.boot_and_home();
        let mut p = r.plant.q;
        p[j] = 0.0;
        r.goto(p);
        r.run(1_500);
        p[j] = d;
        let mut rule = FollowingRule::<S>::new(&cfg, j);
        let mut prev = r.last.unwrap();
        let mut expected = None;
        let mut faulted = None;
        for n in 0..1_000u32 {
            if n == at {
                r.plant.reversed = 1 << j;
            }
            let now = if n == 0 { r.goto(p) } else { r.tick(None) };
            if expected.is_none() && rule.step(j, &prev, &now) {
                expected = Some(n);
            }
            if now.status.state == State::Fault {
                faulted = Some(n);
                assert_eq!(now.status.fault.unwrap().reason, FaultReason::FollowingError { axis: j as u8 });
                break;
            }
            prev = now;
        }
        let faulted = faulted.expect("a reversed motor faults");
        assert_eq!(Some(faulted), expected, "J1 to {d}, reversed at tick {at}: fault tick vs the rule");
    }
}

/// The converse of the direction rule: a joint that lags its path by more
/// than half the bound but less than the bound, while moving *with* the
/// command at speed, is no following error (PROTOCOL.md 6.7: "more than
/// half of that behind while moving against the command"). J1 is held back
/// by a slight steady drag (a stiff cable, 0.05 rad/s: about 0.037 rad
/// behind at speed) through a full-speed go-to either way, without a
/// fault. Survivors: either half of `against` with its `&&` as `||`.
fn a_joint_lagging_while_moving_with_the_command_is_no_fault<S: Scalar>() {
    let j = 0;
    let mut r = Rig::<S>::new(START);
    r.boot_and_home();
    let fe = f64::from(PAROL6.following_error);
    let half_speed = 0.5 * f64::from(PAROL6.joints[j].max_velocity);
    for (from, to) in [(-1.2, 1.2), (1.2, -1.2)] {
        let mut p = r.plant.q;
        p[j] = from;
        r.goto(p);
        r.run(2_000);
        // Drag against the coming motion.
        r.plant.disturbance[j] = if to > from { -0.05 } else { 0.05 };
        p[j] = to;
        let mut prev = r.goto(p);
        let mut lag_at_speed = 0.0f64;
        for _ in 0..2_000 {
            let now = r.tick(None);
            assert_eq!(now.status.state, State::Operational, "{:?}", now.status.fault);
            let e = f64::from(prev.status.setpoint[j].minus(now.status.position[j]).to_f32()).abs();
            if f64::from(now.status.velocity[j].to_f32()).abs() > half_speed {
                lag_at_speed = lag_at_speed.max(e);
            }
            prev = now;
        }
        assert!(lag_at_speed > 0.5 * fe && lag_at_speed < fe, "{from} -> {to}: lag at speed {lag_at_speed}");
        r.plant.disturbance[j] = 0.0;
    }
}

/// The estimate's plausibility bounds (`POSITION_ABS_MAX`, 32 rad): an
/// unhomed J6 turned by an outside force (below its runaway speed) for
/// turn after turn has an estimate that eventually leaves them; that is a
/// `Numeric` fault on the tick it does, not a number that keeps growing
/// toward the fixed-point range (128 rad). Survivors: each `&&`
/// of the plausibility chain as `||` (the bounds no longer checked for a
/// finite estimate).
fn an_estimate_beyond_the_absolute_bound_is_a_numeric_fault<S: Scalar>() {
    let j = 5;
    let mut r = Rig::<S>::new(START);
    r.run(3);
    assert_eq!(r.k.state(), State::Unhomed);
    r.plant.disturbance[j] = -1.1 * f64::from(PAROL6.joints[j].max_velocity);
    let n = r.run_until(10_000, |o| o.status.state == State::Fault).expect("faults");
    let out = r.last.unwrap();
    assert_eq!(out.status.fault.unwrap().reason, FaultReason::Numeric { axis: j as u8 }, "after {n} ticks");
    let x = out.status.position[j].to_f32();
    assert!(x < -POSITION_ABS_MAX && x > -POSITION_ABS_MAX - 0.01, "{x}");
}
