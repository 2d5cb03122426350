//! The twin (the shipped Serial1 image on the peripheral models) against
//! the simulator (the same composition root built for the host, its own
//! plant) on the same scenario: the same event lines in the same order, at
//! the same times within [`EVENT_TOL_MS`] (per-command `REFUSED MOTION`
//! lines by count), the same anchors within that
//! tolerance, and the joint angles at the end within [`ANGLE_TOL_RAD`].
//!
//! Tolerances. Events: the simulator stamps a line when the root produces
//! it; the twin when its first byte leaves the UART at 115 200 baud,
//! behind at most one feedback line (~100 bytes, 8.7 ms) and a tick of
//! queueing, and its idle skipping can delay main-loop work by up to one
//! tick: 10 ms; a streamed command also reaches the image ~7 ms later than
//! the simulator's (a driver line on the 115 200 baud wire), which moves a
//! command timeout (SOFT_ESTOP) by as much: 20 ms. Homing amplifies one tick: a switch hit seen one tick
//! apart during the fast seek (the plants differ: encoder mounting
//! offsets, the simulator's sampling jitter) moves the slow seek's start by
//! `fast_speed x 1 ms` and its length by `fast / slow` ms: 40 ms for J6
//! (2.0 / 0.05 rad/s), 20 ms for J4/J5 (1.0 / 0.05), 10 ms for J1..J3
//! (0.5 / 0.05). The groups home one after the other, so a run can end up
//! to 40 + 20 + 10 = 70 ms apart, and everything timed from its end (a
//! stream started at homed + t, its HOLDING or SOFT_ESTOP) with it; plus
//! the 20 ms of the wire: 90 ms in all. (Measured with the issue-12 kernel,
//! whose homing ramps its speeds: up to 86 ms on the second homing of
//! `startup-homing`, 53-55 ms on the streams after homing; 42 ms before.)
//!
//! Angles: both plants step exactly, but the encoders' phases and the simulator's sampling jitter differ, so homing's
//! switch hits may differ by a tick at the slow seek speed (0.05 rad/s x
//! 1 ms = 0.05 mrad), and a step-rate quantisation of the last move; with
//! a stream, each command reaches the image ~7 ms later (the wire), so a
//! stop lands up to `v_max x 10 ms` further along: 6.3 mrad at
//! `cable-pull`'s 0.63 rad/s (J6): 8 mrad.

use sim::runner::{run as sim_run, RunOptions};
use sim::scenario::{Anchor, Scenario};

/// Event line time tolerance (ms), see the module docs.
const EVENT_TOL_MS: u64 = 90;
/// Final joint angle tolerance (rad), see the module docs.
const ANGLE_TOL_RAD: f64 = 0.008;

