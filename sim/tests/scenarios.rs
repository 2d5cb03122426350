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
}

#[test]
fn every_builtin_scenario_parses_and_its_file_loads() {
    let all = builtin().unwrap();
    assert_eq!(all.len(), 10);
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
fn configurator_jog_at_25_hz() {
    let r = run_builtin("configurator-jog-25hz");
    assert_passes(&r);
}

#[test]
fn cable_pull_soft_stops_within_200_ms_and_recovers_after_enable() {
    let r = run_builtin("cable-pull");
    assert_passes(&r);
    let (_, first) = r.stops[0];
    assert!(first.unwrap() <= 200, "{:?}", r.stops);
    assert!(r.trace.iter().any(|s| s.state == State::SoftEstop));
    assert_eq!(r.trace.last().unwrap().state, State::SoftEstop, "the stream ended: the watchdog stops again");
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
