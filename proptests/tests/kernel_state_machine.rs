//! proptest-state-machine runs of the whole kernel, both numeric variants:
//! long random sequences of motion commands (stream samples, valid, out of
//! limits, NaN, too far: `TARGET_JUMP`; configurator-style go-to frames),
//! dropouts (that hold or latch), lost links, encoder losses and glitches,
//! limit hits, outside forces, stalled and reversed motors, dead homing
//! switches, hardware faults, enables and homes (also while moving),
//! against the plant, with every safety
//! requirement that applies checked at every tick by the `monitor` crate (re-exported as `proptests::monitor`).
//!
//! Cases: `PROPTEST_CASES` (default below). Failures are persisted in
//! `proptest-regressions/kernel_state_machine_{f32,fx}.txt` and replayed first.

use std::cell::RefCell;
use std::marker::PhantomData;
use std::time::Instant;

use proptest::prelude::*;
use proptest::test_runner::TestRunner;
use proptest_state_machine::{ReferenceStateMachine, StateMachineTest};
use proptests::monitor::{Stats, FAULT_KINDS};
use proptests::scenario::{class, run_step, start_strategy, step_strategy, Mix, Start, Step, Sut, Variant};
use std::collections::BTreeMap;

/// Default cases per variant (debug build: about 10 s each on 2 cores).
const DEFAULT_CASES: u32 = 64;
/// Steps per case (each step lasts 1 to a few thousand ticks).
const STEPS: std::ops::RangeInclusive<usize> = 1..=48;

/// The reference model only generates: the kernel's behaviour is judged by
/// the monitor against the requirements, not against a second implementation.
struct Model;

impl ReferenceStateMachine for Model {
    type State = Start;
    type Transition = Step;

    fn init_state() -> BoxedStrategy<Start> {
        start_strategy()
    }
    fn transitions(_: &Start) -> BoxedStrategy<Step> {
        step_strategy(Mix::Full)
    }
    fn apply(state: Start, _: &Step) -> Start {
        state
    }
}

thread_local! {
    static STATS: RefCell<Stats> = RefCell::new(Stats::default());
    /// Ticks per interaction class (`proptests::scenario::class`), and the
    /// step before the one being played.
    static CLASSES: RefCell<BTreeMap<String, u64>> = const { RefCell::new(BTreeMap::new()) };
    static PREV: RefCell<Option<Step>> = const { RefCell::new(None) };
}

struct KernelTest<S>(PhantomData<S>);

impl<S: Variant> StateMachineTest for KernelTest<S> {
    type SystemUnderTest = Sut<S>;
    type Reference = Model;

    fn init_test(start: &Start) -> Sut<S> {
        PREV.with(|p| *p.borrow_mut() = None);
        Sut::new(start)
    }
    fn apply(mut sut: Sut<S>, start: &Start, step: Step) -> Sut<S> {
        let c = PREV.with(|p| class(&sut, &step, p.borrow().as_ref(), start));
        let t0 = sut.mon.stats.ticks;
        run_step(&mut sut, &step);
        let n = sut.mon.stats.ticks.saturating_sub(t0);
        CLASSES.with(|m| *m.borrow_mut().entry(c).or_insert(0) += n);
        PREV.with(|p| *p.borrow_mut() = Some(step));
        sut
    }
    fn teardown(sut: Sut<S>, _: Start) {
        STATS.with(|s| s.borrow_mut().merge(&sut.mon.stats));
    }
}

fn run<S: Variant>(file: &'static str) {
    let config = proptests::config(DEFAULT_CASES, file);
    let cases = config.cases;
    // Built outside the timed region (it homes once).
    let _ = S::homed_snapshot();
    STATS.with(|s| *s.borrow_mut() = Stats::default());
    CLASSES.with(|m| m.borrow_mut().clear());
    let t0 = Instant::now();
    let mut runner = TestRunner::new(config.clone());
    let result = runner.run(&Model::sequential_strategy(STEPS), |(start, steps, seen)| {
        KernelTest::<S>::test_sequential(config.clone(), start, steps, seen);
        Ok(())
    });
    if let Err(e) = result {
        panic!("{} kernel: {e}", S::NAME);
    }
    let s = STATS.with(|s| s.borrow().clone());
    let faults: Vec<String> = FAULT_KINDS.iter().zip(s.faults.iter()).map(|(n, c)| format!("{n} {c}")).collect();
    println!(
        "state machine [{}]: {cases} cases, {} ticks checked in {:.1} s; ticks per state \
         (Boot, Unhomed, Homing, Operational, Stopping, SoftEstop, Fault) {:?}; moving {}; \
         targets accepted {}, requests rejected {}; enables {} (refused with a cause {}; sent at rest {}); \
         soft stops {} (completed {}; of them for a lost link {}); holds at the timeout {}; go-tos accepted {}; \
         stream samples refused as jumps {}; HOME while moving {}; targets inside the braking distance {}; \
         ticks with a broken motor {}; homing runs completed {}; faults: {}",
        S::NAME,
        s.ticks,
        t0.elapsed().as_secs_f64(),
        s.state_ticks,
        s.moving_ticks,
        s.accepted,
        s.rejected,
        s.enabled,
        s.enable_refused,
        s.quiet_enables,
        s.soft_stops,
        s.stopped,
        s.link_stops,
        s.holds,
        s.goto_accepted,
        s.target_jumps,
        s.homes_after_stop,
        s.infeasible_retargets,
        s.broken_motor_ticks,
        s.homing_done,
        faults.join(", ")
    );
    // Ticks per interaction class (where modes meet), this run.
    let classes = CLASSES.with(|m| m.borrow().clone());
    let per_class: Vec<String> =
        classes.iter().filter(|(c, _)| c.as_str() != "other").map(|(c, n)| format!("{c}: {n}")).collect();
    println!("interaction classes [{}], ticks: {}", S::NAME, per_class.join("; "));
    // The generator must actually exercise the kernel (not a proof of
    // coverage, a guard against a vacuous generator).
    if cases >= DEFAULT_CASES {
        assert!(s.state_ticks.iter().all(|t| *t > 0), "every state visited: {:?}", s.state_ticks);
        assert!(s.accepted > 0 && s.enabled > 0 && s.stopped > 0 && s.homing_done > 0, "{s:?}");
        assert!(s.goto_accepted > 0 && s.link_stops > 0 && s.broken_motor_ticks > 0, "{s:?}");
        for c in ["link loss in homing", "chatter", "burst", "switch pressed while homing"] {
            assert!(classes.keys().any(|k| k.starts_with(c)), "no {c} class: {classes:?}");
        }
    }
}

#[test]
fn kernel_f32_state_machine() {
    run::<f32>("proptest-regressions/kernel_state_machine_f32.txt");
}

#[test]
fn kernel_fx_state_machine() {
    run::<kernel::Fx>("proptest-regressions/kernel_state_machine_fx.txt");
}
