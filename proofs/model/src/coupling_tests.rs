//! The coupling lemma a per-axis decomposition of a homing group would rest
//! on, checked over the kernel's public API (`tick`, `homing_phases`,
//! `homed`, its outputs and events, and its `Debug` text, which prints each
//! axis's whole state: observer, set-point, homing record, commanded path,
//! following-error count).
//!
//! Lemma: in a homing run, on a tick that raises no fault, each axis of the
//! group being homed (a group with an axis in a moving phase) ends the tick
//! in a state, with an output and a homed bit, that depend only on its own
//! state and its own switch: not on its siblings' switches, nor on their
//! states. The axes of a group are coupled only by the first fault (which
//! ends the whole run) and by the group's completion (every axis `Done`:
//! the next tick moves on to the next group), both of which a
//! decomposition would have to compose explicitly.
//!
//! Checked on sampled homing runs of the homing configuration's arm
//! (`HOMING_MODEL_CONFIG`: J4 may finish after J5, so a finished axis
//! waits): random switch arrivals of the seeking axes on every tick, from
//! `<HOME>` and from `<HOMEn>` after a complete run. At every state of a run:
//! (1) for every subset of the seeking axes' switches, each axis of the
//! group ends as it does when only its own switch is as in that subset
//! (so two ticks whose switches agree on an axis agree on that axis);
//! (2) across all states of all runs, the same axis state with the same
//! own switch always leads to the same axis state and output. **Sampled**
//! evidence: it holds on the runs drawn, not on every reachable state.

use crate::config::HOMING_MODEL_CONFIG;
use crate::coupling::{active_group, axis_texts, faulted};
use kernel::config::{Validated, AXES};
use kernel::homing::Phase;
use kernel::{Fx, Kernel, Request, State, TickOutput};
use proofs::setup::{new_kernel, still};
use proptest::prelude::*;
use proptest::test_runner::{RngAlgorithm, TestRng, TestRunner};
use std::collections::HashMap;

fn axis_text(k: &Kernel<Fx>, i: usize) -> String {
    let texts = axis_texts(k).expect("the kernel's Debug text has a per-axis array");
    texts[i].clone()
}

/// What the lemma compares of axis `i` after a tick.
fn axis_after(k: &Kernel<Fx>, o: &TickOutput<Fx>, i: usize) -> (String, Fx, bool) {
    (axis_text(k, i), o.act.velocity[i], k.homed() & (1 << i) != 0)
}

/// Counts of what a sample checked.
#[derive(Default)]
struct Seen {
    /// (state, subset, axis) comparisons made (no fault in either tick).
    compared: usize,
    /// Comparisons skipped because a tick faulted (the run's coupling).
    fault_coupled: usize,
    /// Comparisons where the axis was `Done` and a sibling still moving.
    waiting: usize,
    /// Times (2) met an axis state and switch it had met before.
    repeated: usize,
}

/// Checks (1) at `k` and records (2) in `seen_map`.
fn check_state(
    k: &Kernel<Fx>,
    seen_map: &mut HashMap<(usize, String, bool), (String, Fx, bool)>,
    seen: &mut Seen,
) -> Result<(), TestCaseError> {
    let phases = k.homing_phases();
    let Some(group) = active_group(&phases) else { return Ok(()) };
    let seeking = (0..AXES)
        .filter(|i| group & (1 << i) != 0 && matches!(phases[*i], Phase::FastSeek | Phase::SlowSeek))
        .fold(0u8, |m, i| m | 1 << i);
    let tick = |m: u8| {
        let mut c = k.clone();
        let o = c.tick(&still(m), None);
        (c, o)
    };
    let mut m = seeking;
    loop {
        let (a, oa) = tick(m);
        for i in (0..AXES).filter(|i| group & (1 << i) != 0) {
            let (b, ob) = tick(m & (1 << i));
            if faulted(&oa) || faulted(&ob) {
                seen.fault_coupled += 1;
                continue;
            }
            seen.compared += 1;
            if phases[i] == Phase::Done {
                seen.waiting += 1;
            }
            let (got, solo) = (axis_after(&a, &oa, i), axis_after(&b, &ob, i));
            prop_assert_eq!(&got, &solo, "axis {} depends on a sibling's switch (switches {:#08b})", i, m);
            let key = (i, axis_text(k, i), m & (1 << i) != 0);
            if let Some(before) = seen_map.insert(key, got.clone()) {
                seen.repeated += 1;
                prop_assert_eq!(before, got, "axis {} depends on more than its own state and switch", i);
            }
        }
        if m == 0 {
            break;
        }
        m = (m - 1) & seeking;
    }
    Ok(())
}

