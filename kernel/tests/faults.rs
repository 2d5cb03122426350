//! What faults, on which tick and with which reason: following error and
//! its direction rule, runaway, position limits, limit switches, encoder
//! loss, jumps and implausible readings, the boot timeout, hardware
//! overruns; a fault keeps its first reason (SAFETY.md SR-3, SR-4, SR-5,
//! SR-9, SR-10, SR-11, SR-19, SR-21, SR-28; docs/PROTOCOL.md 6.7). Both
//! numeric variants, every tick checked by the safety monitor (the common
//! rig).

mod common;

use common::{both, homed, EncoderFault, Rig, START};
use kernel::config::{ms_to_ticks, ArmConfig, Validated, PAROL6, POSITION_ABS_MAX};
use kernel::{Event, FaultReason, HomingStatus, Reject, RequestKind, Scalar, State, TickOutput};

both!(
    a_motor_reversed_mid_motion_faults_on_the_direction_rule,
    a_joint_lagging_while_moving_with_the_command_is_no_fault,
    a_motor_that_stalls_during_a_soft_stop_faults,
    homed_axis_leaving_its_limits_faults,
    a_homed_joint_pushed_past_its_limit_faults_on_the_position_limit,
    unhomed_arm_outside_the_limits_is_not_a_fault,
    runaway_faults_every_axis_in_the_same_tick,
    runaway_faults_in_unhomed_where_no_path_is_followed,
    limit_switch_outside_homing_faults_and_enable_is_refused_while_pressed,
    encoder_loss_and_jump_fault_and_require_rehoming,
    counts_out_of_range_are_lost_samples,
    boot_timeout_names_the_unready_encoder_on_time,
    after_a_boot_timeout_enable_waits_for_the_missing_encoder,
    a_home_queued_in_boot_fails_at_the_boot_timeout,
    an_estimate_beyond_the_absolute_bound_is_a_numeric_fault,
    hardware_overrun_faults,
    enable_is_refused_while_a_hardware_fault_persists,
    fault_keeps_its_first_reason,
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
/// evaluated on the reported status, says. Catches: every comparison of
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
/// fault. Catches: either half of `against` with its `&&` as `||`.
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

/// The same in Stopping: J6 stalls the moment a soft stop starts from
/// speed (link lost); the ramp's commanded path runs away from the
/// estimate and the stop ends in a fault, not in a quiet latch.
fn a_motor_that_stalls_during_a_soft_stop_faults<S: Scalar>() {
    let mut r = homed::<S>();
    let mut p = r.plant.q;
    p[5] -= 1.5;
    r.goto(p);
    r.run(150);
    assert!(r.last.unwrap().act.velocity[5].to_f32().abs() > 1.0, "J6 at speed");
    r.plant.link_lost = true;
    r.plant.stalled = 1 << 5;
    let out = r.tick(None);
    assert_eq!(out.status.state, State::Stopping);
    r.run_until(500, |o| o.status.state != State::Stopping).expect("the stop ends");
    let out = r.last.unwrap();
    assert_eq!(out.status.state, State::Fault);
    assert_eq!(out.status.fault.unwrap().reason, FaultReason::FollowingError { axis: 5 });
}

/// A joint dragged off its path by an outside force faults on its
/// following error long before it can leave its limits (the position limit
/// is the second line: it keeps enable refused while the joint is outside).
fn homed_axis_leaving_its_limits_faults<S: Scalar>() {
    let mut r = homed::<S>();
    // J2 is dragged harder than its 3 rad/s clamp can resist: it drifts at
    // a net 0.5 rad/s toward its upper limit.
    let q0 = r.plant.q[1];
    r.plant.disturbance[1] = 3.5;
    let n = r.run_until(5_000, |o| o.status.state == State::Fault).expect("fault");
    let out = r.last.unwrap();
    assert_eq!(out.status.fault.unwrap().reason, FaultReason::FollowingError { axis: 1 });
    // The arm is pushed at up to 3.5 rad/s (its output ramps against the
    // push at the acceleration limit): 0.05 rad of error plus the 20 ms the
    // error may last, at that speed.
    let drift = r.plant.q[1] - q0;
    // Plus 20 mrad: the estimate lags the true angle while it accelerates.
    let bound = f64::from(PAROL6.following_error) + 3.5 * (f64::from(PAROL6.following_error_ms) + 1.0) / 1000.0 + 0.02;
    println!("J2 dragged at 3.5 rad/s: following-error fault after {n} ticks, {drift:.3} rad (bound {bound:.3})");
    assert!(drift < bound, "faulted after {drift} rad of drift");
    // Still dragged (outputs are zero in Fault) until past its limit + margin.
    while r.plant.q[1] <= f64::from(PAROL6.joints[1].limit_max + PAROL6.position_margin) + 0.01 {
        r.tick(None);
    }
    r.plant.disturbance[1] = 0.0;
    r.run(300); // at rest again (a moving joint would be refused as too fast)
    let out = r.enable();
    assert!(out.events.iter().any(|e| *e
        == Event::Rejected {
            request: RequestKind::Enable,
            reason: Reject::CauseActive(FaultReason::PositionLimit { axis: 1 })
        }));

    // The lower side: J3 (its switch is at the upper end) dragged below.
    let mut r = homed::<S>();
    r.plant.disturbance[2] = -(f64::from(PAROL6.joints[2].max_velocity) + 0.5);
    r.run_until(10_000, |o| o.status.state == State::Fault).expect("fault");
    assert_eq!(r.last.unwrap().status.fault.unwrap().reason, FaultReason::FollowingError { axis: 2 });
}

/// SR-8: a homed joint outside its limits plus the margin faults as a
/// position limit in Operational, the tick it gets there. With the
/// PAROL6's 20 ms following-error time the following error always fires
/// first (it is the first line: `homed_axis_leaving_its_limits_faults`);
/// with the longest time `config::check` allows (200 ms), a joint pushed
/// hard past a limit reaches limit + margin before that, and the position
/// limit is what stops it. Both sides: J1 up (its switch is at the lower
/// end), J3 down (its switch is at the upper end). Catches: the check's
/// `||` as `&&`, `<` or `>` as `==`.
fn a_homed_joint_pushed_past_its_limit_faults_on_the_position_limit<S: Scalar>() {
    let cfg = Validated::new(ArmConfig { following_error_ms: 200, ..PAROL6 }).expect("valid");
    for (j, up) in [(0usize, true), (2, false)] {
        let mut r = Rig::<S>::with_config(START, &cfg);
        r.boot_and_home();
        let c = &PAROL6.joints[j];
        let (limit, edge) = if up {
            (c.limit_max, c.limit_max + PAROL6.position_margin)
        } else {
            (c.limit_min, c.limit_min - PAROL6.position_margin)
        };
        let mut p = r.plant.q;
        p[j] = f64::from(limit);
        r.goto(p);
        r.run(1_500);
        assert_eq!(r.k.state(), State::Operational);
        // Pushed harder than the joint's speed limit can resist, below
        // its runaway speed.
        let push = 1.1 * f64::from(c.max_velocity);
        r.plant.disturbance[j] = if up { push } else { -push };
        let n = r.run_until(1_000, |o| o.status.state == State::Fault).expect("faults");
        let out = r.last.unwrap();
        assert_eq!(out.status.fault.unwrap().reason, FaultReason::PositionLimit { axis: j as u8 }, "J{}", j + 1);
        // Within a tick's travel of limit + margin.
        let x = f64::from(out.status.position[j].to_f32());
        let beyond = if up { x - f64::from(edge) } else { f64::from(edge) - x };
        assert!((0.0..0.01).contains(&beyond), "J{}: {beyond} rad beyond the edge after {n} ticks", j + 1);
        // Left there at rest, the cause stays present: <ENABLE> is refused
        // (PROTOCOL.md 6.5, CAUSE_ACTIVE). Catches: `present_cause`'s
        // lower bound as `==`.
        r.plant.disturbance[j] = 0.0;
        r.run(200);
        let out = r.enable();
        let reason = Reject::CauseActive(FaultReason::PositionLimit { axis: j as u8 });
        assert!(
            out.events.iter().any(|e| *e == Event::Rejected { request: RequestKind::Enable, reason }),
            "J{}: {:?}",
            j + 1,
            out.events
        );
        assert_eq!(out.status.state, State::Fault);
    }
}

/// Before homing the estimate is not in the joint frame: a power-on pose
/// outside the joint limits is not a position fault (only homed, moving
/// axes are checked).
fn unhomed_arm_outside_the_limits_is_not_a_fault<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.run(3);
    // Pushed slowly (0.5 rad/s for 4 s) to 2 rad beyond J1's upper limit.
    r.plant.disturbance[0] = 0.5;
    let out = r.run(4000 + (1000.0 * (f64::from(PAROL6.joints[0].limit_max) - START[0])) as u32 * 2);
    r.plant.disturbance[0] = 0.0;
    assert!(out.status.position[0].to_f32() > PAROL6.joints[0].limit_max + 1.0, "{:?}", out.status.position);
    assert_eq!(out.status.state, State::Unhomed, "{:?}", out.status.fault);
}

