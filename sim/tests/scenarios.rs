//! Every built-in scenario, run in simulated time through the kernel and
//! protocol crates, with its report checked.

use kernel::config::{AXES, PAROL6, PAROL6_VALIDATED};
use kernel::State;
use sim::plant::PlantOptions;
use sim::report::Report;
use sim::root::Root;
use sim::runner::{run, RunOptions, TickChecker};
use sim::scenario::{builtin, Scenario};

fn run_builtin(name: &str) -> Report {
    let sc = builtin().unwrap().into_iter().find(|s| s.name == name).unwrap_or_else(|| panic!("no scenario {name}"));
    let r = run(&PAROL6_VALIDATED, &sc, &RunOptions::default(), &mut |_| {});
    println!("{}", r.text());
    r
}

fn assert_passes(r: &Report) {
    assert!(r.safe(), "{}: safety violated: {:?}", r.name, r.violations);
    for (e, ok, d) in &r.expectations {
        assert!(*ok, "{}: expectation `{e}` failed: {d}", r.name);
    }
    // The output's acceleration stays within each joint's limit in every
    // state (fault ticks and homing's switch stops excepted), homing included.
    for (i, (a, j)) in r.max_accel.iter().zip(PAROL6.joints.iter()).enumerate() {
        assert!(*a <= f64::from(j.max_acceleration) * 1.01, "{}: J{} accelerated at {a} rad/s^2", r.name, i + 1);
    }
}

fn first_fault(r: &Report) -> (u64, String) {
    r.faults.first().cloned().unwrap_or_else(|| panic!("{}: no fault", r.name))
}

#[test]
fn every_builtin_scenario_parses_and_its_file_loads() {
    let all = builtin().unwrap();
    assert_eq!(all.len(), sim::scenario::BUILTIN.len());
    for s in &all {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios").join(format!("{}.scn", s.name));
        let f = Scenario::from_file(&path).unwrap();
        assert_eq!(&f, s);
        assert!(!s.expects.is_empty(), "{} has no expectations", s.name);
    }
}

#[test]
fn startup_and_homing() {
    let r = run_builtin("startup-homing");
    assert_passes(&r);
    // Nothing moved before <HOME> at 2 s.
    let moved_early = r.trace.iter().take_while(|s| s.t < 2000).any(|s| !s.still);
    assert!(!moved_early);
    let h = r.homed_at.unwrap();
    assert!(h < 85_000, "homing took {h} ms");
}

#[test]
fn driver_trajectory_at_100_hz() {
    let r = run_builtin("driver-trajectory-100hz");
    assert_passes(&r);
    println!("tracking at a 100 Hz command rate (C++ acceptance figure: under 8 mrad):");
    for (i, (e, f)) in r.tracking.iter().zip(r.tracking_ref.iter()).enumerate() {
        println!(
            "  J{}: set-point vs true RMS {:.3} max {:.3} mrad; host reference vs true RMS {:.3} max {:.3} mrad",
            i + 1,
            e.rms_mrad(),
            e.max_mrad(),
            f.rms_mrad(),
            f.max_mrad()
        );
    }
    assert!(r.goal_error.unwrap() < 0.05);
    assert!(r.faults.is_empty());
    assert_eq!(r.rejected_total, 0, "{:?} {:?}", r.wire, r.refusals);
    assert!(r.commands_accepted >= 790, "{} commands accepted", r.commands_accepted);
}

#[test]
fn driver_stream_cut_holds_at_rest_and_latches_while_moving() {
    let r = run_builtin("driver-stream-cut");
    assert_passes(&r);
    assert!(r.trace.iter().any(|s| s.state == State::SoftEstop));
    assert_eq!(r.trace.last().unwrap().state, State::Operational);
}

#[test]
fn configurator_jog_at_25_hz_holds_between_jogs() {
    let r = run_builtin("configurator-jog-25hz");
    assert_passes(&r);
    assert!(r.trace.iter().all(|s| s.state != State::SoftEstop), "a jog's end latched");
}

#[test]
fn jog_release_jog_needs_no_enable() {
    let r = run_builtin("jog-release-jog");
    assert_passes(&r);
    assert!(r.trace.iter().all(|s| s.state != State::SoftEstop && s.state != State::Stopping));
    assert!(r.refusals.is_empty(), "{:?}", r.refusals);
}

#[test]
fn configurator_goto_completes_and_holds() {
    let r = run_builtin("configurator-goto");
    assert_passes(&r);
    let g = r.goal_error.unwrap();
    println!("go-to goal error {g:.4} rad");
    assert!(g < 0.01);
    let (_, tg) = *r.targets.last().unwrap();
    let end = r.trace.last().unwrap();
    for (i, (q, t)) in end.q.iter().zip(tg.iter()).enumerate() {
        assert!((q - t).abs() < 0.01, "J{} at {q} at the end, target {t}", i + 1);
    }
}

