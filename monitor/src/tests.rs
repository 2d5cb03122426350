//! The monitor against the real kernel (no violation on a clean run) and
//! against fabricated bad outputs (each caught, with the right SR).

use super::*;
use crate::plant::{Plant, Witness};
use kernel::config::{PAROL6, PAROL6_VALIDATED};
use kernel::{Authority, Event, FaultReason, Kernel, KernelF32, MotionTarget, Reject, Request, RequestKind};
use std::format;
use std::string::ToString;

const START: [f64; AXES] = [0.3, 0.2, -0.4, 0.5, -0.3, 1.0];

struct Rig {
    k: KernelF32,
    auth: Authority,
    plant: Plant,
    wit: Witness,
    mon: Monitor<f32>,
}

impl Rig {
    fn new() -> Self {
        let (k, auth) = Kernel::new(&PAROL6_VALIDATED);
        Rig { k, auth, plant: Plant::at(START), wit: Witness::new(), mon: Monitor::new(&PAROL6) }
    }

    /// One tick; `tamper` may change the output before the monitor sees it
    /// (the plant still gets the kernel's real output).
    fn tick_with(
        &mut self,
        req: Option<Request<f32>>,
        tamper: impl FnOnce(&mut TickOutput<f32>, &mut [Phase; AXES]),
    ) -> (TickOutput<f32>, Checked) {
        self.tick_facts(req, tamper, |_| {})
    }

    /// One tick; `tamper` may change the output and `facts` the plant's
    /// facts before the monitor sees them.
    fn tick_facts(
        &mut self,
        req: Option<Request<f32>>,
        tamper: impl FnOnce(&mut TickOutput<f32>, &mut [Phase; AXES]),
        tamper_facts: impl FnOnce(&mut PlantFacts),
    ) -> (TickOutput<f32>, Checked) {
        let sense = self.plant.sense();
        self.wit.before(&self.plant);
        let sent = req.as_ref().map(Sent::of);
        let out = self.k.tick(&sense, req);
        let mut facts = self.wit.after(&self.plant, &out);
        tamper_facts(&mut facts);
        let mut seen = out;
        let mut phases = self.k.homing_phases();
        tamper(&mut seen, &mut phases);
        let r = self.mon.check(&sense, sent.as_ref(), &seen, Some(&phases), Some(&facts));
        self.plant.apply(&out.act.step_rate);
        (out, r)
    }

    fn tick(&mut self, req: Option<Request<f32>>) -> TickOutput<f32> {
        let (out, r) = self.tick_with(req, |_, _| {});
        if let Err(v) = r {
            panic!("clean run: {v}");
        }
        out
    }

    fn run(&mut self, n: u32) -> TickOutput<f32> {
        let mut out = self.tick(None);
        for _ in 1..n {
            out = self.tick(None);
        }
        out
    }

    fn homed() -> Self {
        let mut r = Rig::new();
        r.run(3);
        r.tick(Some(Request::Home));
        for _ in 0..60_000 {
            if r.tick(None).status.state != State::Homing {
                break;
            }
        }
        assert_eq!(r.k.state(), State::Operational);
        r
    }

    fn motion(&mut self, p: [f64; AXES]) -> TickOutput<f32> {
        self.tick(Some(Request::Motion(target(p, kernel::MotionKind::Stream))))
    }

    /// Stream samples toward joint `axis`'s position plus `d` rad, in a
    /// burst continuous by SR-30 (the first 0.04 rad from the set-point,
    /// each next 0.1 rad on): the set-point is still moving 100 ms later
    /// when |d| is near 0.3. Returns the last sample's tick.
    fn nudge(&mut self, axis: usize, d: f64) -> TickOutput<f32> {
        let mut p = self.plant.q;
        let from = f64::from(self.k.status(0).setpoint[axis]);
        let to = p[axis] + d;
        let mut x = from;
        loop {
            let step = if x == from { 0.04 } else { 0.1 };
            x = if (to - x).abs() <= step { to } else { x + step * (to - x).signum() };
            p[axis] = x;
            let out = self.motion(p);
            if x == to {
                return out;
            }
        }
    }

