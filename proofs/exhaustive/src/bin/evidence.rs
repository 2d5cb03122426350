//! Prints the evidence summary of a test run: per requirement of SAFETY.md,
//! the kinds of evidence that ran here, how many cases or states, and the
//! result. Reads the records the shim (`shim.tsv`), the sweeps
//! (`exhaustive.tsv`), the model exploration (`model.tsv`) and the SMT step
//! (`smt.tsv`) wrote to `$EVIDENCE_DIR`.
//!
//! It also checks that SAFETY.md's traceability matrix and this summary
//! agree, and fails if not:
//! - every kind a row claims (each top-level `;` clause of its "executed
//!   here" cell: `exhaustive`, `enumerated slice`, `model-checked`, `SMT`,
//!   `sampled (shim ...)`, `sampled (bounded model exploration ...)`) has a
//!   record of that kind for that requirement from this run;
//! - a row that claims the model names the model properties that check it
//!   (`property "NAME"`, each tagged with the row's requirement: `SR-5: ...`
//!   or `SR-1/4/5: ...`), and each named property backs a run of every
//!   model kind the row claims (a run lists the properties that held and
//!   applied: a transition check whose antecedent never held backs
//!   nothing);
//! - every record of this run for a requirement (a sweep, an SMT proof) is
//!   claimed by its row with the record's own kind (a slice is never
//!   printed as exhaustive, a bounded exploration never as model-checked);
//! - every requirement has executed evidence or a build-time check.
//!
//! `--partial` (the test command's QUICK mode, which skips the sweeps, the
//! model and the SMT step) reports claims whose step did not run instead of
//! failing on them.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One executed record: kind as docs/spec/evidence.md names it, cases/states,
/// result, what it covered.
#[derive(Clone, Debug, PartialEq)]
struct Record {
    kind: String,
    cases: u64,
    result: String,
    detail: String,
}

/// Where a claim's evidence comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Source {
    /// Kani harnesses under the shim (`shim.tsv`).
    Shim,
    /// A full-domain sweep (`exhaustive.tsv`, kind `exhaustive`).
    Exhaustive,
    /// A sweep over part of a domain (`exhaustive.tsv`, kind `slice`).
    Slice,
    /// The bounded model exploration (`model.tsv`, any kind).
    ModelBounded,
    /// A complete model check (`model.tsv`, kind `model-checked`).
    ModelChecked,
    /// An SMT proof (`smt.tsv`).
    Smt,
    /// Tests, proptests, fuzzing, Miri, the build: no record to check.
    Unrecorded,
}

/// The top-level `;`-separated clauses of a cell (a `;` inside parentheses
/// belongs to its clause).
fn clauses(cell: &str) -> Vec<String> {
    let (mut out, mut cur, mut depth) = (Vec::new(), String::new(), 0i32);
    for ch in cell.chars() {
        match ch {
            '(' => depth += 1,
            ')' => depth -= 1,
            ';' if depth == 0 => {
                out.push(cur.trim().to_string());
                cur.clear();
                continue;
            }
            _ => {}
        }
        cur.push(ch);
    }
    if !cur.trim().is_empty() {
        out.push(cur.trim().to_string());
    }
    out
}

/// The source a clause claims, from its leading kind word and its subject.
fn claim(clause: &str) -> Source {
    let head = clause.split('(').next().unwrap_or("").trim();
    if head.starts_with("enumerated slice") || head.starts_with("slice") {
        Source::Slice
    } else if head.starts_with("exhaustive") {
        Source::Exhaustive
    } else if head.starts_with("model-checked") {
        Source::ModelChecked
    } else if head.starts_with("SMT") {
        Source::Smt
    } else if head.starts_with("sampled") && clause.contains("bounded model exploration") {
        Source::ModelBounded
    } else if head.starts_with("sampled") && clause.contains("shim") {
        Source::Shim
    } else {
        Source::Unrecorded
    }
}

/// The records of one run.
#[derive(Default)]
struct Run {
    /// harness -> (shim kind: `exhaustive` enumeration or `sampled`, cases).
    shim: BTreeMap<String, (String, u64)>,
    /// requirement -> sweep and SMT records.
    by_req: BTreeMap<String, Vec<(Source, Record)>>,
    /// Model runs, each with the properties that back it.
    model: Vec<(Record, Vec<String>)>,
}

