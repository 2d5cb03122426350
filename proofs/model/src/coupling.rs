//! The homing group's coupling lemma (`README.md`, "The homing group's
//! coupling") checked on every explored transition of a run
//! (`--coupling`): on a tick of a homing run with no request, no
//! perturbation and no fault, each axis of the group being homed ends in a
//! state (its `Debug` text: observer, set-point, homing record, commanded
//! path, following-error count), with an output and a homed bit, that
//! depend only on its own state and its own switch. Two checks per axis:
//! the tick with only the axis's own switch as pressed gives the same, and
//! across the whole run the same axis state and own switch always give the
//! same. Run to completion on the homing configuration, that is every
//! reachable state of it and every subset of its seeking switches there.
//! `coupling_tests` samples the same lemma in the test suite.

use crate::environment::Perturb;
use crate::identity::ModelScalar;
use crate::model::Supervisor;
use kernel::config::{AXES, HOMING_GROUPS};
use kernel::homing::Phase;
use kernel::{Event, Kernel, Scalar, TickOutput};
use std::collections::HashMap;
use std::fmt::Debug;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;

/// Whether this run checks the lemma (`--coupling`).
pub(crate) static ON: AtomicBool = AtomicBool::new(false);
static COMPARED: AtomicUsize = AtomicUsize::new(0);
static WAITING: AtomicUsize = AtomicUsize::new(0);
static SKIPPED: AtomicUsize = AtomicUsize::new(0);
static REPEATED: AtomicUsize = AtomicUsize::new(0);
/// What an axis state and own switch led to: (axis, state, switch) to
/// (state, output, homed).
type Seen = HashMap<(usize, String, bool), (String, String, bool)>;
static SEEN: Mutex<Option<Seen>> = Mutex::new(None);
/// The first violation found, if any.
static FAILED: Mutex<Option<String>> = Mutex::new(None);

/// The `Debug` text of each axis's state (the kernel's per-axis array
/// `axes: [Axis { .. }, ..]`), or `None` if the text does not parse.
pub(crate) fn axis_texts<S: Scalar + Debug>(k: &Kernel<S>) -> Option<Vec<String>> {
    let text = format!("{k:?}");
    let start = text.find("axes: [Axis {")?;
    let rest = &text[start + "axes: [".len()..];
    let (mut depth, mut from, mut found) = (0usize, 0usize, Vec::new());
    for (n, c) in rest.char_indices() {
        match c {
            '{' | '[' | '(' => {
                if depth == 0 {
                    from = n;
                }
                depth += 1;
            }
            '}' | ']' | ')' => {
                if depth == 0 {
                    break;
                }
                depth -= 1;
                if depth == 0 && c == '}' {
                    found.push(rest.get(from..=n)?.to_string());
                }
            }
            _ => {}
        }
    }
    (found.len() == AXES).then_some(found)
}

/// The group being homed: the one with an axis in a moving phase.
pub(crate) fn active_group(phases: &[Phase; AXES]) -> Option<u8> {
    HOMING_GROUPS.into_iter().find(|g| (0..AXES).any(|i| g & (1 << i) != 0 && phases[i].is_moving()))
}

pub(crate) fn faulted<S>(o: &TickOutput<S>) -> bool {
    o.events.iter().any(|e| matches!(e, Event::Fault(_)))
}

fn fail(what: String) {
    if let Ok(mut f) = FAILED.lock() {
        f.get_or_insert(what);
    }
}

/// Checks the lemma on the tick from `s` with the switches `pressed` (no
/// request, no perturbation) that gave `n` and `o`.
pub(crate) fn check<S: ModelScalar>(sup: &Supervisor<S>, s: &Kernel<S>, pressed: u8, n: &Kernel<S>, o: &TickOutput<S>) {
    let phases = s.homing_phases();
    let Some(group) = active_group(&phases) else { return };
    let (Some(before), Some(after)) = (axis_texts(s), axis_texts(n)) else {
        fail("the kernel's Debug text has no per-axis array".into());
        return;
    };
    for i in (0..AXES).filter(|i| group & (1 << i) != 0) {
        let bit = 1u8 << i;
        let mut b = s.clone();
        let ob = b.tick(&sup.sense(Perturb::None, pressed & bit), None);
        if faulted(o) || faulted(&ob) {
            SKIPPED.fetch_add(1, Ordering::Relaxed);
            continue;
        }
        let Some(solo_texts) = axis_texts(&b) else { return };
        let got = (after[i].clone(), format!("{:?}", o.act.velocity[i]), n.homed() & bit != 0);
        let solo = (solo_texts[i].clone(), format!("{:?}", ob.act.velocity[i]), b.homed() & bit != 0);
        COMPARED.fetch_add(1, Ordering::Relaxed);
        if phases[i] == Phase::Done {
            WAITING.fetch_add(1, Ordering::Relaxed);
        }
        if got != solo {
            fail(format!("axis {i} depends on a sibling's switch (switches {pressed:#08b}): {got:?} / {solo:?}"));
        }
        if let Ok(mut seen) = SEEN.lock() {
            let key = (i, before[i].clone(), pressed & bit != 0);
            if let Some(prev) = seen.get_or_insert_with(HashMap::new).insert(key, got.clone()) {
                REPEATED.fetch_add(1, Ordering::Relaxed);
                if prev != got {
                    fail(format!("axis {i} depends on more than its own state and switch: {prev:?} / {got:?}"));
                }
            }
        }
    }
}

/// Prints what the run checked; false if the lemma failed.
pub(crate) fn report(cfg: &str) -> bool {
    let distinct = SEEN.lock().ok().and_then(|s| s.as_ref().map(HashMap::len)).unwrap_or(0);
    println!(
        "coupling {cfg}: {} comparisons ({} of a finished axis waiting), {} skipped on a fault, {distinct} distinct axis states and switches, met again {} times",
        COMPARED.load(Ordering::Relaxed),
        WAITING.load(Ordering::Relaxed),
        SKIPPED.load(Ordering::Relaxed),
        REPEATED.load(Ordering::Relaxed)
    );
    match FAILED.lock().ok().and_then(|f| f.clone()) {
        Some(what) => {
            println!("coupling {cfg}: VIOLATED: {what}");
            false
        }
        None => COMPARED.load(Ordering::Relaxed) > 0,
    }
}