    /// Runs until the state is `s` (at most `max` ticks).
    fn until(&mut self, s: State, max: u32) {
        for _ in 0..max {
            if self.k.state() == s {
                return;
            }
            self.tick(None);
        }
        assert_eq!(self.k.state(), s);
    }

    /// The next tick with `tamper` must be reported against `sr`.
    fn caught(&mut self, sr: Sr, tamper: impl FnOnce(&mut TickOutput<f32>, &mut [Phase; AXES])) -> Violation {
        self.caught_req(sr, None, tamper)
    }

    /// The next tick, with `req` and `tamper`, must be reported against `sr`.
    fn caught_req(
        &mut self,
        sr: Sr,
        req: Option<Request<f32>>,
        tamper: impl FnOnce(&mut TickOutput<f32>, &mut [Phase; AXES]),
    ) -> Violation {
        let (_, r) = self.tick_with(req, tamper);
        let v = r.expect_err("the tampered tick must be a violation");
        assert_eq!(v.sr, sr, "{v}");
        v
    }
}

fn target(p: [f64; AXES], kind: kernel::MotionKind) -> MotionTarget<f32> {
    MotionTarget { position: p.map(|x| x as f32), velocity: [0.0; AXES], kind }
}

#[test]
fn a_clean_run_has_no_violation_and_is_counted() {
    let mut r = Rig::homed();
    let mut p = r.plant.q;
    p[0] += 0.2;
    r.nudge(0, 0.2);
    for _ in 0..50 {
        r.motion(p);
        r.run(9);
    }
    // Silence with the arm at rest at its target: it holds.
    r.run(400);
    assert_eq!(r.k.state(), State::Operational);
    // Silence while still moving: timeout, ramp, SoftEstop; then enable.
    r.nudge(0, 0.28);
    r.run(400);
    assert_eq!(r.k.state(), State::SoftEstop);
    let cap = r.auth.enable();
    r.tick(Some(Request::Enable(cap)));
    assert_eq!(r.k.state(), State::Operational);
    let s = &r.mon.stats;
    assert!(s.accepted >= 51 && s.soft_stops == 1 && s.stopped == 1 && s.enabled == 1 && s.homing_done == 1, "{s:?}");
    assert!(s.moving_ticks > 0 && s.holds == 1, "{s:?}");
}

#[test]
fn sr1_output_before_homing() {
    let mut r = Rig::new();
    r.run(3);
    let v = r.caught(Sr::Sr1, |o, _| o.act.velocity[2] = 0.1);
    assert_eq!(v.axis, None);
}

#[test]
fn sr2_non_finite_and_too_fast_outputs_and_wrong_step_sign() {
    let mut r = Rig::homed();
    let v = r.caught(Sr::Sr2, |o, _| o.act.velocity[1] = f32::NAN);
    assert_eq!(v.axis, Some(1));
    r.caught(Sr::Sr2, |o, _| o.act.velocity[0] = PAROL6.joints[0].max_velocity * 1.01);
    r.caught(Sr::Sr2, |o, _| o.act.step_rate[3] = PAROL6.max_step_rate as i32 + 1);
    r.caught(Sr::Sr2, |o, _| {
        o.act.velocity[4] = 0.0;
        o.act.step_rate[4] = 10;
    });
}

#[test]
fn sr4_fault_tick_with_output() {
    let mut r = Rig::homed();
    let mut p = r.plant.q;
    p[0] += 0.25;
    r.motion(p);
    r.run(20);
    r.plant.hardware_fault = Some(kernel::HardwareFault::TickOverrun);
    // The Fault state's own rule (SR-5) is checked after the fault tick's (SR-4).
    r.caught(Sr::Sr4, |o, _| o.act.velocity[0] = 0.01);
}