impl Run {
    fn read(dir: &Path) -> Run {
        let read = |f: &str| std::fs::read_to_string(dir.join(f)).unwrap_or_default();
        Run::parse(&read("shim.tsv"), &read("exhaustive.tsv"), &read("model.tsv"), &read("smt.tsv"))
    }

    fn parse(shim_tsv: &str, sweeps: &str, model_tsv: &str, smt_tsv: &str) -> Run {
        let mut run = Run::default();
        for l in shim_tsv.lines() {
            let c: Vec<&str> = l.split('\t').collect();
            if let [name, kind, cases, ..] = c[..] {
                let short = name.rsplit("::").next().unwrap_or(name).to_string();
                run.shim.insert(short, (kind.to_string(), cases.parse().unwrap_or(0)));
            }
        }
        // Sweeps and SMT proofs: requirements (`SR-2/3`), kind, cases,
        // result, what.
        for (text, smt) in [(sweeps, false), (smt_tsv, true)] {
            for l in text.lines() {
                let c: Vec<&str> = l.split('\t').collect();
                if let [reqs, kind, cases, result, name, ..] = c[..] {
                    let src = match (smt, kind) {
                        (true, _) => Source::Smt,
                        (false, "exhaustive") => Source::Exhaustive,
                        _ => Source::Slice,
                    };
                    let rec = Record {
                        kind: kind.into(),
                        cases: cases.parse().unwrap_or(0),
                        result: result.into(),
                        detail: name.into(),
                    };
                    for r in reqs.replace("SR-", "").split('/') {
                        run.by_req.entry(format!("SR-{r}")).or_default().push((src, rec.clone()));
                    }
                }
            }
        }
        for l in model_tsv.lines() {
            let c: Vec<&str> = l.split('\t').collect();
            if let [_, kind, n, result, what, ..] = c[..] {
                let props = c.get(5).map_or(Vec::new(), |p| p.split('|').map(str::to_string).collect());
                let rec = Record {
                    kind: kind.into(),
                    cases: n.parse().unwrap_or(0),
                    result: result.into(),
                    detail: what.into(),
                };
                run.model.push((rec, props));
            }
        }
        run
    }
}

