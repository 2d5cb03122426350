//! f32 against fixed point: the same random sequence of requests and
//! environment changes played in lockstep to `KernelF32` and `KernelFx` on
//! the same plant (both sense the same arm every tick; the f32 kernel's
//! outputs move it), each tick of each kernel checked by the safety monitor.
//!
//! Property: at every tick both kernels are in the same state, with the same
//! homed joints and the same kind of latched fault; their outputs differ by at
//! most `BOUND_V` rad/s, their set-points and estimates by at most `BOUND_Q`
//! rad.
//!
//! Exception: while their homing phases differ (at most `MAX_SKEW` ticks in
//! a row: a back-off that ends when the estimate crosses a distance can end
//! a tick apart) their outputs are not compared; those ticks are counted.
//!
//! Bound, not equality, for the set-point profile: its discrete
//! decisions (accelerate, cruise, brake, land; the hold-versus-latch test
//! that follows from them) can fall a tick apart in the two variants when a
//! braking or landing test lands within its rounding allowance. Then one
//! set-point runs a whole acceleration step (`dv`) ahead, so outputs differ
//! by about `dv`, and a later decision that depends on them (hold versus
//! latch at the timeout) can differ too. From the first tick whose
//! set-point velocities differ by more than `PROFILE_SPLIT * dv` on some
//! axis (a split) outputs and set-points are not compared, until the
//! set-points have agreed within `BOUND_Q / 10` with velocities within
//! `PROFILE_SPLIT * dv` for `RESYNC_TICKS` ticks, or both kernels
//! resynchronise their set-points together (entering Homing or Fault, or
//! an enable). States differing during a split end that case's comparison
//! (counted); outside a split they fail the test, but for one case: the
//! fixed-point kernel does not drive the arm (the f32 kernel's outputs do),
//! so after a split its commanded path and the arm drift apart and it can
//! fault FOLLOWING_ERROR alone; that ends the case too (counted separately;
//! its monitor does not apply the clean-plant checks, `Sut::follower`). Splits, the ticks not
//! compared and the cases ended are printed. Both kernels stay checked by
//! the safety monitor at every tick, split or not.
//!
//! The sequences avoid inputs whose outcome legitimately depends on
//! rounding: outside forces near the runaway or position thresholds and
//! encoder glitches near the plausibility window (`Mix::Discrete`). Those are
//! covered per variant by `kernel_state_machine.rs`.
//!
//! Cases: `PROPTEST_CASES` (default below). Failures are persisted in
//! `proptest-regressions/differential.txt`.

use std::cell::Cell;
use std::time::Instant;

use proptest::collection::vec;
use proptest::test_runner::TestRunner;
use proptests::scenario::{run_step, start_strategy, step_strategy, Mix, Pair, MAX_SKEW, PROFILE_SPLIT, RESYNC_TICKS};

const DEFAULT_CASES: u32 = 32;
/// Largest output difference allowed (rad/s): 1% of the smallest joint limit.
const BOUND_V: f64 = 0.05;
/// Largest difference of set-points and of estimates allowed (rad): 1 mrad,
/// about 4 encoder counts of J1.
const BOUND_Q: f64 = 1e-3;

#[test]
fn f32_and_fixed_point_agree() {
    let config = proptests::config(DEFAULT_CASES, "proptest-regressions/differential.txt");
    let cases = config.cases;
    let t0 = Instant::now();
    let mut runner = TestRunner::new(config);
    let worst = Cell::new((0.0f64, 0.0f64, 0.0f64));
    let ticks = Cell::new(0u64);
    let skew = Cell::new((0u32, 0u64));
    let split = Cell::new((0u32, 0u64, 0.0f64, 0u64, 0u32, 0u32));
    let strategy = (start_strategy(), vec(step_strategy(Mix::Discrete), 1..=48));
    let result = runner.run(&strategy, |(start, steps)| {
        let mut pair = Pair::new(&start, BOUND_V, BOUND_Q);
        for s in &steps {
            run_step(&mut pair, s);
        }
        let w = worst.get();
        worst.set((w.0.max(pair.worst_v), w.1.max(pair.worst_q), w.2.max(pair.worst_est)));
        ticks.set(ticks.get() + pair.a.ticks);
        let k = skew.get();
        skew.set((k.0.max(pair.worst_skew), k.1 + pair.skew_ticks));
        let d = split.get();
        split.set((
            d.0 + u32::from(pair.diverged.is_some()),
            d.1 + pair.compared_ticks,
            d.2.max(pair.worst_sp_vel),
            d.3 + pair.split_ticks,
            d.4 + pair.splits,
            d.5 + u32::from(pair.follower_fe),
        ));
        Ok(())
    });
    if let Err(e) = result {
        panic!("{e}");
    }
    let (worst, ticks, skew, split) = (worst.get(), ticks.get(), skew.get(), split.get());
    println!(
        "differential f32 vs I8F24: {cases} cases, {ticks} ticks in {:.1} s; states equal at every tick but in \
         splits; \
         max |v_f32 - v_fx| = {:.3e} rad/s (bound {BOUND_V}), max |set-point difference| = {:.3e} rad, \
         max |estimate difference| = {:.3e} rad (bound {BOUND_Q}); homing phases a tick apart on {} ticks \
         (longest run {}, bound {MAX_SKEW}); profile splits (set-point velocities more than {PROFILE_SPLIT} dv \
         apart) {}, ticks not compared during splits {}, cases ended by a state difference during or after a split {} \
         of {cases} ({} of them the fixed-point kernel's FOLLOWING_ERROR: it does not drive the arm); split ends after {RESYNC_TICKS} realigned ticks; {} ticks compared; max set-point velocity \
         difference while compared {:.3e} rad/s",
        t0.elapsed().as_secs_f64(),
        worst.0,
        worst.1,
        worst.2,
        skew.1,
        skew.0,
        split.4,
        split.3,
        split.0,
        split.5,
        split.1,
        split.2
    );
}