#[test]
fn sr5_fault_without_reason_and_changed_reason() {
    let mut r = Rig::homed();
    r.plant.force_switch = 1;
    r.tick(None);
    assert_eq!(r.k.state(), State::Fault);
    r.caught(Sr::Sr5, |o, _| o.status.fault = None);
    r.caught(Sr::Sr5, |o, _| {
        if let Some(f) = o.status.fault.as_mut() {
            f.reason = FaultReason::Runaway { axis: 3 };
        }
    });
}

#[test]
fn sr6_enable_that_jumps() {
    let mut r = Rig::homed();
    r.run(400); // never commanded: no timeout (SR-8), still Operational
    r.plant.force_switch = 1;
    r.tick(None);
    r.plant.force_switch = 0;
    r.run(5);
    let cap = r.auth.enable();
    let (_, res) = r.tick_with(Some(Request::Enable(cap)), |o, _| o.status.setpoint[5] += 0.01);
    assert_eq!(res.expect_err("set-point jump after enable").sr, Sr::Sr6);
}

#[test]
fn sr7_ramp_that_speeds_up() {
    let mut r = Rig::homed();
    r.nudge(0, 0.28);
    for _ in 0..200 {
        if r.k.state() == State::Stopping {
            break;
        }
        r.tick(None);
    }
    assert_eq!(r.k.state(), State::Stopping);
    r.run(50); // halfway down the ramp: 1.5 times the speed is still below vmax
    assert_eq!(r.k.state(), State::Stopping);
    let v = r.caught(Sr::Sr7, |o, _| o.act.velocity[0] *= 1.5);
    assert_eq!(v.axis, Some(0));
}

#[test]
fn sr8_timeout_armed_without_a_command() {
    let mut r = Rig::homed();
    r.caught(Sr::Sr8, |o, _| o.status.timeout_armed = true);
}

#[test]
fn sr9_runaway_estimate_without_fault() {
    let mut r = Rig::homed();
    let v = r.caught(Sr::Sr9, |o, _| o.status.velocity[3] = PAROL6.joints[3].runaway_velocity * 1.1);
    assert_eq!(v.axis, Some(3));
}

#[test]
fn sr13_homing_order_swapped() {
    let mut r = Rig::new();
    r.run(3);
    r.tick(Some(Request::Home));
    // J1 (axis 0) moving while J6 is still seeking: the seed's order forbids it.
    let v = r.caught(Sr::Sr13, |o, ph| {
        ph[0] = Phase::FastSeek;
        o.act.velocity[0] = 0.05;
    });
    assert_eq!(v.axis, Some(0));
}

#[test]
fn sr16_motion_outside_a_moving_phase() {
    let mut r = Rig::new();
    r.run(3);
    r.tick(Some(Request::Home));
    r.caught(Sr::Sr16, |o, _| o.act.velocity[0] = 0.05);
}

#[test]
fn sr19_position_outside_limits_without_fault() {
    let mut r = Rig::homed();
    r.caught(Sr::Sr19, |o, _| o.status.position[2] = PAROL6.joints[2].limit_max + 1.0);
}

#[test]
fn sr25_acceleration_step() {
    let mut r = Rig::homed();
    let v = r.caught(Sr::Sr25, |o, _| o.act.velocity[1] = PAROL6.joints[1].max_velocity * 0.9);
    assert_eq!(v.axis, Some(1));
}

#[test]
fn display_names_the_requirement_axis_and_numbers() {
    let mut r = Rig::homed();
    let v = r.caught(Sr::Sr25, |o, _| o.act.velocity[1] = 0.5);
    let s = v.to_string();
    assert!(s.starts_with("SR-25 J2: output stepped"), "{s}");
    assert!(s.contains("got 0.5") && s.contains("bound") && s.contains("Operational"), "{s}");
    assert_eq!(format!("{v}"), s);
}

