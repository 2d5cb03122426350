//! One model-check run: breadth first over every reachable state, its
//! counterexamples, and the properties that back evidence.

use crate::checks::{Check, EXERCISED};
use crate::identity::ModelScalar;
use crate::model::supervisor;
use stateright::{Checker, DiscoveryClassification, Expectation, HasDiscoveries, Model};
use std::sync::atomic::Ordering;

pub(crate) struct Run {
    pub(crate) unique: usize,
    pub(crate) generated: usize,
    pub(crate) depth: usize,
    pub(crate) secs: f64,
    pub(crate) violated: Vec<String>,
    /// Every reachable state was explored (not stopped by `--bounded` or
    /// `--depth`).
    pub(crate) exhaustive: bool,
    /// The `always` properties that held and applied in this run: every
    /// state property, and each transition check whose antecedent held on
    /// some explored transition.
    pub(crate) backing: Vec<&'static str>,
}

/// `timeout`: stop after that many seconds; `bounded`: a stop is a bounded
/// exploration (sampled evidence), not a failure; `depth`: explore breadth
/// first on one thread (so every state is first reached by a shortest
/// path) and expand no state at depth `depth` or beyond (the initial state
/// is at depth 1): every path of up to `depth - 2` ticks from power-on is
/// checked, whatever the machine's load.
pub(crate) fn run<S: ModelScalar>(
    cfg: &str,
    expect: Option<&str>,
    timeout: Option<u64>,
    bounded: bool,
    depth: Option<usize>,
) -> Run {
    let model = supervisor::<S>(cfg);
    let started = std::time::Instant::now();
    // A cap on generated states (stateright counts every generated state, not
    // only unique ones) so that a state explosion reports instead of
    // exhausting memory; reaching it makes the run fail (not exhaustive).
    const CAP: usize = 1_000_000_000;
    // Stop as soon as a property named like `want` is violated.
    let wanted: std::collections::BTreeSet<&'static str> =
        model.properties().iter().map(|p| p.name).filter(|n| expect.is_some_and(|w| n.contains(w))).collect();
    let mut b = model.checker().threads(2).target_state_count(CAP);
    EXERCISED.store(0, Ordering::Relaxed);
    if let Some(want) = expect {
        let names = wanted;
        if names.is_empty() {
            println!("model: no property is named like '{want}'");
            std::process::exit(1);
        }
        b = b.finish_when(HasDiscoveries::AnyOf(names));
    }
    if let Some(t) = timeout {
        b = b.timeout(std::time::Duration::from_secs(t));
    }
    if let Some(d) = depth {
        b = b.threads(1).target_max_depth(d);
    }
    let checker = b.spawn_bfs();
    // Progress every 30 s (stderr), so a slow run shows how it grows.
    let mut last = std::time::Instant::now();
    while !checker.is_done() {
        std::thread::sleep(std::time::Duration::from_millis(200));
        if last.elapsed().as_secs() >= 30 {
            last = std::time::Instant::now();
            eprintln!(
                "model {}: {:.0} s, {} unique states, {} generated, depth {}",
                S::NAME,
                started.elapsed().as_secs_f64(),
                checker.unique_state_count(),
                checker.state_count(),
                checker.max_depth()
            );
        }
    }
    let checker = checker.join();
    if crate::census::ON.load(Ordering::Relaxed) {
        crate::census::report(S::NAME, cfg, 30);
    }
    // (Before the properties' verdict, so that a kernel that fails the
    // lemma and a property too still reports the lemma.)
    if crate::coupling::ON.load(Ordering::Relaxed) && !crate::coupling::report(cfg) {
        println!("model: the homing group's coupling lemma failed or was never exercised");
        std::process::exit(1);
    }
    let secs = started.elapsed().as_secs_f64();
    // (stateright records a state's depth before skipping it at the bound,
    // so a maximum depth at the bound means some state was not expanded.)
    let stopped = timeout.is_some_and(|t| secs >= t as f64)
        || checker.state_count() >= CAP
        || depth.is_some_and(|d| checker.max_depth() >= d);
    if stopped && !bounded {
        println!(
            "model: stopped by --timeout or the state cap after {secs:.0} s: NOT exhaustive ({} unique states)",
            checker.unique_state_count()
        );
        std::process::exit(2);
    }
    let mut violated = Vec::new();
    for (name, path) in checker.discoveries() {
        if matches!(checker.discovery_classification(name), DiscoveryClassification::Counterexample) {
            violated.push(name.to_string());
            // The counterexample: its actions, and the last two states' kernel status.
            let states = path.clone().into_states();
            eprintln!("counterexample for '{name}', {} ticks:", states.len().saturating_sub(1));
            for a in path.clone().into_actions() {
                eprintln!("  {a:?}");
            }
            for st in states.iter().rev().take(2).rev() {
                eprintln!(
                    "  state {:?}, fault {:?}, homed {:#08b}, phases {:?}, j1 {:?}",
                    st.k.state(),
                    st.k.fault().map(|f| f.reason),
                    st.k.homed(),
                    st.k.homing_phases(),
                    st.j1
                );
            }
        }
    }
    let exercised = EXERCISED.load(Ordering::Relaxed);
    let checks: Vec<&'static str> = Check::ALL.iter().map(|c| c.name()).collect();
    let mut backing = Vec::new();
    for p in checker.model().properties() {
        if p.expectation != Expectation::Always || violated.iter().any(|v| v == p.name) {
            continue;
        }
        match Check::ALL.iter().find(|c| c.name() == p.name) {
            Some(c) if exercised & c.bit() == 0 => {
                if expect.is_none() {
                    println!("model {} {cfg}: not exercised (backs nothing here): {}", S::NAME, p.name);
                }
            }
            _ => backing.push(p.name),
        }
    }
    debug_assert!(checks.len() <= 64);
    let r = Run {
        unique: checker.unique_state_count(),
        generated: checker.state_count(),
        depth: checker.max_depth(),
        secs,
        violated,
        exhaustive: true,
        backing,
    };
    if expect.is_none() {
        if !r.violated.is_empty() {
            println!("model-checked {}: VIOLATED: {:?}", S::NAME, r.violated);
            if stopped {
                std::process::exit(1);
            }
        }
        // Every 'sometimes' property must be reached: a bounded exploration
        // that missed one explored too little to back what it shows
        // reachable, and a complete one that missed one shows the model
        // does not reach what it claims (all of them named, not only the
        // first).
        let missed: Vec<&str> = checker
            .model()
            .properties()
            .iter()
            .filter(|p| p.expectation == Expectation::Sometimes && checker.discovery(p.name).is_none())
            .map(|p| p.name)
            .collect();
        if !missed.is_empty() {
            let what = if stopped { "bounded exploration" } else { "exploration of every reachable state" };
            println!(
                "model {}: the {what} ({} unique states, depth {}) never reached the 'sometimes' properties {missed:?}",
                S::NAME,
                r.unique,
                r.depth
            );
            std::process::exit(1);
        }
        if stopped {
            // A bounded exploration: every property held in every explored
            // state and every 'sometimes' property was reached.
            let what = match depth {
                Some(d) => format!("every path of up to {} ticks from power-on explored", d.saturating_sub(2)),
                None => format!("stopped after {secs:.0} s"),
            };
            println!(
                "model {}: bounded exploration ({what}): {} unique states to depth {}: NOT exhaustive; no property violated in any explored state; every 'sometimes' property reached",
                S::NAME,
                r.unique,
                r.depth
            );
        } else {
            checker.assert_properties();
        }
    }
    Run { exhaustive: !stopped, ..r }
}
