//! Prints the evidence summary of a test run: per requirement of SAFETY.md,
//! the kinds of evidence that ran here, how many cases or states, and the
//! result. Reads the records the shim (`shim.tsv`), the sweeps
//! (`exhaustive.tsv`) and the model check (`model.tsv`) wrote to
//! `$EVIDENCE_DIR`; fails if a requirement ended up with no executed evidence.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn read(dir: &Path, f: &str) -> String {
    std::fs::read_to_string(dir.join(f)).unwrap_or_default()
}

fn main() {
    let dir = PathBuf::from(std::env::var("EVIDENCE_DIR").unwrap_or_else(|_| "target/evidence".into()));
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let safety = std::fs::read_to_string(root.join("SAFETY.md")).unwrap_or_else(|e| {
        eprintln!("evidence: cannot read SAFETY.md: {e}");
        std::process::exit(1)
    });
    // harness -> (kind, cases)
    let mut shim: BTreeMap<String, (String, u64)> = BTreeMap::new();
    for l in read(&dir, "shim.tsv").lines() {
        let c: Vec<&str> = l.split('\t').collect();
        if let [name, kind, cases, ..] = c[..] {
            let short = name.rsplit("::").next().unwrap_or(name).to_string();
            shim.insert(short, (kind.to_string(), cases.parse().unwrap_or(0)));
        }
    }
    // requirement -> [(kind, cases, result, what)]: kind `exhaustive` (a
    // whole domain) or `slice` (one argument of several enumerated).
    let mut by_req: BTreeMap<String, Vec<(String, u64, String, String)>> = BTreeMap::new();
    for l in read(&dir, "exhaustive.tsv").lines() {
        let c: Vec<&str> = l.split('\t').collect();
        if let [reqs, kind, cases, result, name, ..] = c[..] {
            let reqs = reqs.replace("SR-", "");
            for r in reqs.split('/') {
                by_req.entry(format!("SR-{r}")).or_default().push((
                    kind.into(),
                    cases.parse().unwrap_or(0),
                    result.into(),
                    name.into(),
                ));
            }
        }
    }
    // One line per model run (variant and configuration in the last field).
    let model: Vec<(u64, String, String)> = read(&dir, "model.tsv")
        .lines()
        .filter_map(|l| {
            let c: Vec<&str> = l.split('\t').collect();
            Some((c.get(2)?.parse().ok()?, c.get(3)?.to_string(), c.get(4).unwrap_or(&"").to_string()))
        })
        .collect();
    let start = safety.find("## 6. Traceability").unwrap_or(0);
    let mut missing = Vec::new();
    println!("\n{:<6} {:<14} {:>16}  {:<8} detail", "req", "kind", "cases/states", "result");
    for line in safety[start..].lines().filter(|l| l.starts_with("| SR-")) {
        let cells: Vec<&str> = line.trim_matches('|').split(" | ").map(str::trim).collect();
        let (id, kani, executed) = (cells[0], cells[1], cells.get(2).copied().unwrap_or(""));
        let mut rows: Vec<(String, u64, String, String)> = Vec::new();
        let harnesses: Vec<&str> = kani.split('`').skip(1).step_by(2).collect();
        let mut shim_cases: BTreeMap<String, u64> = BTreeMap::new();
        for h in &harnesses {
            if let Some((kind, n)) = shim.get(*h) {
                *shim_cases.entry(format!("{kind} (shim)")).or_default() += n;
            }
        }
        for (k, n) in shim_cases {
            rows.push((k, n, "holds".into(), format!("{} Kani harness(es) under the shim", harnesses.len())));
        }
        for (k, n, r, what) in by_req.get(id).into_iter().flatten() {
            let detail = if k == "exhaustive" { format!("whole domain: {what}") } else { format!("slice: {what}") };
            rows.push((k.clone(), *n, r.clone(), detail));
        }
        // A kind counts only where it is claimed, not where it is denied.
        if executed.contains("model-checked") && !executed.contains("not model-checked") {
            for (n, r, what) in &model {
                rows.push(("model-checked".into(), *n, r.clone(), format!("every reachable state: {what}")));
            }
        }
        if rows.is_empty() {
            let other = if executed.contains("build") { "build" } else { "tests" };
            rows.push((other.into(), 0, "see SAFETY.md".into(), executed.chars().take(60).collect()));
            if !executed.contains("build") && !executed.contains("sampled") {
                missing.push(id.to_string());
            }
        }
        for (i, (k, n, r, d)) in rows.iter().enumerate() {
            let label = if i == 0 { id } else { "" };
            let n = if *n == 0 { "-".to_string() } else { n.to_string() };
            println!("{label:<6} {k:<14} {n:>16}  {r:<8} {d}");
        }
    }
    if !missing.is_empty() {
        eprintln!("evidence: no executed evidence recorded for {missing:?}");
        std::process::exit(1);
    }
}