#[test]
fn from_kind_skips_only_the_target_checks() {
    let k: Sent<f32> = Sent::from_kind(RequestKind::Motion);
    assert_eq!(k, Sent::Motion(None));
    assert_eq!(k.kind(), RequestKind::Motion);
    assert_eq!(Sent::<f32>::from_kind(RequestKind::HomeJoint(3)).kind(), RequestKind::HomeJoint(3));
}

#[test]
fn seed_dependencies_are_the_seed_order() {
    // J6 first; J5, J4 after J6; J1, J2, J3 after J4, J5, J6.
    assert_eq!(SEED_DEPENDENCIES[5], 0);
    assert_eq!(SEED_DEPENDENCIES[4], bit(5));
    assert_eq!(SEED_DEPENDENCIES[3], bit(5));
    for d in &SEED_DEPENDENCIES[..3] {
        assert_eq!(*d, bit(3) | bit(4) | bit(5));
    }
}

/// A rig moving J1 toward a sample 0.28 rad away, `n` ticks after it.
fn moving(n: u32) -> Rig {
    let mut r = Rig::homed();
    r.nudge(0, 0.28);
    r.run(n);
    assert_eq!(r.k.state(), State::Operational);
    r
}

/// The events of a real tick of a fork of `r`'s kernel after `f` (events
/// cannot be built outside the kernel).
fn events_after(r: &Rig, ticks: u32, req: Option<Request<f32>>) -> kernel::Events {
    let (mut k, _) = r.k.fork();
    let mut plant = r.plant.clone();
    let mut out = k.tick(&plant.sense(), req);
    plant.apply(&out.act.step_rate);
    for _ in 0..ticks {
        out = k.tick(&plant.sense(), None);
        plant.apply(&out.act.step_rate);
    }
    out.events
}

#[test]
fn sr27_setpoint_velocity_step() {
    let mut r = moving(30);
    // 1 mrad more in one tick: within vmax/tick_hz (SR-18) but a velocity
    // change of 1 rad/s.
    let v = r.caught(Sr::Sr27, |o, _| o.status.setpoint[0] += 0.001);
    assert_eq!(v.axis, Some(0));
    assert!(v.to_string().contains("velocity changed"), "{v}");
}

#[test]
fn sr27_setpoint_that_leaves_its_target() {
    let mut r = Rig::homed();
    r.run(5);
    // At rest at its target: one 10 um step away is within every
    // acceleration bound but leaves the target.
    let v = r.caught(Sr::Sr27, |o, _| o.status.setpoint[2] += 1e-5 * 2.0);
    assert_eq!(v.axis, Some(2));
    assert!(v.to_string().contains("passed the target"), "{v}");
}

#[test]
fn sr27_setpoint_outside_the_limits() {
    let mut r = Rig::homed();
    // A go-to to exactly the limit of J1, then a set-point 1 mrad past it.
    let mut p = r.plant.q;
    p[0] = f64::from(PAROL6.joints[0].limit_max);
    r.tick(Some(Request::Motion(target(p, kernel::MotionKind::GoTo))));
    r.run(2000);
    assert_eq!(r.k.state(), State::Operational);
    let v = r.caught(Sr::Sr27, |o, _| o.status.setpoint[0] = PAROL6.joints[0].limit_max + 2e-5);
    assert!(v.to_string().contains("outside the joint limits") || v.to_string().contains("passed"), "{v}");
}

