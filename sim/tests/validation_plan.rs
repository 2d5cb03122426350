//! The bench validation plan (`docs/safety/VALIDATION-PLAN.md`) dry-run in
//! the simulator: every case names a built-in scenario that exists and
//! passes (safety held at every tick, every expectation met), or says why
//! the simulator cannot express it; every twin entry names a test or
//! scenario file that the twin's own tests (`twin/test.sh`) run.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use kernel::config::PAROL6_VALIDATED;
use sim::runner::{run, RunOptions};
use sim::scenario::builtin;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("repository root").to_path_buf()
}

fn backticked(cell: &str) -> Vec<String> {
    cell.split('`').skip(1).step_by(2).map(str::to_string).collect()
}

/// (case, scenarios, twin entries) of every `| VC-` row.
fn cases(plan: &str) -> Vec<(String, Vec<String>, Vec<String>)> {
    plan.lines()
        .filter(|l| l.starts_with("| VC-"))
        .map(|l| {
            let c: Vec<&str> = l.trim().trim_matches('|').split(" | ").map(str::trim).collect();
            assert_eq!(c.len(), 7, "case row needs 7 cells: {l}");
            assert!(
                !backticked(c[5]).is_empty() || c[5].starts_with("none: "),
                "{}: names no scenario and gives no reason",
                c[0]
            );
            // A reason (`none: ...`) may quote host tests: no scenario.
            let named = |cell: &str| if cell.starts_with("none: ") { Vec::new() } else { backticked(cell) };
            (c[0].to_string(), named(c[5]), named(c[6]))
        })
        .collect()
}

/// The plan's scenario names that are not built-in scenarios.
fn unknown_scenarios(plan: &str, known: &BTreeSet<String>) -> Vec<String> {
    cases(plan)
        .into_iter()
        .flat_map(|(id, s, _)| s.into_iter().map(move |n| (id.clone(), n)))
        .filter(|(_, n)| !known.contains(n))
        .map(|(id, n)| format!("{id}: {n}"))
        .collect()
}

fn plan() -> String {
    std::fs::read_to_string(repo().join("docs/safety/VALIDATION-PLAN.md")).expect("VALIDATION-PLAN.md")
}

#[test]
fn every_case_names_a_scenario_that_exists_and_passes() {
    let plan = plan();
    let all = builtin().expect("built-in scenarios");
    let known: BTreeSet<String> = all.iter().map(|s| s.name.clone()).collect();
    let unknown = unknown_scenarios(&plan, &known);
    assert!(unknown.is_empty(), "cases naming no built-in scenario: {unknown:?}");
    let cases = cases(&plan);
    assert!(cases.len() >= 40, "{} cases", cases.len());
    let named: BTreeSet<String> = cases.iter().flat_map(|(_, s, _)| s.iter().cloned()).collect();
    for sc in all.iter().filter(|s| named.contains(&s.name)) {
        let r = run(&PAROL6_VALIDATED, sc, &RunOptions::default(), &mut |_| {});
        assert!(r.safe(), "{}: safety violated: {:?}", r.name, r.violations);
        for (e, ok, d) in &r.expectations {
            assert!(*ok, "{}: expectation `{e}` failed: {d}", r.name);
        }
        println!("{}: passes ({} expectations)", r.name, r.expectations.len());
    }
    let none: Vec<&str> = cases.iter().filter(|(_, s, _)| s.is_empty()).map(|(id, _, _)| id.as_str()).collect();
    println!(
        "{} cases, {} scenarios run; no simulator scenario (reason in the plan): {none:?}",
        cases.len(),
        named.len()
    );
}

#[test]
fn every_twin_entry_is_run_by_the_twin_tests() {
    let mut twin_tests = String::new();
    for e in std::fs::read_dir(repo().join("twin/tests")).expect("twin/tests") {
        let p = e.expect("entry").path();
        if p.extension().is_some_and(|x| x == "rs") {
            twin_tests.push_str(&std::fs::read_to_string(&p).expect("read"));
        }
    }
    let mut on_twin = 0;
    for (id, _, twin) in cases(&plan()) {
        for t in twin {
            let as_test = format!("fn {t}(");
            let as_file = format!("\"{t}\"");
            assert!(
                twin_tests.contains(&as_test) || twin_tests.contains(&as_file),
                "{id}: the twin's tests neither define `{t}` nor run it"
            );
            on_twin += 1;
        }
    }
    assert!(on_twin >= 5, "{on_twin} twin entries");
}

#[test]
fn the_plan_check_rejects_an_unknown_scenario() {
    let known: BTreeSet<String> = builtin().expect("built-in").into_iter().map(|s| s.name).collect();
    let forged = "| VC-SR-1 | x | LA | y | 1 | `no-such-scenario` | none: - |\n";
    assert_eq!(unknown_scenarios(forged, &known), vec!["VC-SR-1: no-such-scenario".to_string()]);
    assert!(unknown_scenarios("| VC-SR-1 | x | LA | y | 1 | `runaway` | none: - |\n", &known).is_empty());
}