fn runaway_faults_every_axis_in_the_same_tick<S: Scalar>() {
    let mut r = homed::<S>();
    let mut p = r.plant.q;
    p[0] += 0.3;
    r.goto(p);
    r.run(5);
    // J5 is pushed by an outside force beyond its runaway threshold.
    r.plant.disturbance[4] = 9.0;
    let mut faulted = None;
    for _ in 0..200 {
        let out = r.tick(None);
        if out.status.state == State::Fault {
            faulted = Some(out);
            break;
        }
    }
    let out = faulted.expect("runaway detected");
    // Dragged at 9 rad/s, J5 is both off its path and too fast: whichever
    // check sees it first names it; every axis stops in that tick.
    let reason = out.status.fault.unwrap().reason;
    assert!(matches!(reason, FaultReason::Runaway { axis: 4 } | FaultReason::FollowingError { axis: 4 }), "{reason:?}");
    assert!(out.act.velocity.iter().all(|v| *v == S::ZERO), "all axes zero in the fault tick");
    assert!(out.act.step_rate.iter().all(|v| *v == 0));
}

/// SR-9: a joint faster than its runaway speed faults in every state. In
/// Unhomed nothing else can see it (no path is followed, an unhomed arm
/// outside its limits is no fault): a joint pushed past its runaway speed
/// faults as a runaway, within a few ticks of the observer's velocity
/// passing the threshold. Catches: the runaway check as `==`.
fn runaway_faults_in_unhomed_where_no_path_is_followed<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.run(3);
    assert_eq!(r.k.state(), State::Unhomed);
    let runaway = f64::from(PAROL6.joints[4].runaway_velocity);
    r.plant.disturbance[4] = 1.2 * runaway;
    let n = r.run_until(500, |o| o.status.state == State::Fault).expect("faults");
    let out = r.last.unwrap();
    assert_eq!(out.status.fault.unwrap().reason, FaultReason::Runaway { axis: 4 }, "after {n} ticks");
    assert!(n < 100, "{n} ticks");
}