#[test]
fn sr29_holding_while_moving_and_latching_at_rest() {
    // Holding at the timeout while the set-point still moves.
    let mut r = moving(0);
    let timeout = ms_to_ticks(PAROL6.command_timeout_ms, PAROL6.tick_hz);
    let hold = {
        let mut h = Rig::homed();
        h.nudge(0, 0.01);
        h.run(timeout - 1);
        events_after(&h, 0, None)
    };
    assert!(hold.iter().any(|e| *e == Event::Holding), "{hold:?}");
    r.run(timeout - 2);
    let v = r.caught(Sr::Sr29, |o, _| {
        o.events = hold;
        o.status.state = State::Operational;
        o.status.timeout_armed = false;
    });
    assert!(v.to_string().contains("still moves"), "{v}");
    // A latch at the timeout of an arm at rest at its target.
    let mut h = Rig::homed();
    h.nudge(0, 0.01);
    h.run(timeout - 1);
    let stop = {
        let mut m = moving(0);
        m.run(timeout - 2);
        events_after(&m, 0, None)
    };
    assert!(stop.iter().any(|e| matches!(e, Event::SoftEstop { .. })), "{stop:?}");
    let v = h.caught(Sr::Sr29, |o, _| {
        o.events = stop;
        o.status.state = State::Stopping;
    });
    assert!(v.to_string().contains("at rest"), "{v}");
}

#[test]
fn sr5_home_accepted_while_latched() {
    let mut r = moving(0);
    r.run(400);
    assert_eq!(r.k.state(), State::SoftEstop);
    let quiet = events_after(&r, 0, None);
    assert!(quiet.is_empty());
    // The kernel refuses it (Latched); the tampered tick drops the refusal.
    let v = r.caught_req(Sr::Sr5, Some(Request::Home), |o, _| o.events = quiet);
    assert!(v.to_string().contains("HOME accepted"), "{v}");
    // And leaving SoftEstop for Homing on a HOME is no longer an exit.
    let started = {
        let mut h = Rig::new();
        h.run(3);
        events_after(&h, 0, Some(Request::Home))
    };
    r.caught_req(Sr::Sr5, Some(Request::Home), |o, _| {
        o.events = started;
        o.status.state = State::Homing;
    });
}

#[test]
fn sr7_homing_after_a_latching_stop_and_home_without_a_stop() {
    // A timeout ramp (no HOME pending) may not end in Homing.
    let mut r = moving(0);
    r.until(State::Stopping, 200);
    let n = ms_to_ticks(PAROL6.soft_stop_ms, PAROL6.tick_hz);
    r.run(n - 2);
    assert_eq!(r.k.state(), State::Stopping);
    let started = {
        let mut h = Rig::new();
        h.run(3);
        events_after(&h, 0, Some(Request::Home))
    };
    let v = r.caught(Sr::Sr7, |o, _| {
        o.events = started;
        o.status.state = State::Homing;
    });
    assert!(v.to_string().contains("pending HOME"), "{v}");
    // HOME while moving must stop first (HomingAfterStop), not home at once.
    let mut r = moving(30);
    let v = r.caught_req(Sr::Sr7, Some(Request::Home), |o, _| {
        o.events = started;
        o.status.state = State::Homing;
        o.act.velocity = [0.0; AXES];
        o.act.step_rate = [0; AXES];
    });
    assert!(v.to_string().contains("without a stop first"), "{v}");
}

#[test]
fn home_while_moving_stops_then_homes_cleanly() {
    let mut r = moving(30);
    let out = r.tick(Some(Request::Home));
    assert!(out.events.iter().any(|e| *e == Event::HomingAfterStop), "{:?}", out.events);
    assert_eq!(out.status.state, State::Stopping);
    r.until(State::Homing, 200);
    r.until(State::Operational, 60_000);
    assert_eq!(r.mon.stats.homes_after_stop, 1);
}

#[test]
fn sr8_goto_that_arms_the_timeout() {
    let mut r = Rig::homed();
    let mut p = r.plant.q;
    p[3] += 1.0;
    let (_, res) = r.tick_with(Some(Request::Motion(target(p, kernel::MotionKind::GoTo))), |o, _| {
        o.status.timeout_armed = true;
    });
    let v = res.expect_err("an armed go-to");
    assert_eq!(v.sr, Sr::Sr8, "{v}");
}

