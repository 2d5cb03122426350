//! Deterministic replays of failing cases the property tests can draw
//! (each a shrunk case of `kernel_state_machine.rs`, or the same situation
//! built by hand), every tick checked by the safety monitor. Each bullet
//! names what a kernel without the rule does in that case.
//!
//! * `no_following_error_on_a_clean_plant_*`: streams that reverse a joint
//!   must not trip `FOLLOWING_ERROR` with nothing injected (SR-28: a stalled,
//!   reversed or step-losing motor is the only cause). The set-point
//!   reverses at the full `max_acceleration` and the output is limited to
//!   the same acceleration, so the control law has no authority left to
//!   correct the lag; the estimate's velocity lags the joint's, so "more
//!   than half the bound behind while moving away" holds for 20 ms.
//! * `no_following_error_after_an_enable_that_follows_a_stop_at_speed`:
//!   the enable resynchronises the set-points to estimates still moving
//!   after an abrupt stop; they drift apart and FOLLOWING_ERROR trips.
//! * `setpoint_acceleration_within_its_bound_fx`: a set-point velocity
//!   change of 0.0622 rad/s in a tick (bound 0.0612).
//! * `a_target_inside_the_braking_distance_is_treated_alike_both_ways`: a
//!   stream sample just ahead of a fast set-point (closer than its braking
//!   distance). Approached upward the set-point stops dead on it (a
//!   velocity step of about 1.7 rad/s in one tick, while the feed-forward
//!   keeps the profile's velocity and decays by `dv` per tick); approached
//!   downward it reaches it and then passes it by about `v^2 / 2a` (the
//!   remaining distance is zero and a zero distance is taken as "positive").
//!   Either behaviour breaks one of SR-27's two rules (acceleration, never
//!   past the target); the two directions must at least agree.

use kernel::config::PAROL6;
use kernel::{Fx, MotionKind, MotionTarget, Request, State};
use proptests::scenario::{run_step, Bad, Pair, Start, Step, Sut, Variant};

fn replay<S: Variant>(steps: &[Step]) {
    let mut s = Sut::<S>::new(&Start::Homed);
    for st in steps {
        run_step(&mut s, st);
    }
}

fn reversal() -> Vec<Step> {
    let z = [0.0; 6];
    vec![
        Step::Stream {
            goal: [0.0, 0.0, 0.0, 0.0, 0.624_223_661_739_445_2, 0.583_460_362_199_310_5],
            vel: z,
            period: 8,
            count: 9,
        },
        Step::Stream { goal: [0.0, 0.0, 0.0, 0.0, 1.0, 0.0], vel: z, period: 8, count: 2 },
    ]
}

#[test]
fn no_following_error_on_a_clean_plant_f32() {
    replay::<f32>(&reversal());
}

#[test]
fn no_following_error_on_a_clean_plant_fx() {
    replay::<Fx>(&reversal());
}

/// A fast stream toward the lower limits, then a limit switch (a fault:
/// the outputs drop to zero at once), an enable right after the switch is
/// released, and silence. The enable resynchronises the set-points to the
/// estimates while the estimates still move (the observer's velocity
/// decays after the abrupt stop), so the estimates drift from the
/// set-points and `FOLLOWING_ERROR` trips with nothing injected since the
/// resynchronisation (f32, J3; shrunk from the state machine).
#[test]
fn no_following_error_after_an_enable_that_follows_a_stop_at_speed() {
    let z = [0.0; 6];
    replay::<f32>(&[
        Step::Stream { goal: z, vel: z, period: 8, count: 3 },
        Step::LimitHit { mask: 1, ticks: 7 },
        Step::Enable(0),
        Step::Silence(90),
    ]);
}

