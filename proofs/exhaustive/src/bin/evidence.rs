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
    /// Model runs.
    model: Vec<Record>,
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
                run.model.push(Record {
                    kind: kind.into(),
                    cases: n.parse().unwrap_or(0),
                    result: result.into(),
                    detail: what.into(),
                });
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

    if claims.contains(&Source::ModelBounded) || claims.contains(&Source::ModelChecked) {
        for m in &run.model {
            let detail = if m.kind == "model-checked" {
                format!("every reachable state: {}", m.detail)
            } else {
                m.detail.clone()
            };
            rows.push(Record { detail, ..m.clone() });
        }
        if run.model.is_empty() {
            missing.push(format!("{id}: claims the model, but it did not run"));
        }
        let checked = run.model.iter().any(|m| m.kind == "model-checked");
        let bounded = run.model.iter().any(|m| m.kind != "model-checked");
        if claims.contains(&Source::ModelChecked) && !checked {
            missing.push(format!("{id}: claims model-checked, but no model run explored every reachable state"));
        }
        if claims.contains(&Source::ModelBounded) && !bounded {
            missing.push(format!("{id}: claims a bounded model exploration, but none ran"));
        }
        if checked && !claims.contains(&Source::ModelChecked) {
            unclaimed.push(format!("{id}: a model run explored every reachable state, but its row does not say so"));
        }
        if bounded && !claims.contains(&Source::ModelBounded) {
            unclaimed.push(format!("{id}: a model run was bounded, but its row does not say so"));
        }
    }
    (rows, missing, unclaimed)
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
            let other = if executed.contains("build") {
                "build"
            } else if executed.contains("emulated") {
                "emulated"
            } else {
                "tests"
            };
            rows.push(Record {
                kind: other.into(),
                cases: 0,
                result: "see SAFETY.md".into(),
                detail: executed.chars().take(60).collect(),
            });
            if !executed.contains("build") && !executed.contains("sampled") && !executed.contains("emulated") {
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
            "model\tsampled\t8000000\tholds\tbounded BFS\n",
            "SR-2\tSMT\t5\tproved\tsaturate f32\n",
        )
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
            "enumerated slices (x); SMT (saturate); sampled (shim); sampled (bounded model exploration)",
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
        let (_, m, _) = check_row("SR-4", "", "model-checked (every state)", &run());
        assert!(m.iter().any(|s| s.contains("model-checked")), "{m:?}");
    }

    #[test]
    fn an_smt_claim_needs_a_proof_and_a_proof_needs_its_claim() {
        let (_, m, _) = check_row("SR-7", "", "SMT (the ramp)", &run());
        assert!(!m.is_empty());
        let (_, _, u) = check_row("SR-2", "", "enumerated slices (x)", &run());
        assert!(u.iter().any(|s| s.contains("Smt")), "{u:?}");
    }

    #[test]
    fn a_shim_claim_needs_its_harness_to_have_run() {
        let (_, m, _) = check_row("SR-9", "`never_ran_f32`", "sampled (shim)", &run());
        assert!(!m.is_empty());
    }
}