#[test]
fn sr30_far_stream_sample_accepted_and_near_one_refused() {
    let mut r = Rig::homed();
    let quiet = events_after(&r, 0, None);
    let mut p = r.plant.q;
    p[0] += 0.5; // beyond the set-point's reach from rest (0.044 rad on J1)
    let far = Request::Motion(target(p, kernel::MotionKind::Stream));
    let v = r.caught_req(Sr::Sr30, Some(far), |o, _| {
        o.events = quiet;
        o.status.timeout_armed = true;
    });
    assert_eq!(v.axis, Some(0));
    let mut r = Rig::homed();
    let mut p = r.plant.q;
    p[0] += 0.5;
    let refused = events_after(&r, 0, Some(Request::Motion(target(p, kernel::MotionKind::Stream))));
    assert!(refused.iter().any(|e| matches!(e, Event::Rejected { reason: Reject::TargetJump { axis: 0 }, .. })));
    let mut p = r.plant.q;
    p[0] += 0.03;
    let near = Request::Motion(target(p, kernel::MotionKind::Stream));
    let v = r.caught_req(Sr::Sr30, Some(near), |o, _| {
        o.events = refused;
        o.status.timeout_armed = false;
    });
    assert!(v.to_string().contains("reach refused"), "{v}");
    // A go-to far away is fine (the kernel's own answer).
    let mut r = Rig::homed();
    let mut p = r.plant.q;
    p[0] += 1.0;
    r.tick(Some(Request::Motion(target(p, kernel::MotionKind::GoTo))));
    r.run(1500);
    assert!((r.plant.q[0] - p[0]).abs() < 0.01, "{:?}", r.plant.q);
    assert!(r.mon.stats.goto_accepted == 1);
}

#[test]
fn sr31_link_lost_while_moving_without_a_stop() {
    let mut r = moving(20);
    r.plant.link_lost = true;
    let quiet = events_after(&Rig::homed(), 0, None);
    let v = r.caught(Sr::Sr31, |o, _| {
        o.events = quiet;
        o.status.state = State::Operational;
    });
    assert!(v.to_string().contains("without a soft stop"), "{v}");
    // At rest a lost link holds; moving, it stops at once.
    let mut r = Rig::homed();
    r.plant.link_lost = true;
    r.run(20);
    assert_eq!(r.k.state(), State::Operational);
    r.plant.link_lost = false;
    r.nudge(0, 0.2);
    r.run(10);
    r.plant.link_lost = true;
    let out = r.tick(None);
    assert_eq!(out.status.state, State::Stopping);
    assert_eq!(r.mon.stats.link_stops, 1);
}

#[test]
fn sr25_homing_output_step() {
    let mut r = Rig::new();
    r.run(3);
    r.tick(Some(Request::Home));
    // The run rests homing_settle_ms (50 ms) before J6 seeks.
    r.run(70);
    assert_eq!(r.k.homing_phases()[5], Phase::FastSeek);
    let v = r.caught(Sr::Sr25, |o, _| o.act.velocity[5] += 0.5);
    assert_eq!(v.axis, Some(5));
}

#[test]
fn sr28_homing_travel_beyond_its_bound() {
    let mut r = Rig::new();
    r.run(3);
    r.tick(Some(Request::Home));
    // The run rests homing_settle_ms (50 ms) before J6 seeks.
    r.run(70);
    assert_eq!(r.k.homing_phases()[5], Phase::FastSeek);
    let v = r.caught(Sr::Sr28, |o, _| o.status.position[5] += PAROL6.joints[5].homing.max_travel + 0.01);
    assert_eq!(v.axis, Some(5));
}