#[test]
fn cable_pull_soft_stops_at_once_and_recovers_after_enable() {
    let r = run_builtin("cable-pull");
    assert_passes(&r);
    // The link loss is seen in the tick of the pull: Stopping at once, still
    // 100 ms later (the ramp), latched.
    let (_, first) = r.stops[0];
    assert!(first.unwrap() <= 120, "{:?}", r.stops);
    assert!(r.trace.iter().any(|s| s.state == State::SoftEstop));
    assert_eq!(r.trace.last().unwrap().state, State::Operational, "the last stream ends at rest: it holds");
}

#[test]
fn cable_pull_mid_goto_stops_at_once() {
    let r = run_builtin("cable-pull-goto");
    assert_passes(&r);
    let h = r.homed_at.unwrap();
    let pull = h + 700;
    let at = |t: u64| r.trace.iter().find(|s| s.t == t).unwrap();
    assert_eq!(at(pull - 1).state, State::Operational);
    assert!(!at(pull - 1).still, "the go-to was under way at the pull");
    assert_eq!(at(pull).state, State::Stopping, "stopping in the tick of the pull");
    assert!(r.goal_error.is_none_or(|g| g > 0.5), "the go-to was cut short: {:?}", r.goal_error);
}

#[test]
fn home_mid_stream_stops_first_then_homes() {
    let r = run_builtin("home-mid-stream");
    assert_passes(&r);
    let h = r.homed_at.unwrap();
    // Between the <HOME> and the end of the stop every joint decelerates:
    // speeds never grow.
    let win: Vec<_> = r.trace.iter().filter(|s| s.t >= h + 800 && s.state == State::Stopping).collect();
    assert!(win.len() >= 99, "{} ticks of Stopping", win.len());
    for w in win.windows(2) {
        for i in 0..AXES {
            assert!(w[1].v[i].abs() <= w[0].v[i].abs() + 1e-6, "J{} sped up at {} ms", i + 1, w[1].t);
        }
    }
}

#[test]
fn stale_h2_reactivation_moves_nothing() {
    let r = run_builtin("stale-h2-reactivation");
    assert_passes(&r);
    let jumps: u64 = r.refusals.iter().filter(|(k, _)| k.contains("TargetJump")).map(|(_, n)| n).sum();
    assert!(jumps > 100, "{:?}", r.refusals);
}

#[test]
fn inverted_dir_faults_following_error() {
    let r = run_builtin("inverted-dir");
    assert_passes(&r);
    let (tf, f) = first_fault(&r);
    println!("inverted DIR: {f} at {} ms after the stream's first frame", tf - (r.homed_at.unwrap() + 500));
    assert!(f.contains("following error J1"), "{f}");
}

#[test]
fn dead_homing_switch_faults_within_the_travel_bound() {
    let r = run_builtin("dead-homing-switch");
    assert_passes(&r);
    let (tf, f) = first_fault(&r);
    assert!(f.contains("homing travel J1"), "{f}");
    let q0 = f64::from(r.trace[0].q[0]);
    let travel = r.trace.iter().map(|s| (f64::from(s.q[0]) - q0).abs()).fold(0.0, f64::max);
    let bound = f64::from(PAROL6.joints[0].homing.max_travel);
    println!("dead switch: {f} at {tf} ms after {travel:.3} rad of J1 travel (bound {bound:.3})");
    assert!(travel <= bound + 0.01, "J1 travelled {travel} rad, bound {bound}");
    assert_eq!(r.homed_at, None);
}

#[test]
fn limit_hit_faults_and_enable_waits_for_release() {
    let r = run_builtin("limit-hit");
    assert_passes(&r);
    assert_eq!(r.faults.len(), 1, "{:?}", r.faults);
}

#[test]
fn encoder_glitch_faults_and_rehoming_recovers() {
    assert_passes(&run_builtin("encoder-glitch"));
}

#[test]
fn encoder_loss_faults_and_rehoming_recovers() {
    assert_passes(&run_builtin("encoder-loss"));
}

#[test]
fn garbage_is_rejected_and_reported_without_disturbing_motion() {
    let r = run_builtin("garbage");
    assert_passes(&r);
    assert!(r.wire.len() >= 12, "distinct rejection reasons: {:?}", r.wire);
}

#[test]
fn runaway_faults_every_axis_in_the_same_tick() {
    let r = run_builtin("runaway");
    assert_passes(&r);
    let (tf, _) = r.faults[0];
    let s = r.trace.iter().find(|s| s.t == tf).unwrap();
    assert!(s.still && s.v.iter().all(|v| *v == 0.0));
}

/// The Serial1 build's main loop (configurator line at 10 Hz) serves the
/// same scenario safely, and both clients still get their lines.
#[test]
fn serial1_host_runs_the_stream_scenario() {
    let sc = builtin().unwrap().into_iter().find(|s| s.name == "driver-trajectory-100hz").unwrap();
    let r = run(&PAROL6_VALIDATED, &sc, &RunOptions { serial1: true }, &mut |_| {});
    assert!(r.decode.contains("Serial1"), "{}", r.decode);
    assert_passes(&r);
}