/// The summary rows of one requirement, and the disagreements between its
/// SAFETY.md row and the run (`missing`: claimed but not run; `unclaimed`:
/// run but not claimed with its kind).
fn check_row(id: &str, kani: &str, executed: &str, run: &Run) -> (Vec<Record>, Vec<String>, Vec<String>) {
    let claims: Vec<Source> = clauses(executed).iter().map(|c| claim(c)).collect();
    let mut rows = Vec::new();
    let (mut missing, mut unclaimed) = (Vec::new(), Vec::new());
    let harnesses: Vec<&str> = kani.split('`').skip(1).step_by(2).collect();

    // Kani harnesses under the shim: sampled evidence (docs/spec/evidence.md),
    // whether the shim drew its inputs or enumerated the harness's own.
    let (mut drawn, mut enumerated, mut cases) = (0, 0, 0u64);
    for h in &harnesses {
        if let Some((kind, n)) = run.shim.get(*h) {
            cases += n;
            if kind == "exhaustive" {
                enumerated += 1;
            } else {
                drawn += 1;
            }
        }
    }
    if drawn + enumerated > 0 {
        rows.push(Record {
            kind: "sampled".into(),
            cases,
            result: "holds".into(),
            detail: format!(
                "{} Kani harness(es) under the shim ({drawn} drawn, {enumerated} with every input of the harness enumerated)",
                drawn + enumerated
            ),
        });
    } else if claims.contains(&Source::Shim) {
        missing.push(format!("{id}: claims the shim, but none of its harnesses ran under it"));
    }

    let recs = run.by_req.get(id).cloned().unwrap_or_default();
    for (src, r) in &recs {
        let label = match src {
            Source::Exhaustive => format!("whole domain: {}", r.detail),
            Source::Slice => format!("slice: {}", r.detail),
            _ => r.detail.clone(),
        };
        let kind = if *src == Source::Slice { "slice".to_string() } else { r.kind.clone() };
        rows.push(Record { kind, detail: label, ..r.clone() });
        if !claims.contains(src) {
            unclaimed.push(format!("{id}: ran {src:?} ({}), but its SAFETY.md row does not claim it", r.detail));
        }
    }
    for src in [Source::Exhaustive, Source::Slice, Source::Smt] {
        if claims.contains(&src) && !recs.iter().any(|(s, _)| *s == src) {
            missing.push(format!("{id}: claims {src:?}, but no such record ran for it"));
        }
    }

    let (claims_checked, claims_bounded) =
        (claims.contains(&Source::ModelChecked), claims.contains(&Source::ModelBounded));
    if claims_checked || claims_bounded {
        let named = model_properties(executed);
        if named.is_empty() {
            missing.push(format!("{id}: claims the model, but names no model property (property \"NAME\")"));
        }
        for p in &named {
            if !property_tags(p).iter().any(|t| t == id) {
                missing.push(format!("{id}: names the model property \"{p}\", which is not tagged with {id}"));
            }
        }
        let checked = |m: &Record| m.kind == "model-checked";
        for (want, kind) in [(claims_checked, true), (claims_bounded, false)] {
            if !want {
                continue;
            }
            let label = if kind { "model-checked" } else { "a bounded model exploration" };
            let runs: Vec<&(Record, Vec<String>)> = run.model.iter().filter(|(m, _)| checked(m) == kind).collect();
            if runs.is_empty() {
                missing.push(format!("{id}: claims {label}, but no such model run ran"));
                continue;
            }
            for p in &named {
                let backing: Vec<&Record> =
                    runs.iter().filter(|(_, props)| props.iter().any(|q| q == p)).map(|(m, _)| m).collect();
                if backing.is_empty() {
                    missing.push(format!("{id}: claims {label} by \"{p}\", but no such run checked that property"));
                }
                for m in backing {
                    let detail = if kind {
                        format!("every reachable state: {}: \"{p}\"", m.detail)
                    } else {
                        format!("{}: \"{p}\"", m.detail)
                    };
                    rows.push(Record { detail, ..m.clone() });
                }
            }
        }
        // Each configuration a model-checked clause names backs each of
        // its properties (a property of a transition backs a run only where
        // its antecedent held on an explored transition).
        let complete: Vec<&(Record, Vec<String>)> = run.model.iter().filter(|(m, _)| checked(m)).collect();
        if claims_checked && !complete.is_empty() {
            for clause in clauses(executed).iter().filter(|c| claim(c) == Source::ModelChecked) {
                let configs = clause_configs(clause);
                for (p, only) in properties_with_configs(clause) {
                    for cfg in if only.is_empty() { &configs } else { &only } {
                        let tag = format!(" {cfg} configuration");
                        match complete.iter().find(|(m, _)| m.detail.contains(&tag)) {
                            None => missing.push(format!(
                                "{id}: claims every reachable state of the {cfg} configuration, but no such model run ran"
                            )),
                            Some((_, props)) if !props.contains(&p) => missing.push(format!(
                                "{id}: claims \"{p}\" in the {cfg} configuration, but that run does not back it (not exercised there)"
                            )),
                            Some(_) => {}
                        }
                    }
                }
            }
        }
        // A run of the other kind that checked a property of this
        // requirement must be claimed too.
        for (m, props) in &run.model {
            let tagged = props.iter().any(|p| property_tags(p).iter().any(|t| t == id));
            if tagged && checked(m) && !claims_checked {
                unclaimed
                    .push(format!("{id}: a model run explored every reachable state, but its row does not say so"));
            }
            if tagged && !checked(m) && !claims_bounded {
                unclaimed.push(format!("{id}: a model run was bounded, but its row does not say so"));
            }
        }
    }
    (rows, missing, unclaimed)
}

/// The kind of a row's evidence that leaves no record here (the build, the
/// twin's runs, tests and property tests): the first clause that starts
/// with `build`, `emulated` or `sampled`, read from the clause's first
/// words as `claim` reads them (a word inside a clause, "the image
/// `retarget` builds", claims nothing). `None`: the row has no such
/// evidence.
fn unrecorded_kind(executed: &str) -> Option<&'static str> {
    clauses(executed).iter().find_map(|c| {
        let head = c.split('(').next().unwrap_or("").trim();
        ["build", "emulated", "sampled"].into_iter().find(|k| head.starts_with(k))
    })
}

