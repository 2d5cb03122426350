//! The monitor against the real kernel (no violation on a clean run) and
//! against fabricated bad outputs (each caught, with the right SR).

use super::*;
use crate::plant::{Plant, Witness};
use kernel::config::{PAROL6, PAROL6_VALIDATED};
use kernel::{Authority, Kernel, KernelF32};
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
        let sense = self.plant.sense();
        self.wit.before(&self.plant);
        let sent = req.as_ref().map(Sent::of);
        let out = self.k.tick(&sense, req);
        let facts = self.wit.after(&self.plant, &out);
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
        let t = MotionTarget { position: p.map(|x| x as f32), velocity: [0.0; AXES], kind: kernel::MotionKind::Stream };
        self.tick(Some(Request::Motion(t)))
    }

    /// The next tick with `tamper` must be reported against `sr`.
    fn caught(&mut self, sr: &str, tamper: impl FnOnce(&mut TickOutput<f32>, &mut [Phase; AXES])) -> Violation {
        let (_, r) = self.tick_with(None, tamper);
        let v = r.expect_err("the tampered tick must be a violation");
        assert_eq!(v.sr, sr, "{v}");
        v
    }
}

#[test]
fn a_clean_run_has_no_violation_and_is_counted() {
    let mut r = Rig::homed();
    let mut p = r.plant.q;
    p[0] += 0.2;
    for _ in 0..50 {
        r.motion(p);
        r.run(9);
    }
    // Silence: timeout, ramp, SoftEstop; then enable.
    r.run(400);
    assert_eq!(r.k.state(), State::SoftEstop);
    let cap = r.auth.enable();
    r.tick(Some(Request::Enable(cap)));
    assert_eq!(r.k.state(), State::Operational);
    let s = &r.mon.stats;
    assert!(s.accepted >= 50 && s.soft_stops == 1 && s.stopped == 1 && s.enabled == 1 && s.homing_done == 1);
    assert!(s.moving_ticks > 0);
}

#[test]
fn sr1_output_before_homing() {
    let mut r = Rig::new();
    r.run(3);
    let v = r.caught("SR-1", |o, _| o.act.velocity[2] = 0.1);
    assert_eq!(v.axis, None);
}

#[test]
fn sr2_non_finite_and_too_fast_outputs_and_wrong_step_sign() {
    let mut r = Rig::homed();
    let v = r.caught("SR-2", |o, _| o.act.velocity[1] = f32::NAN);
    assert_eq!(v.axis, Some(1));
    r.caught("SR-2", |o, _| o.act.velocity[0] = PAROL6.joints[0].max_velocity * 1.01);
    r.caught("SR-2", |o, _| o.act.step_rate[3] = PAROL6.max_step_rate as i32 + 1);
    r.caught("SR-2", |o, _| {
        o.act.velocity[4] = 0.0;
        o.act.step_rate[4] = 10;
    });
}

#[test]
fn sr4_fault_tick_with_output() {
    let mut r = Rig::homed();
    let mut p = r.plant.q;
    p[0] += 0.3;
    r.motion(p);
    r.run(20);
    r.plant.hardware_fault = Some(kernel::HardwareFault::TickOverrun);
    // The Fault state's own rule (SR-5) is checked after the fault tick's (SR-4).
    r.caught("SR-4", |o, _| o.act.velocity[0] = 0.01);
}

#[test]
fn sr5_fault_without_reason_and_changed_reason() {
    let mut r = Rig::homed();
    r.plant.force_switch = 1;
    r.tick(None);
    assert_eq!(r.k.state(), State::Fault);
    r.caught("SR-5", |o, _| o.status.fault = None);
    r.caught("SR-5", |o, _| {
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
    assert_eq!(res.expect_err("set-point jump after enable").sr, "SR-6");
}

#[test]
fn sr7_ramp_that_speeds_up() {
    let mut r = Rig::homed();
    let mut p = r.plant.q;
    p[0] += 0.5;
    r.motion(p);
    for _ in 0..200 {
        if r.k.state() == State::Stopping {
            break;
        }
        r.tick(None);
    }
    assert_eq!(r.k.state(), State::Stopping);
    r.run(50); // halfway down the ramp: 1.5 times the speed is still below vmax
    assert_eq!(r.k.state(), State::Stopping);
    let v = r.caught("SR-7", |o, _| o.act.velocity[0] *= 1.5);
    assert_eq!(v.axis, Some(0));
}

#[test]
fn sr8_timeout_armed_without_a_command() {
    let mut r = Rig::homed();
    r.caught("SR-8", |o, _| o.status.timeout_armed = true);
}

#[test]
fn sr9_runaway_estimate_without_fault() {
    let mut r = Rig::homed();
    let v = r.caught("SR-9", |o, _| o.status.velocity[3] = PAROL6.joints[3].runaway_velocity * 1.1);
    assert_eq!(v.axis, Some(3));
}

#[test]
fn sr13_homing_order_swapped() {
    let mut r = Rig::new();
    r.run(3);
    r.tick(Some(Request::Home));
    // J1 (axis 0) moving while J6 is still seeking: the seed's order forbids it.
    let v = r.caught("SR-13", |o, ph| {
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
    r.caught("SR-16", |o, _| o.act.velocity[0] = 0.05);
}

#[test]
fn sr19_position_outside_limits_without_fault() {
    let mut r = Rig::homed();
    r.caught("SR-19", |o, _| o.status.position[2] = PAROL6.joints[2].limit_max + 1.0);
}

#[test]
fn sr25_acceleration_step() {
    let mut r = Rig::homed();
    let v = r.caught("SR-25", |o, _| o.act.velocity[1] = PAROL6.joints[1].max_velocity * 0.9);
    assert_eq!(v.axis, Some(1));
}

#[test]
fn display_names_the_requirement_axis_and_numbers() {
    let mut r = Rig::homed();
    let v = r.caught("SR-25", |o, _| o.act.velocity[1] = 0.5);
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
