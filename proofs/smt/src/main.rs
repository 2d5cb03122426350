//! Runs every SMT proof (two at a time, one z3 each) and prints each
//! proof's verdict, path count and time. Exit status 1 if any is not
//! proved. `smt FILTER` runs the proofs whose "name variant joints" contains
//! FILTER; `--extended` adds the proofs not established within the test
//! command's budget (see README.md).

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let extended = args.iter().any(|a| a == "--extended");
    args.retain(|a| a != "--extended");
    let filter = args.first().cloned().unwrap_or_default();
    let proofs: Vec<smt::Proof> = smt::all()
        .into_iter()
        .filter(|p| extended || !p.extended)
        .filter(|p| format!("{} {} {}", p.name, p.variant, p.joints_label()).contains(filter.as_str()))
        .collect();
    assert!(!proofs.is_empty(), "no proof matches {filter:?}");
    let workers = std::env::var("SMT_JOBS").ok().and_then(|s| s.parse().ok()).unwrap_or(2usize).max(1);
    println!("SMT proofs: {} obligations, {} at a time, z3 over a pipe", proofs.len(), workers);
    let t0 = Instant::now();
    let next = AtomicUsize::new(0);
    let results = Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..workers {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(p) = proofs.get(i) else { break };
                let o = p.run();
                let verdict = if o.proved() { "proved" } else { "COUNTEREXAMPLE" };
                println!(
                    "  {verdict:<14} {:>6.1} s  {:>4} paths  {:>5} checks ({} undecided, {} left open, {} reused)  {:<6} {:<12} {}",
                    o.time.as_secs_f64(),
                    o.paths,
                    o.checks,
                    o.undecided,
                    o.blind,
                    o.reused,
                    p.variant,
                    p.joints_label(),
                    p.name
                );
                if let Some(cex) = &o.counterexample {
                    for (k, v) in cex {
                        println!("      {k} = {v}");
                    }
                }
                results.lock().expect("no poisoned lock").push((i, o));
            });
        }
    });
    let mut results = results.into_inner().expect("no poisoned lock");
    results.sort_by_key(|(i, _)| *i);
    println!("\n| proof | variant | joints | verdict | paths | checks | time (s) |");
    println!("|---|---|---|---|---:|---:|---:|");
    let mut failed = 0;
    for (i, o) in &results {
        let p = &proofs[*i];
        let verdict = if o.proved() { "proved" } else { "NOT proved" };
        failed += usize::from(!o.proved());
        println!(
            "| {} | {} | {} | {verdict} | {} | {} | {:.1} |",
            p.name,
            p.variant,
            p.joints_label(),
            o.paths,
            o.checks,
            o.time.as_secs_f64()
        );
    }
    println!("\n{} of {} proved in {:.1} s", results.len() - failed, results.len(), t0.elapsed().as_secs_f64());
    // The evidence record (`ci/test.sh`'s summary checks SAFETY.md's rows
    // against it): requirement, kind, paths, verdict, what.
    if let Ok(dir) = std::env::var("EVIDENCE_DIR") {
        let mut tsv = String::new();
        for (i, o) in &results {
            let p = &proofs[*i];
            tsv.push_str(&format!(
                "{}\tSMT\t{}\t{}\t{} ({}, {}, {} paths, {:.1} s)\n",
                smt::requirements(p.name),
                o.paths,
                if o.proved() { "proved" } else { "NOT proved" },
                p.name,
                p.variant,
                p.joints_label(),
                o.paths,
                o.time.as_secs_f64()
            ));
        }
        if let Err(e) = std::fs::write(std::path::Path::new(&dir).join("smt.tsv"), tsv) {
            eprintln!("smt: cannot write the evidence file in {dir}: {e}");
            std::process::exit(1);
        }
    }
    if failed > 0 {
        std::process::exit(1);
    }
}