/// One homing run: `request` after boot (and after a complete `<HOME>` for
/// a per-joint run), each seeking axis's switch pressed on a tick when its
/// bit in that tick's draw is set.
fn run(
    joint: Option<u8>,
    draws: &[u8],
    seen_map: &mut HashMap<(usize, String, bool), (String, Fx, bool)>,
    seen: &mut Seen,
) -> Result<(), TestCaseError> {
    let (mut k, _) = new_kernel::<Fx>(&Validated::relaxed(HOMING_MODEL_CONFIG));
    k.tick(&still(0), None);
    if joint.is_some() {
        // A complete run first, every switch on the first tick it is sought.
        k.tick(&still(0), Some(Request::Home));
        for _ in 0..64 {
            if k.state() != State::Homing {
                break;
            }
            let p = k.homing_phases();
            let m = (0..AXES).filter(|i| matches!(p[*i], Phase::FastSeek | Phase::SlowSeek)).fold(0, |m, i| m | 1 << i);
            k.tick(&still(m), None);
        }
        prop_assert_eq!(k.state(), State::Operational);
    }
    k.tick(&still(0), Some(joint.map_or(Request::Home, Request::HomeJoint)));
    for d in draws {
        if k.state() != State::Homing {
            break;
        }
        check_state(&k, seen_map, seen)?;
        let p = k.homing_phases();
        let seeking =
            (0..AXES).filter(|i| matches!(p[*i], Phase::FastSeek | Phase::SlowSeek)).fold(0u8, |m, i| m | 1 << i);
        k.tick(&still(seeking & d), None);
    }
    Ok(())
}

/// A draw that presses each seeking switch with probability about 3/4
/// (most runs then finish within the timeouts, with arrivals out of step).
fn draws() -> impl Strategy<Value = Vec<u8>> {
    proptest::collection::vec((any::<u8>(), any::<u8>()).prop_map(|(a, b)| a | b), 40)
}

#[test]
fn a_homing_axis_reads_only_its_own_switch_and_state() {
    // `<HOME>`, then `<HOME4>`, `<HOME5>` and `<HOME1>` after a complete run.
    let requests = [None, Some(3), Some(4), Some(0)];
    let state = std::cell::RefCell::new((HashMap::new(), Seen::default()));
    // A fixed seed: the same runs every time, so the counts below are
    // stable.
    let rng = TestRng::deterministic_rng(RngAlgorithm::ChaCha);
    let mut runner = TestRunner::new_with_rng(ProptestConfig { cases: 256, ..ProptestConfig::default() }, rng);
    for joint in requests {
        let result = runner.run(&draws(), |d| {
            let (seen_map, seen) = &mut *state.borrow_mut();
            run(joint, &d, seen_map, seen)
        });
        if let Err(e) = result {
            panic!("homing joint {joint:?}: {e}");
        }
    }
    let (seen_map, seen) = state.into_inner();
    eprintln!(
        "coupling: {} comparisons ({} of a waiting axis), {} skipped on a fault, {} distinct axis states and switches, met again {} times",
        seen.compared,
        seen.waiting,
        seen.fault_coupled,
        seen_map.len(),
        seen.repeated
    );
    // The sample reached what the lemma is about: comparisons, finished
    // axes waiting for a sibling, and the fault that couples a run.
    assert!(seen.compared > 5_000, "only {} comparisons", seen.compared);
    assert!(seen.waiting > 20, "only {} comparisons of a waiting axis", seen.waiting);
    assert!(seen.fault_coupled > 0, "no tick faulted");
    assert!(seen_map.len() > 100, "only {} distinct axis states", seen_map.len());
    assert!(seen.repeated > 5_000, "(2) compared only {} times", seen.repeated);
}