/// C++ defect 4 (docs/spec/robot.md section 6): enable cleared a fault while a limit switch was pressed.
fn limit_switch_outside_homing_faults_and_enable_is_refused_while_pressed<S: Scalar>() {
    {
        // A fault that loses no zero keeps homing complete (H2).
        let mut r = homed::<S>();
        r.plant.force_switch = 0b100;
        let out = r.tick(None);
        assert_eq!(out.status.state, State::Fault);
        assert_eq!(out.status.homing, HomingStatus::Complete);
    }
    let mut r = homed::<S>();
    r.motion(r.plant.q);
    r.plant.force_switch = 0b100; // J3
    let out = r.tick(None);
    assert_eq!(out.status.state, State::Fault);
    assert!(out.act.velocity.iter().all(|v| *v == S::ZERO));
    assert_eq!(out.status.fault.unwrap().reason, FaultReason::LimitSwitch { axis: 2 });
    let out = r.enable();
    assert!(out.events.iter().any(|e| *e
        == Event::Rejected {
            request: RequestKind::Enable,
            reason: Reject::CauseActive(FaultReason::LimitSwitch { axis: 2 })
        }));
    assert_eq!(out.status.state, State::Fault);
    r.plant.force_switch = 0;
    r.run(3);
    let out = r.enable();
    assert_eq!(out.status.state, State::Operational);
}