#[test]
fn sr28_following_error_on_a_clean_plant_and_a_stall_without_one() {
    // A real following-error fault (J1 stalled, commanded to move).
    let (fe_events, fe_fault) = {
        let mut h = Rig::homed();
        h.plant.stalled = 1;
        h.nudge(0, 0.2);
        let mut found = None;
        for _ in 0..200 {
            let out = h.tick(None);
            if out.status.state == State::Fault {
                found = Some((out.events, out.status.fault));
                break;
            }
        }
        found.expect("a stalled J1 faults")
    };
    assert!(matches!(fe_fault, Some(Fault { reason: FaultReason::FollowingError { axis: 0 }, .. })), "{fe_fault:?}");
    let mut r = Rig::homed();
    let v = r.caught(Sr::Sr28, |o, _| {
        o.events = fe_events;
        o.status.fault = fe_fault;
        o.status.state = State::Fault;
        o.act.velocity = [0.0; AXES];
        o.act.step_rate = [0; AXES];
    });
    assert!(v.to_string().contains("nothing injected"), "{v}");
    // A stalled joint whose set-point runs away from it, and no fault.
    let mut r = Rig::homed();
    let limit = ms_to_ticks(PAROL6.following_error_ms, PAROL6.tick_hz) + FE_LIVENESS_SLACK.1;
    let mut res = Ok(());
    for _ in 0..=limit {
        let (_, c) = r.tick_facts(
            None,
            |_, _| {},
            |f| {
                f.broken_motor = 1;
                f.q[0] += 0.1;
            },
        );
        res = res.and(c);
    }
    let v = res.expect_err("a stall without a fault");
    assert_eq!((v.sr, v.axis), (Sr::Sr28, Some(0)), "{v}");
}

#[test]
fn sr19_joint_beyond_the_overrun_bound_on_a_clean_plant() {
    let mut r = Rig::homed();
    let j = PAROL6.joints[2];
    let beyond = f64::from(j.limit_max + PAROL6.overrun_bound(&j)) + 0.01;
    let (_, res) = r.tick_facts(None, |_, _| {}, |f| f.q[2] = beyond);
    let v = res.expect_err("beyond the overrun bound");
    assert_eq!((v.sr, v.axis), (Sr::Sr19, Some(2)), "{v}");
}

/// The go-to + frame case with the refusal hidden (as a constant distance
/// bound from the set-point would accept it): a driver frame 0.12 rad
/// ahead of J6's set-point, inside its 0.37 rad stopping distance, during a
/// full-speed go-to, accepted: SR-30.
#[test]
fn sr30_a_frame_inside_a_go_to_s_stopping_distance_accepted() {
    let mut r = Rig::homed();
    let mut p = r.plant.q;
    p[5] = 0.5;
    r.tick(Some(Request::Motion(target(p, kernel::MotionKind::GoTo))));
    r.run(3_000);
    p[5] = -5.5;
    r.tick(Some(Request::Motion(target(p, kernel::MotionKind::GoTo))));
    while r.k.status(0).setpoint[5] > -0.134 {
        r.tick(None);
    }
    p[5] = -0.25;
    let quiet = events_after(&r, 0, None);
    let frame = Request::Motion(target(p, kernel::MotionKind::Stream));
    let v = r.caught_req(Sr::Sr30, Some(frame), |o, _| {
        o.events = quiet;
        o.status.timeout_armed = true;
    });
    assert_eq!(v.axis, Some(5), "{v}");
}

/// `fx_word` reads the raw I8F24 word (every boundary word and a stride
/// through the whole range); only I8F24 is taken for the fixed-point
/// variant.
#[test]
fn fx_word_is_the_raw_word() {
    use crate::motion::{fx_word, is_fixed_point};
    use kernel::Fx;
    assert!(is_fixed_point::<Fx>() && !is_fixed_point::<f32>());
    let mut n = 0u64;
    for w in [i32::MIN, i32::MIN + 1, -1, 0, 1, 1 << 24, i32::MAX - 1, i32::MAX]
        .into_iter()
        .chain((i32::MIN..=i32::MAX).step_by(65_521))
    {
        assert_eq!(fx_word(Fx::from_bits(w)), i64::from(w), "word {w}");
        n += 1;
    }
    println!("fx_word: {n} words read back exactly");
}