/// The model properties a cell names: every `property "NAME"`.
fn model_properties(cell: &str) -> Vec<String> {
    cell.split("property \"").skip(1).filter_map(|r| r.split('"').next()).map(str::to_string).collect()
}

/// The model's configurations, as a clause names them.
const CONFIGS: [&str; 5] = ["full", "stream", "small", "tiny", "homing"];

fn config_words(text: &str) -> Vec<String> {
    text.split(|c: char| !c.is_ascii_alphanumeric()).filter(|w| CONFIGS.contains(w)).map(str::to_string).collect()
}

/// The configurations a model-checked clause claims every reachable state
/// of: "every reachable state: `Kernel<Fx>` full, small and homing,
/// `Kernel<f32>` tiny; ...".
fn clause_configs(clause: &str) -> Vec<String> {
    clause
        .split_once("every reachable state:")
        .map_or(Vec::new(), |(_, rest)| config_words(rest.split(';').next().unwrap_or("")))
}

/// Each `property "NAME"` of a clause, with the configurations it is
/// restricted to when a parenthesis that starts with one follows it
/// (`property "NAME" (full, small and tiny)`, or `(full and small: the
/// reason)`, the list ending at the colon); empty: the clause's.
fn properties_with_configs(clause: &str) -> Vec<(String, Vec<String>)> {
    clause
        .split("property \"")
        .skip(1)
        .filter_map(|r| {
            let (name, after) = r.split_once('"')?;
            let inside = after.strip_prefix(" (").and_then(|a| a.split_once(')')).map_or("", |(i, _)| i);
            // The list ends at a colon: "(full and small: why not homing)".
            let inside = inside.split(':').next().unwrap_or("");
            let first = inside.split(|c: char| !c.is_ascii_alphanumeric()).find(|w| !w.is_empty());
            let only = if first.is_some_and(|w| CONFIGS.contains(&w)) { config_words(inside) } else { Vec::new() };
            Some((name.to_string(), only))
        })
        .collect()
}

/// The requirements a model property is tagged with: `SR-1/4/5: ...` ->
/// SR-1, SR-4, SR-5.
fn property_tags(name: &str) -> Vec<String> {
    let Some((head, _)) = name.split_once(':') else { return Vec::new() };
    let Some(nums) = head.strip_prefix("SR-") else { return Vec::new() };
    nums.split('/').map(|n| format!("SR-{n}")).collect()
}