/// Go-tos and streams in turn (shrunk from the differential run, whose
/// samples follow the arm the f32 kernel drives): the fixed-point set-point
/// of J5 changes its velocity by 0.0622 rad/s in one tick, above
/// `max_acceleration / tick_hz` (0.06) plus the landing allowance and
/// rounding (0.0612): SR-27. (The profile depends on the targets only; the
/// pair is needed to reproduce these targets.)
#[test]
fn setpoint_acceleration_within_its_bound_fx() {
    let z = [0.0; 6];
    let mut pair = Pair::new(&Start::Homed, 0.05, 1e-3);
    for st in &[
        Step::Stream { goal: [0.0, 0.0, 0.0, 0.0, 0.840_646_885_082_405_4, 0.0], vel: z, period: 8, count: 3 },
        Step::GoTo {
            goal: [0.342_021_178_259_337_2, 0.0, 0.0, 0.998_820_097_286_460_6, 0.642_916_711_977_528_1, 0.0],
            wait: 306,
        },
        Step::GoTo { goal: z, wait: 26 },
        Step::Stream {
            goal: [0.0, 0.0, 0.0, 0.818_473_697_858_016_7, 0.0, 0.480_933_292_197_845_2],
            vel: z,
            period: 24,
            count: 8,
        },
        Step::Silence(43),
        Step::BadMotion { axis: 0, bad: Bad::OutOfLimits(0.001), idle: 5 },
        Step::GoTo { goal: [0.0, 0.0, 0.0, 0.0, 0.749_324_751_295_564_6, 0.0], wait: 19 },
        Step::Stream { goal: z, vel: z, period: 16, count: 14 },
    ] {
        run_step(&mut pair, st);
    }
}

/// J1 streamed at 2.5 rad/s (a sample every 10 ms), then a sample 10 mrad
/// ahead of its set-point (its braking distance is about 0.1 rad): the
/// largest set-point velocity change per tick, how far the set-point went
/// past the close sample (rad, positive = past), and the fault, if any.
/// The kernel and the plant only (the monitor would stop at the fault).
fn brake_inside(dir: f64) -> (f64, f64, Option<kernel::Fault>) {
    let snap = Sut::<f32>::new(&Start::Homed);
    let (mut k, _) = snap.k.fork();
    let mut plant = snap.plant.clone();
    let mut tick = |k: &mut kernel::KernelF32, p: Option<([f64; 6], MotionKind)>| {
        let req = p
            .map(|(p, kind)| Request::Motion(MotionTarget { position: p.map(|x| x as f32), velocity: [0.0; 6], kind }));
        let o = k.tick(&plant.sense(), req);
        plant.apply(&o.act.step_rate);
        o
    };
    // J1 to mid-range first (a go-to), then the stream.
    let mut q = [0.0; 6];
    let o = tick(&mut k, None);
    for (qi, x) in q.iter_mut().zip(o.status.position.iter()) {
        *qi = f64::from(*x);
    }
    q[0] = 0.0;
    tick(&mut k, Some((q, MotionKind::GoTo)));
    for _ in 0..3000 {
        tick(&mut k, None);
    }
    let mut p = q;
    let mut sp = 0.0f64;
    for n in 1..=20 {
        p[0] = q[0] + dir * 0.025 * f64::from(n);
        tick(&mut k, Some((p, MotionKind::Stream)));
        for _ in 0..9 {
            sp = f64::from(tick(&mut k, None).status.setpoint[0]);
        }
    }
    assert_eq!(k.state(), State::Operational);
    let close = sp + dir * 0.01;
    p[0] = close;
    let hz = f64::from(PAROL6.tick_hz);
    let (mut prev, mut prev_v, mut worst, mut past) = (sp, f64::NAN, 0.0f64, f64::MIN);
    let mut o = tick(&mut k, Some((p, MotionKind::Stream)));
    for _ in 0..200 {
        if o.status.state != State::Operational {
            break;
        }
        let x = f64::from(o.status.setpoint[0]);
        let v = (x - prev) * hz;
        if prev_v.is_finite() {
            worst = worst.max((v - prev_v).abs());
        }
        past = past.max((x - close) * dir);
        prev = x;
        prev_v = v;
        o = tick(&mut k, None);
    }
    (worst, past, k.fault())
}

#[test]
fn a_target_inside_the_braking_distance_is_treated_alike_both_ways() {
    let (up_dv, up_past, up_fault) = brake_inside(1.0);
    let (down_dv, down_past, down_fault) = brake_inside(-1.0);
    let dv = f64::from(PAROL6.joints[0].max_acceleration) / f64::from(PAROL6.tick_hz);
    let msg = format!(
        "target 10 mrad ahead at 2.5 rad/s (J1, dv {dv} rad/s per tick): upward: largest set-point velocity change \
         {up_dv:.3} rad/s per tick, {up_past:.4} rad past, fault {up_fault:?}; downward: {down_dv:.3} rad/s per tick, \
         {down_past:.4} rad past, fault {down_fault:?}"
    );
    println!("{msg}");
    let same = |a: f64, b: f64, tol: f64| (a - b).abs() <= tol;
    assert!(same(up_dv, down_dv, 0.2 * dv) && same(up_past, down_past, 1e-3), "asymmetric: {msg}");
    assert!(up_fault.is_none() && down_fault.is_none(), "a fault on a clean plant: {msg}");
}