fn encoder_loss_and_jump_fault_and_require_rehoming<S: Scalar>() {
    let limit = PAROL6.encoder_invalid_limit;
    // Up to `limit` lost samples in a row are ridden through (the observer
    // coasts); one more is a fault that zeroes every axis.
    let mut r = homed::<S>();
    r.plant.encoder[2] = EncoderFault::Lost;
    for _ in 0..limit {
        assert_eq!(r.tick(None).status.state, State::Operational);
    }
    let out = r.tick(None);
    assert_eq!(out.status.fault.unwrap().reason, FaultReason::EncoderLost { axis: 2 });
    assert!(out.act.velocity.iter().all(|v| *v == S::ZERO));
    // Only J3 loses its zero; homing is no longer complete (H0, not H2).
    assert_eq!(out.status.homed, 0b11_1011);
    assert_eq!(out.status.homing, HomingStatus::NotRequested);
    let out = r.enable();
    assert!(out.events.iter().any(|e| matches!(e, Event::Rejected { reason: Reject::CauseActive(_), .. })));
    r.plant.encoder[2] = EncoderFault::None;
    let out = r.enable();
    // J3's count was lost: it must be homed again; the others keep theirs.
    assert_eq!(out.status.state, State::Unhomed);
    assert_eq!(out.status.homed, 0b11_1011);
    assert_ne!(out.status.homing, HomingStatus::Complete);

    // A single glitch is skipped; a persistent jump faults.
    let mut r = homed::<S>();
    r.plant.glitch[1] = 1500;
    assert_eq!(r.tick(None).status.state, State::Operational);
    r.plant.glitch[1] = 0;
    assert_eq!(r.run(5).status.state, State::Operational);
    r.plant.glitch[1] = 1500;
    let out = r.run(limit + 1);
    assert!(matches!(out.status.fault.unwrap().reason, FaultReason::EncoderJump { axis: 1, .. }));
    assert!(out.act.velocity.iter().all(|v| *v == S::ZERO));
}

/// A reading of 4096 or more is not a count of a 12-bit encoder: it is
/// treated as a lost sample (ridden through, then a fault), never unwrapped.
fn counts_out_of_range_are_lost_samples<S: Scalar>() {
    let mut r = homed::<S>();
    let limit = PAROL6.encoder_invalid_limit;
    let mut out = None;
    for k in 0..=limit {
        let mut sense = r.plant.sense();
        sense.encoders[1] = kernel::EncoderSample::Count(4096);
        let o = r.tick_with(sense, None);
        let want = if k < limit { State::Operational } else { State::Fault };
        assert_eq!(o.status.state, want, "sample {k}");
        out = Some(o);
    }
    assert_eq!(out.unwrap().status.fault.unwrap().reason, FaultReason::EncoderLost { axis: 1 });
}