/// The per-tick checker (the safety monitor plus the wire checks) is not
/// vacuous: it flags a moving output in UNHOMED, a NaN output and a `nan`
/// on the wire.
#[test]
fn safety_checker_flags_violations() {
    let mut root = Root::new(&PAROL6_VALIDATED, PlantOptions::new(&PAROL6), firmware::root::HostConfig::USB);
    let mut checker = TickChecker::new(&PAROL6_VALIDATED);
    let mut step = root.step(b"");
    assert!(checker.check(&step).is_empty());
    for _ in 0..10 {
        step = root.step(b"");
        assert!(checker.check(&step).is_empty(), "{:?}", checker.check(&step));
    }
    assert_eq!(step.out.status.state, State::Unhomed);
    let mut bad = step.clone();
    bad.out.act.velocity[2] = 0.5;
    bad.out.act.step_rate[2] = 9000;
    let v = checker.clone().check(&bad);
    assert!(v.iter().any(|v| v.contains("UNHOMED") || v.contains("Unhomed")), "{v:?}");
    let mut bad = step.clone();
    bad.out.act.velocity[0] = f32::NAN;
    assert!(!checker.clone().check(&bad).is_empty());
    let mut bad = step;
    bad.lines.push("<ACK,1,nan>\n".into());
    assert!(checker.clone().check(&bad).iter().any(|v| v.contains("nan")));
    let _ = AXES;
}

#[test]
fn bad_scenario_files_name_the_line() {
    let dir = std::env::temp_dir().join(format!("sim-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("bad.scn");
    std::fs::write(&f, "description x\nat 100 send <HOME>\nat 200 stream driver 100 1s cosine 1s 1 2 3\n").unwrap();
    let e = format!("{:#}", Scenario::from_file(&f).unwrap_err());
    assert!(e.contains("bad.scn") && e.contains("line 3"), "{e}");
    let e = format!("{:#}", Scenario::from_file(&dir.join("missing.scn")).unwrap_err());
    assert!(e.contains("missing.scn"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn stream_resuming_after_silence_is_refused_while_far() {
    let r = run_builtin("stream-resumes-after-silence");
    assert_passes(&r);
    let jumps: u64 = r.refusals.iter().filter(|(k, _)| k.contains("TargetJump")).map(|(_, n)| n).sum();
    assert!(jumps > 10, "{:?}", r.refusals);
}

/// The wire checks accept every event line of the motion rules (formatted by the
/// protocol crate itself): none contains `nan`/`inf`, none starts with `<`.
#[test]
fn wire_checks_accept_the_new_lines() {
    use kernel::homing::Phase;
    use kernel::{Event, FaultReason, Reject, RequestKind, StopCause};
    let events = [
        Event::Holding,
        Event::HomingAfterStop,
        Event::SoftEstop { cause: StopCause::LinkLost },
        Event::SoftEstop { cause: StopCause::CommandTimeout { since_command_ms: 101 } },
        Event::Fault(FaultReason::FollowingError { axis: 0 }),
        Event::Fault(FaultReason::HomingTravel { axis: 5, phase: Phase::FastSeek }),
        Event::Fault(FaultReason::HomingTimeout { axis: 2, phase: Phase::Settle }),
        Event::Rejected { request: RequestKind::Motion, reason: Reject::TargetJump { axis: 3 } },
        Event::Rejected { request: RequestKind::Home, reason: Reject::Latched },
        Event::Rejected { request: RequestKind::HomeJoint(2), reason: Reject::Latched },
        Event::Rejected { request: RequestKind::Motion, reason: Reject::Internal },
    ];
    let mut lines = Vec::new();
    for e in &events {
        let mut l = protocol::Line::new();
        protocol::report::event_line(&mut l, e).unwrap();
        lines.push(format!("{l}\n"));
    }
    let mut root = Root::new(&PAROL6_VALIDATED, PlantOptions::new(&PAROL6), firmware::root::HostConfig::USB);
    let mut checker = TickChecker::new(&PAROL6_VALIDATED);
    for _ in 0..10 {
        assert!(checker.check(&root.step(b"")).is_empty());
    }
    let mut step = root.step(b"");
    step.lines.extend(lines.iter().cloned());
    assert!(checker.check(&step).is_empty(), "{lines:?}: {:?}", checker.check(&step));
    println!("{}", lines.concat());
}

/// A driver frame inside a full-speed go-to's stopping distance is refused
/// (accepted, J6's set-point would run 0.25 rad past it); the go-to ends
/// at its target.
#[test]
fn a_driver_frame_inside_a_go_to_s_stopping_distance_is_refused() {
    let r = run_builtin("goto-then-driver-frame");
    assert_passes(&r);
}

/// After `<ENABLE>` a resumed stream's first sample 0.22 rad (J1) and
/// 0.30 rad (J6) from the pose is refused; a stream from the pose moves.
#[test]
fn a_leap_from_rest_after_enable_is_refused() {
    let r = run_builtin("leap-after-enable");
    assert_passes(&r);
}
