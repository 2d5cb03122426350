//! The command timeout and `<ENABLE>`: no timeout between homing and the
//! first command, a timeout soft-stops monotonically and latches, enable
//! resynchronises without a jump and is refused while a cause is present
//! (a fault detected in the same tick, a joint faster than its limit, a
//! stop still ramping), and a lost encoder does not block it forever
//! (SAFETY.md SR-6, SR-7, SR-8; docs/PROTOCOL.md 6.4, 6.5). Both numeric
//! variants, every tick checked by the safety monitor (the common rig).
#![allow(clippy::needless_range_loop)] // six axes: indices read best

mod common;

use common::{both, homed, EncoderFault, Rig, START};
use kernel::config::{AXES, PAROL6};
use kernel::{Event, FaultReason, HomingStatus, Reject, RequestKind, Scalar, State};

both!(
    no_timeout_between_homing_and_first_command,
    command_timeout_soft_stops_monotonically_and_latches,
    enable_after_soft_stop_resyncs_without_a_jump,
    enable_is_refused_when_a_fault_is_detected_in_the_same_tick,
    enable_is_refused_while_an_axis_moves_faster_than_its_limit,
    enable_while_stopping_is_refused_as_stopping,
    encoder_lost_while_fast_does_not_block_enable_forever,
);

/// The ROS 2 driver streams only after it sees H2; the timeout is armed by
/// the first accepted motion command, so a long pause before it is safe.
fn no_timeout_between_homing_and_first_command<S: Scalar>() {
    let mut r = homed::<S>();
    let out = r.run(5_000);
    assert_eq!(out.status.state, State::Operational);
    assert!(!out.status.timeout_armed);
    let out = r.motion(r.plant.q);
    assert!(out.status.timeout_armed);
}

fn command_timeout_soft_stops_monotonically_and_latches<S: Scalar>() {
    let mut r = homed::<S>();
    // Stream a fast move on every axis, then stop sending.
    let mut p = r.plant.q;
    for _ in 0..50 {
        for (i, x) in p.iter_mut().enumerate() {
            let dir = if PAROL6.joints[i].homing.direction.sign() > 0.0 { -1.0 } else { 1.0 };
            *x += dir * 0.02;
        }
        r.motion(p);
        r.run(9);
    }
    // A last sample 0.25 rad further (inside the stream-continuity bound):
    // the set-points are still on their way when the timeout expires, so
    // the motion is interrupted (a stream ending at rest holds instead).
    for (i, x) in p.iter_mut().enumerate() {
        let dir = if PAROL6.joints[i].homing.direction.sign() > 0.0 { -1.0 } else { 1.0 };
        *x += dir * 0.25;
    }
    r.stream_to(p);
    let moving = r.last.unwrap().act.velocity;
    assert!(moving.iter().all(|v| v.abs().to_f32() > 0.5), "{moving:?}");
    // Silence: 100 ms of timeout, then the ramp.
    let mut prev = moving;
    let mut ticks_to_stop = None;
    let mut started = None;
    for t in 1..=400u32 {
        let out = r.tick(None);
        if out.status.state == State::Stopping && started.is_none() {
            started = Some(t);
        }
        if started.is_some() {
            for i in 0..AXES {
                let (a, b) = (out.act.velocity[i], prev[i]);
                assert!(a.abs() <= b.abs(), "axis {i}: speed increased {b:?} -> {a:?}");
                assert!(a == S::ZERO || (a > S::ZERO) == (b > S::ZERO), "axis {i} reversed");
                let dv = (b.to_f32() - a.to_f32()).abs();
                let bound = PAROL6.joints[i].max_velocity / 100.0 * 1.01;
                assert!(dv <= bound, "axis {i}: decel {dv} per tick above {bound}");
            }
        }
        if out.act.velocity.iter().all(|v| *v == S::ZERO) && ticks_to_stop.is_none() {
            ticks_to_stop = Some(t);
        }
        prev = out.act.velocity;
    }
    // The last command was in the tick before this loop began.
    let started = started.expect("soft stop started");
    assert!((100..=102).contains(&started), "timeout {started} ticks after the last command");
    let stop = ticks_to_stop.unwrap();
    assert!(stop <= 200, "standstill {stop} ms after the last command (budget 200)");
    assert_eq!(r.k.state(), State::SoftEstop);
    assert!(r.events.iter().any(|e| matches!(e, Event::SoftEstop { .. })));
    assert!(r.events.contains(&Event::Stopped));
    // Latched: motion is refused until enable.
    let out = r.motion(r.plant.q);
    assert!(out.events.iter().any(|e| *e == Event::Rejected { request: RequestKind::Motion, reason: Reject::Latched }));
}