/// An encoder that never reads: Boot lasts exactly the boot timeout, then a
/// fault naming that encoder (kept by `fault()`).
fn boot_timeout_names_the_unready_encoder_on_time<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.plant.encoder[4] = EncoderFault::Lost;
    let n = kernel::config::ms_to_ticks(PAROL6.boot_timeout_ms, PAROL6.tick_hz);
    for t in 0..n {
        let out = r.tick(None);
        assert_eq!(out.status.state, State::Boot, "tick {t}");
    }
    let out = r.tick(None);
    assert_eq!(out.status.state, State::Fault);
    let want = FaultReason::EncoderNotReady { axis: 4 };
    assert_eq!(out.status.fault.unwrap().reason, want);
    assert_eq!(r.k.fault().map(|f| f.reason), Some(want));
}

/// An arm that faulted in Boot with an encoder never read leaves Fault only
/// with every encoder reading: `<ENABLE>` while J5 is still missing is
/// refused with it as the cause present (`EncoderLost`); once it reads, the
/// enable is accepted (Unhomed), J5's estimate starts at rest at its
/// reading, and a full homing run completes (every axis followed). This is
/// the one way into a moving mode other than `Ready` (which needs every
/// encoder read): every axis that runs the following-error check has been
/// read. Catches: `present_cause` without its encoder check (the enable is
/// accepted with J5 never read).
fn after_a_boot_timeout_enable_waits_for_the_missing_encoder<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.plant.encoder[4] = EncoderFault::Lost;
    let out = r.run_until(1_000, |o| o.status.state != State::Boot).expect("boot times out");
    assert_eq!(r.k.fault().map(|f| f.reason), Some(FaultReason::EncoderNotReady { axis: 4 }), "after {out} ticks");
    for _ in 0..3 {
        r.run(10);
        let out = r.enable();
        let reason = Reject::CauseActive(FaultReason::EncoderLost { axis: 4 });
        assert!(
            out.events.iter().any(|e| *e == Event::Rejected { request: RequestKind::Enable, reason }),
            "{:?}",
            out.events
        );
        assert_eq!(out.status.state, State::Fault);
    }
    r.plant.encoder[4] = EncoderFault::None;
    let out = r.enable();
    assert_eq!(out.status.state, State::Unhomed, "{:?}", out.events);
    assert_eq!(out.status.velocity[4], S::ZERO);
    let c = f64::from(r.plant.counts(4));
    let want = c * PAROL6.joints[4].rad_per_count();
    let got = f64::from(out.status.position[4].to_f32());
    assert!((got - want).abs() <= 2.0 * PAROL6.joints[4].rad_per_count() + 1e-5, "J5 at {got}, reading {want}");
    r.tick(Some(kernel::Request::Home));
    r.run_until(60_000, |o| o.status.state != State::Homing).expect("homing finishes");
    assert_eq!(r.k.state(), State::Operational, "{:?}", r.events);
}

/// A `<HOME>` received in Boot is queued (homing "in progress"); when the
/// boot timeout faults instead, the queued run is dropped with the fault:
/// homing reports Failed, no joint is homed, and after the encoder returns
/// `<ENABLE>` leads to Unhomed, where nothing starts homing by itself.
fn a_home_queued_in_boot_fails_at_the_boot_timeout<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.plant.encoder[2] = EncoderFault::Lost;
    let out = r.tick(Some(kernel::Request::Home));
    assert_eq!(out.status.state, State::Boot);
    assert_eq!(out.status.homing, HomingStatus::InProgress, "queued: {:?}", out.events);
    let out = r.run_until(1_000, |o| o.status.state != State::Boot).expect("boot times out");
    assert_eq!(r.k.fault().map(|f| f.reason), Some(FaultReason::EncoderNotReady { axis: 2 }), "after {out} ticks");
    let out = r.tick(None);
    assert_eq!(out.status.state, State::Fault);
    assert_eq!(out.status.homing, HomingStatus::Failed, "the queued run is dropped with the fault");
    assert_eq!(r.k.homed(), 0);
    r.plant.encoder[2] = EncoderFault::None;
    let out = r.enable();
    assert_eq!(out.status.state, State::Unhomed, "{:?}", out.events);
    let out = r.run_until(200, |o| o.status.state != State::Unhomed);
    assert_eq!(out, None, "no homing starts without a new <HOME>: {:?}", r.events);
    assert_eq!(r.k.homing_status(), HomingStatus::Failed);
}