fn compare(file: &str) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(file);
    let sc = Scenario::from_file(&path).unwrap();
    let elf = twin::load_image().unwrap();
    let tw = twin::scenario::run(&sc, &elf).unwrap();
    assert!(tw.skipped.is_empty(), "scenario needs actions the twin lacks: {:?}", tw.skipped);
    let cfg = &kernel::config::PAROL6_VALIDATED;
    let rep = sim_run(cfg, &sc, &RunOptions { serial1: true }, &mut |_| {});
    // event lines: not feedback, not the boot banner and READY (the
    // simulator prints them at 0 ms, the image after its 30 ms encoder
    // self-test and boot: 30 and 38 ms)
    let keep =
        |l: &str| !l.starts_with('<') && !l.starts_with(' ') && !l.starts_with("BOOT") && l != "READY" && !l.is_empty();
    let sim_all: Vec<(u64, String)> =
        rep.lines.iter().map(|(t, l)| (*t, l.trim_end().to_owned())).filter(|(_, l)| keep(l)).collect();
    let tw_all: Vec<(u64, String)> = tw.events.iter().filter(|(_, l)| keep(l)).cloned().collect();
    // Per-command rejections (REFUSED MOTION, one per streamed line while
    // latched) depend on when each line's bytes arrive: compared by count
    // (within 5 or 5 %), every other event line one by one.
    let per_command = |l: &str| l.starts_with("REFUSED MOTION");
    let (sim_rm, tw_rm) =
        (sim_all.iter().filter(|(_, l)| per_command(l)).count(), tw_all.iter().filter(|(_, l)| per_command(l)).count());
    eprintln!("{file}: REFUSED MOTION lines: sim {sim_rm}, twin {tw_rm}");
    let sim_ev: Vec<(u64, String)> = sim_all.into_iter().filter(|(_, l)| !per_command(l)).collect();
    let tw_ev: Vec<(u64, String)> = tw_all.into_iter().filter(|(_, l)| !per_command(l)).collect();
    let mut worst = 0u64;
    let table: Vec<String> = sim_ev
        .iter()
        .zip(tw_ev.iter())
        .map(|((ts, ls), (tt, lt))| format!("sim {ts:>6} ms {ls:<45} twin {tt:>6} ms {lt}"))
        .collect();
    eprintln!("{file}:\n{}", table.join("\n"));
    assert!(sim_rm.abs_diff(tw_rm) <= 5.max(sim_rm / 20), "REFUSED MOTION lines: sim {sim_rm}, twin {tw_rm}");
    assert_eq!(sim_ev.len(), tw_ev.len(), "event counts differ\nsim {sim_ev:?}\ntwin {tw_ev:?}");
    for ((ts, ls), (tt, lt)) in sim_ev.iter().zip(tw_ev.iter()) {
        assert_eq!(ls, lt, "event text differs (sim at {ts} ms, twin at {tt} ms)");
        worst = worst.max(ts.abs_diff(*tt));
        assert!(ts.abs_diff(*tt) <= EVENT_TOL_MS, "{ls}: sim {ts} ms, twin {tt} ms");
    }
    // homed anchor (the simulator's is the kernel's homing-complete tick)
    if let (Some(h), Some(&th)) = (rep.homed_at, tw.anchors[Anchor::Homed.index()].first()) {
        eprintln!("homed: sim {h} ms, twin {th} ms");
        assert!(h.abs_diff(th) <= EVENT_TOL_MS, "homed: sim {h} ms, twin {th} ms");
    }
    // joint angles at the end
    let last = rep.trace.last().expect("simulator trace");
    let mut worst_q = 0.0f64;
    // A USB-only scenario (a pulled cable the firmware sees as a closed
    // port) runs here on Serial1, where the pull is only silence: in
    // `cable-pull` the driver's re-activation then re-homes the arm, and the
    // run ends while homing moves, so the end angles differ by the homing
    // time offset (above) times the homing speed. Its events are compared;
    // its end angles are not.
    if sc.usb_only {
        eprintln!("{file}: USB-only scenario: end angles not compared on Serial1");
        return;
    }
    for i in 0..6 {
        let d = (f64::from(last.q[i]) - tw.q[i]).abs();
        worst_q = worst_q.max(d);
        assert!(d < ANGLE_TOL_RAD, "J{}: sim {} rad, twin {} rad", i + 1, last.q[i], tw.q[i]);
    }
    eprintln!(
        "{file}: {} events, worst time difference {worst} ms, worst angle difference {:.2} mrad; twin {:.2} x real time",
        sim_ev.len(),
        worst_q * 1000.0,
        tw.end_ms as f64 / 1000.0 / tw.wall_s
    );
}

/// The simulator's own `startup-homing` scenario: 2 s of nothing at
/// power-on, `<HOME>` (all six joints from the simulator's start pose), a
/// second `<HOME>` once homed (about 20 s simulated).
#[test]
fn startup_homing_matches_the_simulator() {
    compare("../sim/scenarios/startup-homing.scn");
}

/// Homing from 0.1 rad before every switch: J6, then J5+J4, then J1+J2+J3.
#[test]
fn homing_matches_the_simulator() {
    compare("scenarios/homing-near-switches.scn");
}

/// A limit switch closing after homing: the fault, the refused and the
/// accepted `<ENABLE>`.
#[test]
fn limit_hit_matches_the_simulator() {
    compare("scenarios/limit-hit-at-rest.scn");
}

/// The simulator's `limit-hit`: J2's switch closes during a 100 Hz driver
/// trajectory: the fault, `<ENABLE>` refused while pressed, accepted after
/// release.
#[test]
fn limit_hit_during_a_100hz_stream_matches_the_simulator() {
    compare("../sim/scenarios/limit-hit.scn");
}

/// The simulator's `cable-pull`: the link is cut in the middle of a 100 Hz
/// trajectory: SOFT_ESTOP, motion refused while latched, `<ENABLE>`.
#[test]
fn cable_pull_matches_the_simulator() {
    compare("../sim/scenarios/cable-pull.scn");
}