fn enable_after_soft_stop_resyncs_without_a_jump<S: Scalar>() {
    let mut r = homed::<S>();
    let mut p = r.plant.q;
    // Far enough that the set-point still travels at the timeout (a
    // set-point at rest on its target holds: SR-29).
    p[0] += 0.3;
    r.stream_to(p);
    r.run_until(1000, |o| o.status.state == State::SoftEstop).unwrap();
    let out = r.enable();
    assert!(out.events.iter().any(|e| *e == Event::Enabled(State::Operational)));
    assert_eq!(out.status.homing, HomingStatus::Complete, "still homed: H2");
    // Set-points equal the estimates: the control output is ~zero.
    for i in 0..AXES {
        assert!((out.status.setpoint[i].to_f32() - out.status.position[i].to_f32()).abs() < 1e-3);
        assert!(out.act.velocity[i].abs().to_f32() < 0.01, "axis {i} lurched: {:?}", out.act.velocity[i]);
    }
    assert!(!out.status.timeout_armed);
    // Enable again: nothing to clear.
    let out = r.enable();
    assert!(out.events.iter().any(|e| matches!(e, Event::Rejected { reason: Reject::NothingToClear, .. })));
}

/// Found by the model check: a fault detected while sensing in the same tick
/// as an enable must block that enable.
fn enable_is_refused_when_a_fault_is_detected_in_the_same_tick<S: Scalar>() {
    let mut r = homed::<S>();
    r.plant.force_switch = 0b1;
    assert_eq!(r.tick(None).status.state, State::Fault);
    r.plant.force_switch = 0;
    // Encoder J1 jumps persistently: detected while sensing in the enable tick.
    r.plant.glitch[0] = 1500;
    r.run(PAROL6.encoder_invalid_limit);
    let out = r.enable();
    assert_eq!(out.status.state, State::Fault);
    assert!(out.events.iter().any(|e| matches!(e, Event::Rejected { reason: Reject::CauseActive(_), .. })));
    assert!(!out.events.iter().any(|e| matches!(e, Event::Enabled(_))));
}

/// Enable is refused while an axis moves faster than its velocity limit
/// (here pushed at 1.05 vmax, below the runaway threshold), and accepted
/// once it has stopped.
fn enable_is_refused_while_an_axis_moves_faster_than_its_limit<S: Scalar>() {
    let mut r = homed::<S>();
    r.plant.force_switch = 0b1;
    assert_eq!(r.tick(None).status.state, State::Fault);
    r.plant.force_switch = 0;
    let vmax = f64::from(PAROL6.joints[3].max_velocity);
    r.plant.disturbance[3] = 1.05 * vmax;
    r.run(100);
    let out = r.enable();
    assert!(
        out.events.iter().any(|e| *e
            == Event::Rejected {
                request: RequestKind::Enable,
                reason: Reject::CauseActive(FaultReason::Runaway { axis: 3 })
            }),
        "{:?}",
        out.events
    );
    r.plant.disturbance[3] = 0.0;
    r.run(300);
    assert_eq!(r.enable().status.state, State::Operational);
}

/// During the soft-stop ramp enable is refused with its own reason.
fn enable_while_stopping_is_refused_as_stopping<S: Scalar>() {
    let mut r = homed::<S>();
    let mut p = r.plant.q;
    p[0] += 0.2; // still on its way when the timeout expires
    r.stream_to(p);
    r.run_until(200, |o| o.status.state == State::Stopping).expect("timeout");
    let out = r.enable();
    assert!(
        out.events.iter().any(|e| *e == Event::Rejected { request: RequestKind::Enable, reason: Reject::Stopping }),
        "{:?}",
        out.events
    );
}

/// An encoder lost while its joint moves near its velocity limit freezes
/// the estimate there; were the enable check to read the frozen velocity
/// as a runaway, the arm could never be enabled again. A lost count is
/// re-initialised from its reading at enable (velocity 0): only the
/// reading's presence is a cause (the f32/fixed-point differential
/// property test exercises this case).
fn encoder_lost_while_fast_does_not_block_enable_forever<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.run(3);
    assert_eq!(r.k.state(), State::Unhomed);
    let j = 3;
    let vmax = f64::from(PAROL6.joints[j].max_velocity);
    // Something drives J4 at 1.05 vmax with the outputs at zero: above the
    // enable threshold, below the runaway fault threshold, so no fault yet.
    r.plant.disturbance[j] = 1.05 * vmax;
    let out = r.run(100);
    assert_eq!(out.status.state, State::Unhomed);
    assert!(f64::from(out.status.velocity[j].to_f32()) > vmax, "estimate follows the outside force");
    // Its encoder is lost for longer than the kernel rides through.
    r.plant.encoder[j] = EncoderFault::Lost;
    let out = r.run(PAROL6.encoder_invalid_limit + 1);
    assert_eq!(out.status.fault.unwrap().reason, FaultReason::EncoderLost { axis: j as u8 });
    // The arm stops and the encoder comes back.
    r.plant.disturbance[j] = 0.0;
    r.plant.encoder[j] = EncoderFault::None;
    r.run(50);
    let out = r.enable();
    assert_eq!(out.status.state, State::Unhomed, "events: {:?}", out.events);
    assert_eq!(out.status.velocity[j], S::ZERO);
}