fn main() {
    let partial = std::env::args().any(|a| a == "--partial");
    let dir = PathBuf::from(std::env::var("EVIDENCE_DIR").unwrap_or_else(|_| "target/evidence".into()));
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let safety = std::fs::read_to_string(root.join("SAFETY.md")).unwrap_or_else(|e| {
        eprintln!("evidence: cannot read SAFETY.md: {e}");
        std::process::exit(1)
    });
    let run = Run::read(&dir);
    let start = safety.find("## 6. Traceability").unwrap_or(0);
    let (mut none, mut missing, mut unclaimed) = (Vec::new(), Vec::new(), Vec::new());
    println!("\n{:<6} {:<14} {:>16}  {:<8} detail", "req", "kind", "cases/states", "result");
    for line in safety[start..].lines().filter(|l| l.starts_with("| SR-")) {
        let cells: Vec<&str> = line.trim_matches('|').split(" | ").map(str::trim).collect();
        let (id, kani, executed) = (cells[0], cells[1], cells.get(2).copied().unwrap_or(""));
        let (mut rows, m, u) = check_row(id, kani, executed, &run);
        missing.extend(m);
        unclaimed.extend(u);
        if rows.is_empty() {
            // The twin's runs (kind `emulated`) are not recorded here: twin/test.sh
            // runs and reports them.
            let other = unrecorded_kind(executed);
            rows.push(Record {
                kind: other.unwrap_or("tests").into(),
                cases: 0,
                result: "see SAFETY.md".into(),
                detail: executed.chars().take(60).collect(),
            });
            if other.is_none() {
                none.push(id.to_string());
            }
        }
        for (i, r) in rows.iter().enumerate() {
            let label = if i == 0 { id } else { "" };
            let n = if r.cases == 0 { "-".to_string() } else { r.cases.to_string() };
            println!("{label:<6} {:<14} {n:>16}  {:<8} {}", r.kind, r.result, r.detail);
        }
    }
    let mut failed = false;
    if !none.is_empty() {
        eprintln!("evidence: no executed evidence recorded for {none:?}");
        failed = true;
    }
    for u in &unclaimed {
        eprintln!("evidence: SAFETY.md and the run disagree: {u}");
        failed = true;
    }
    for m in &missing {
        if partial {
            println!("evidence (partial run): {m}");
        } else {
            eprintln!("evidence: SAFETY.md and the run disagree: {m}");
            failed = true;
        }
    }
    if failed {
        std::process::exit(1);
    }
    if partial && !missing.is_empty() {
        println!(
            "\nPartial run: what ran agrees with SAFETY.md; {} claimed records come from steps QUICK mode skips.",
            missing.len()
        );
    } else {
        println!("\nSAFETY.md's traceability matrix and this run agree.");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run() -> Run {
        Run::parse(
            "proofs::a::h_f32\tsampled\t2000\n",
            "SR-12\texhaustive\t16777216\tholds\tunwrap pairs\nSR-2/3\tslice\t4294967296\tholds\tcontrol law\n",
            "model\tsampled\t8000000\tholds\tbounded BFS\tSR-2/3: non-finite|SR-4: fault tick output\n\
             model\tmodel-checked\t3000000\tholds\tsmall\tSR-4: fault tick output|SR-5: latch left\n",
            "SR-2\tSMT\t5\tproved\tsaturate f32\n",
        )
    }

    /// A model-checked clause claims each property in each configuration
    /// it names: a configuration whose run did not exercise a property
    /// (its antecedent never held there) is refused, unless the property
    /// is restricted to the configurations that back it.
    #[test]
    fn a_configuration_that_does_not_back_a_property_is_refused() {
        let r = Run::parse(
            "",
            "",
            "model\tmodel-checked\t3000000\tholds\tsupervisor + homing, Kernel<Fx>, small configuration\tSR-8: armed|SR-8: after homing\n\
             model\tmodel-checked\t500000\tholds\tsupervisor + homing, Kernel<Fx>, homing configuration\tSR-8: after homing\n",
            "",
        );
        let cell = "model-checked (every reachable state: `Kernel<Fx>` small and homing; property \"SR-8: armed\"; property \"SR-8: after homing\")";
        let (_, m, _) = check_row("SR-8", "", cell, &r);
        assert!(m.iter().any(|s| s.contains("\"SR-8: armed\" in the homing configuration")), "{m:?}");
        assert_eq!(m.len(), 1, "{m:?}");
        let restricted = "model-checked (every reachable state: `Kernel<Fx>` small and homing; property \"SR-8: armed\" (small only: the homing configuration sends no motion); property \"SR-8: after homing\")";
        let (_, m, _) = check_row("SR-8", "", restricted, &r);
        assert!(m.is_empty(), "{m:?}");
        let absent =
            "model-checked (every reachable state: `Kernel<Fx>` small and tiny; property \"SR-8: after homing\")";
        let (_, m, _) = check_row("SR-8", "", absent, &r);
        assert!(m.iter().any(|s| s.contains("tiny configuration, but no such model run ran")), "{m:?}");
        // A parenthesis that does not start with a configuration restricts nothing.
        assert_eq!(
            properties_with_configs("property \"SR-5: x\" (a kernel whose home is small fails it)"),
            vec![("SR-5: x".to_string(), Vec::new())]
        );
    }

    #[test]
    fn clauses_split_at_top_level_only() {
        assert_eq!(clauses("sampled (shim: a; b); exhaustive (x)"), vec!["sampled (shim: a; b)", "exhaustive (x)"]);
    }

    #[test]
    fn agreeing_rows_pass() {
        let r = run();
        let (rows, m, u) = check_row("SR-12", "", "exhaustive (all pairs)", &r);
        assert!(m.is_empty() && u.is_empty() && rows.len() == 1, "{m:?} {u:?}");
        let (_, m, u) = check_row(
            "SR-2",
            "`h_f32`",
            "enumerated slices (x); SMT (saturate); sampled (shim); sampled (bounded model exploration: property \"SR-2/3: non-finite\")",
            &r,
        );
        assert!(m.is_empty() && u.is_empty(), "{m:?} {u:?}");
    }

    #[test]
    fn a_slice_claimed_as_exhaustive_is_refused() {
        // SR-3's sweep is a slice: a row calling it exhaustive claims a
        // record that did not run, and leaves the slice unclaimed.
        let (_, m, u) = check_row("SR-3", "", "exhaustive (every set-point)", &run());
        assert!(!m.is_empty() && !u.is_empty());
    }

    #[test]
    fn a_bounded_exploration_claimed_as_model_checked_is_refused() {
        // SR-2's property ran only in the bounded exploration.
        let (_, m, _) = check_row("SR-2", "", "model-checked (property \"SR-2/3: non-finite\")", &run());
        assert!(m.iter().any(|s| s.contains("model-checked")), "{m:?}");
    }

    #[test]
    fn a_model_claim_names_a_property_of_its_requirement_that_ran() {
        let r = run();
        let (rows, m, u) = check_row(
            "SR-4",
            "",
            "sampled (bounded model exploration); model-checked (property \"SR-4: fault tick output\")",
            &r,
        );
        assert!(m.is_empty() && u.is_empty() && rows.len() == 2, "{m:?} {u:?} {rows:?}");
        // No property named.
        let (_, m, _) = check_row("SR-5", "", "model-checked (every reachable state)", &r);
        assert!(m.iter().any(|s| s.contains("names no model property")), "{m:?}");
        // A property of another requirement.
        let (_, m, _) = check_row("SR-6", "", "model-checked (property \"SR-5: latch left\")", &r);
        assert!(m.iter().any(|s| s.contains("not tagged with SR-6")), "{m:?}");
        // A property no run checked (never exercised, or not in the model).
        let (_, m, _) = check_row("SR-5", "", "model-checked (property \"SR-5: reason changed\")", &r);
        assert!(m.iter().any(|s| s.contains("no such run checked")), "{m:?}");
        // A complete run checked SR-4's property: a row saying only
        // "bounded" hides it.
        let (_, _, u) =
            check_row("SR-4", "", "sampled (bounded model exploration: property \"SR-4: fault tick output\")", &r);
        assert!(u.iter().any(|s| s.contains("every reachable state")), "{u:?}");
    }

    #[test]
    fn property_tags_are_the_requirements_before_the_colon() {
        assert_eq!(property_tags("SR-1/4/5: output"), vec!["SR-1", "SR-4", "SR-5"]);
        assert_eq!(property_tags("SR-32: invariant"), vec!["SR-32"]);
        assert!(property_tags("operational").is_empty());
        assert_eq!(
            model_properties("model-checked (property \"SR-5: a\", property \"SR-5: b\"; x)"),
            vec!["SR-5: a", "SR-5: b"]
        );
    }

    #[test]
    fn an_smt_claim_needs_a_proof_and_a_proof_needs_its_claim() {
        let (_, m, _) = check_row("SR-7", "", "SMT (the ramp)", &run());
        assert!(!m.is_empty());
        let (_, _, u) = check_row("SR-2", "", "enumerated slices (x)", &run());
        assert!(u.iter().any(|s| s.contains("Smt")), "{u:?}");
    }

    #[test]
    fn a_kind_is_read_from_a_clause_s_first_words_only() {
        assert_eq!(unrecorded_kind("emulated (twin); tested (host); build (the image's build)"), Some("emulated"));
        assert_eq!(unrecorded_kind("build (const evaluation)"), Some("build"));
        assert_eq!(unrecorded_kind("sampled (`proptests` state machine)"), Some("sampled"));
        // A kind word inside a clause claims nothing: such a row has no
        // evidence of these kinds and is reported.
        assert_eq!(unrecorded_kind("SMT (the interval `retarget` builds, read; sampled draws elsewhere)"), None);
        assert_eq!(unrecorded_kind("tested (host); the coverage checked on every build"), None);
    }

    #[test]
    fn a_shim_claim_needs_its_harness_to_have_run() {
        let (_, m, _) = check_row("SR-9", "`never_ran_f32`", "sampled (shim)", &run());
        assert!(!m.is_empty());
    }
}