/// The SR-7, SR-18 and SR-25 step check (`first_step_over`) compares
/// I8F24 in integer arithmetic on the raw words; its `f64` path (through
/// `to_f32`) must give the same verdict wherever both operands are exact in
/// f32, and elsewhere differ only where the two operands' f32 rounding
/// (half an f32 ulp each) moves the step across the bound: the integer
/// path is the exact one. Enumerated slices, not the whole domain: for each
/// of the monitor's PAROL6 step bounds (acceleration, set-point speed and
/// ramp step per joint), every step within 2048 words of the bound, up and
/// down, from 36 base words (0 and both signs of 0.5 to 127 rad, each also
/// with odd low bits).
#[test]
fn step_check_integer_and_f64_paths_agree() {
    use crate::motion::{slack_words, step_within_f64, step_within_words};
    use kernel::Fx;
    let mon = Monitor::<Fx>::new(&PAROL6);
    let mut slacks: Vec<f64> = Vec::new();
    for i in 0..AXES {
        slacks.push(mon.acc_per_tick[i] * 1.0001 + 1e-6);
        slacks.push(mon.vel_per_tick[i] * 1.001 + 1e-6);
        slacks.push(mon.stop_step[i] * 1.001 + 1e-6);
    }
    slacks.sort_by(f64::total_cmp);
    slacks.dedup();
    let mut bases: Vec<i64> = vec![0];
    for v in [0.5f64, 1.0, 1.5, 3.0, 7.25, 42.0, 100.0, 127.0] {
        let w = (v * 16_777_216.0) as i64;
        for b in [w, w + 12_345, -w, -w - 12_345] {
            bases.push(b);
        }
    }
    bases.push(12_345);
    bases.push(-12_345);
    bases.push(1);
    // At most 24 significant bits: the word converts to f32 exactly.
    let exact_in_f32 = |w: i64| {
        let u = w.unsigned_abs();
        u < (1 << 24) || u.trailing_zeros() >= (64 - u.leading_zeros()).saturating_sub(24)
    };
    let half_ulp = |w: i64| {
        let x = (w as f64 / 16_777_216.0).abs() as f32;
        f64::from(x.next_up() - x) / 2.0
    };
    let (mut pairs, mut agree, mut differ) = (0u64, 0u64, 0u64);
    let mut widest = 0.0f64;
    for &slack in &slacks {
        let k = slack_words(slack) as i64;
        assert!(k > 0 && (k as f64) <= slack * 16_777_216.0 && ((k + 1) as f64) > slack * 16_777_216.0);
        for &b in &bases {
            for d in -2048i64..=2048 {
                for a in [b + k + d, b - k - d] {
                    if i64::from(i32::MIN) > a || a > i64::from(i32::MAX) {
                        continue;
                    }
                    pairs += 1;
                    let (fa, fb) = (Fx::from_bits(a as i32), Fx::from_bits(b as i32));
                    let int = step_within_words(a, b, slack_words(slack));
                    let flt = step_within_f64(fa, fb, slack);
                    if int == flt {
                        agree += 1;
                        continue;
                    }
                    differ += 1;
                    assert!(
                        !(exact_in_f32(a) && exact_in_f32(b)),
                        "paths differ with both operands exact in f32: a {a}, b {b}, slack {slack}"
                    );
                    let exact = (a - b).unsigned_abs() as f64 / 16_777_216.0;
                    let rounded = (f64::from(fa.to_f32()) - f64::from(fb.to_f32())).abs();
                    let err = (exact - rounded).abs();
                    assert!(
                        err <= half_ulp(a) + half_ulp(b),
                        "a {a}, b {b}: the f32 rounding {err} explains no difference"
                    );
                    assert!(
                        (exact - slack).abs() <= err,
                        "a {a}, b {b}: the step {exact} is not within rounding of {slack}"
                    );
                    widest = widest.max(err);
                }
            }
        }
    }
    println!(
        "step check: {} bounds, {pairs} pairs: {agree} same verdict, {differ} differ (all within the operands' f32 rounding, at most {widest:.3e})",
        slacks.len()
    );
    assert!(pairs > 1_000_000 && agree > 0);
}