/// The estimate's plausibility bounds (`POSITION_ABS_MAX`, 32 rad): an
/// unhomed J6 turned by an outside force (below its runaway speed) for
/// turn after turn has an estimate that eventually leaves them; that is a
/// `Numeric` fault on the tick it does, not a number that keeps growing
/// toward the fixed-point range (128 rad). Catches: each `&&`
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

fn hardware_overrun_faults<S: Scalar>() {
    let mut r = homed::<S>();
    let mut sense = r.plant.sense();
    sense.hardware_fault = Some(kernel::HardwareFault::TickOverrun);
    let out = r.tick_with(sense, None);
    assert_eq!(out.status.fault.unwrap().reason, FaultReason::Hardware(kernel::HardwareFault::TickOverrun));
    assert!(out.act.velocity.iter().all(|v| *v == S::ZERO));
}

/// A hardware fault faults at once and, while the sensors still report it,
/// `<ENABLE>` is refused with it as the cause present (PROTOCOL.md 6.5,
/// CAUSE_ACTIVE; SR-6, SR-21): the fault stays latched with its first
/// reason and the outputs at zero; once it is gone, the enable is accepted.
/// Every hardware fault kind. The tick starts from the sensed hardware fault
/// (`Kernel::tick_into`), so the enable sees it as a cause detected in its
/// own tick; `present_cause` checks the sensors again. Catches: an enable
/// that checks neither (each one alone is enough to refuse it).
fn enable_is_refused_while_a_hardware_fault_persists<S: Scalar>() {
    use kernel::{DriverCause, HardwareFault};
    let kinds = [
        HardwareFault::TickOverrun,
        HardwareFault::Driver { axis: 2 },
        HardwareFault::SelfTest(7),
        HardwareFault::DriverDiagnostic { axis: 4, cause: DriverCause::Overtemperature },
    ];
    for h in kinds {
        let mut r = homed::<S>();
        r.plant.hardware_fault = Some(h);
        let out = r.tick(None);
        assert_eq!(out.status.fault.map(|f| f.reason), Some(FaultReason::Hardware(h)));
        for _ in 0..3 {
            r.run(10);
            let out = r.enable();
            let reason = Reject::CauseActive(FaultReason::Hardware(h));
            assert!(
                out.events.iter().any(|e| *e == Event::Rejected { request: RequestKind::Enable, reason }),
                "{h:?}: {:?}",
                out.events
            );
            assert_eq!(out.status.state, State::Fault, "{h:?}");
            assert_eq!(out.status.fault.map(|f| f.reason), Some(FaultReason::Hardware(h)), "{h:?}");
            assert!(out.act.velocity.iter().all(|v| *v == S::ZERO), "{h:?}");
        }
        r.plant.hardware_fault = None;
        r.run(10);
        let out = r.enable();
        assert_eq!(out.status.state, State::Operational, "{h:?}: {:?}", out.events);
    }
}

fn fault_keeps_its_first_reason<S: Scalar>() {
    let mut r = homed::<S>();
    r.plant.force_switch = 0b1;
    r.tick(None);
    r.plant.encoder[5] = EncoderFault::Lost;
    r.plant.force_switch = 0b11_1111;
    let out = r.run(10);
    assert_eq!(out.status.fault.unwrap().reason, FaultReason::LimitSwitch { axis: 0 });
    let faults = r.events.iter().filter(|e| matches!(e, Event::Fault(_))).count();
    assert_eq!(faults, 1);
}
