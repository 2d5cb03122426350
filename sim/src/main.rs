//! `sim`: the PAROL6 firmware's kernel and protocol against a simulated arm.
//!
//! ```text
//! sim                         run the built-in scenarios, write reports and plots
//! sim run FILE... [--builtin] run scenario files (and the built-ins too with --builtin)
//! sim list                    list the built-in scenarios
//! sim live [options]          serve the wire protocol on a pseudo-terminal in real time
//! common: --out DIR (default target/sim-report), --serial1 (the Serial1 build's feedback budget)
//! ```

use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use kernel::config::PAROL6_VALIDATED;
use sim::live::LiveOptions;
use sim::report::{summary, Report};
use sim::runner::{run, RunOptions};
use sim::scenario::{builtin, Scenario};

const USAGE: &str = "\
usage:
  sim                               run the built-in scenarios (reports and plots in target/sim-report/)
  sim run FILE.scn... [--builtin]   run scenario files (plus the built-ins with --builtin)
  sim list                          list the built-in scenarios
  sim live [--tcp ADDR:PORT] [--speed X] [--pose P1,..,P6] [--feedback both|driver|config] [--for SECONDS]
                                    serve the wire protocol on a pseudo-terminal, 1 kHz paced by the wall clock
options: --out DIR (report directory), --serial1 (main loop as the Serial1 build: configurator line at 10 Hz)";

fn main() -> ExitCode {
    match real_main() {
        Ok(code) => code,
        Err(e) => {
            eprintln!("sim: error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn value(args: &[String], i: &mut usize, flag: &str) -> Result<String> {
    *i += 1;
    args.get(*i).cloned().with_context(|| format!("{flag} needs a value\n{USAGE}"))
}

fn real_main() -> Result<ExitCode> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut cmd: Option<String> = None;
    let mut files: Vec<PathBuf> = Vec::new();
    let mut out = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../target/sim-report"));
    let mut opts = RunOptions::default();
    let mut with_builtin = false;
    let mut live = LiveOptions::new(&PAROL6_VALIDATED);
    let mut i = 0;
    while i < args.len() {
        let a = args[i].as_str();
        match a {
            "-h" | "--help" | "help" => {
                println!("{USAGE}");
                return Ok(ExitCode::SUCCESS);
            }
            "--out" => out = PathBuf::from(value(&args, &mut i, a)?),
            "--serial1" => {
                opts.serial1 = true;
                let feedback = live.host.feedback;
                live.host = firmware::root::HostConfig::SERIAL1;
                live.host.feedback = feedback;
            }
            "--builtin" => with_builtin = true,
            "--tcp" => live.tcp = Some(value(&args, &mut i, a)?),
            "--speed" => {
                let v = value(&args, &mut i, a)?;
                live.speed = v.parse().ok().filter(|s: &f64| *s > 0.0 && *s <= 100.0).with_context(|| {
                    format!("--speed must be a number in (0, 100] (simulated ms per wall ms), not {v}")
                })?;
            }
            "--for" => {
                let v = value(&args, &mut i, a)?;
                live.run_for = Some(
                    v.parse()
                        .ok()
                        .filter(|s: &f64| *s > 0.0)
                        .with_context(|| format!("--for must be a positive number of seconds, not {v}"))?,
                );
            }
            "--pose" => {
                let v = value(&args, &mut i, a)?;
                let p: Vec<f64> = v
                    .split(',')
                    .map(|x| x.trim().parse::<f64>())
                    .collect::<Result<_, _>>()
                    .with_context(|| format!("--pose needs six comma-separated numbers, not {v}"))?;
                live.plant.start = p.try_into().map_err(|_| anyhow::anyhow!("--pose needs exactly six numbers"))?;
            }
            "--feedback" => {
                let v = value(&args, &mut i, a)?;
                live.host.feedback = match v.as_str() {
                    "both" => protocol::feedback::FeedbackMode::Both,
                    "driver" => protocol::feedback::FeedbackMode::Driver,
                    "config" | "configurator" => protocol::feedback::FeedbackMode::Configurator,
                    _ => bail!("--feedback must be both, driver or config, not {v}"),
                };
            }
            "run" | "list" | "live" if cmd.is_none() => cmd = Some(a.to_string()),
            _ if a.starts_with('-') => bail!("unknown option {a}\n{USAGE}"),
            _ if cmd.as_deref() == Some("run") => files.push(PathBuf::from(a)),
            _ => bail!("unexpected argument {a}\n{USAGE}"),
        }
        i += 1;
    }
    match cmd.as_deref() {
        Some("list") => {
            for s in builtin()? {
                println!("{:<26} {}", s.name, s.description);
            }
            Ok(ExitCode::SUCCESS)
        }
        Some("live") => {
            sim::live::run_live(&PAROL6_VALIDATED, &live)?;
            Ok(ExitCode::SUCCESS)
        }
        Some("run") => {
            if files.is_empty() && !with_builtin {
                bail!("sim run needs scenario files\n{USAGE}");
            }
            let mut list = if with_builtin { builtin()? } else { Vec::new() };
            for f in &files {
                list.push(Scenario::from_file(f)?);
            }
            run_all(&list, &opts, &out)
        }
        _ => run_all(&builtin()?, &opts, &out),
    }
}

fn run_all(list: &[Scenario], opts: &RunOptions, out: &std::path::Path) -> Result<ExitCode> {
    let started = Instant::now();
    let tty = std::io::stderr().is_terminal();
    let mut reports: Vec<Report> = Vec::new();
    // Every label as wide as the longest, so the verdicts line up.
    let label_w = list.iter().map(|sc| sc.name.chars().count()).max().unwrap_or(0)
        + 2 * (list.len().max(1).ilog10() as usize + 1)
        + 4;
    for (k, sc) in list.iter().enumerate() {
        let label = format!("[{}/{}] {}", k + 1, list.len(), sc.name);
        let mut last = -1i64;
        let mut progress = |f: f64| {
            let pct = (f * 100.0) as i64;
            if tty && pct / 5 != last / 5 {
                eprint!("\r{label:<label_w$} {pct:>3}%");
                let _ = std::io::stderr().flush();
                last = pct;
            }
        };
        let t0 = Instant::now();
        let mut r = run(&PAROL6_VALIDATED, sc, opts, &mut progress);
        std::fs::create_dir_all(out).with_context(|| format!("creating report directory {}", out.display()))?;
        let svg = out.join(format!("{}.svg", r.name));
        std::fs::write(&svg, sim::svg::plot(&r)).with_context(|| format!("writing {}", svg.display()))?;
        r.plot = Some(svg);
        r.write(out)?;
        let took = t0.elapsed().as_secs_f64();
        // The trace and the line log are in the files now; the summary
        // needs neither (their memory is reused by the next scenario).
        r.trace = Vec::new();
        r.lines = Vec::new();
        let verdict = if r.failed() {
            "FAIL"
        } else if r.informational && !r.expectations_held() {
            "info"
        } else {
            "ok"
        };
        if tty {
            eprint!("\r");
        }
        eprintln!("{label:<label_w$} {verdict:<4} ({:.1} s simulated in {took:.3} s)", r.duration_ms as f64 / 1000.0);
        reports.push(r);
    }
    println!();
    print!("{}", summary(&reports));
    let failed: Vec<&Report> = reports.iter().filter(|r| r.failed()).collect();
    for r in &reports {
        if r.failed() || (r.informational && !r.expectations_held()) {
            println!("\n--- {} ---", r.name);
            for (e, ok, d) in &r.expectations {
                if !ok {
                    println!("  expectation failed: {e}: {d}");
                }
            }
            for (t, v) in r.violations.iter().take(10) {
                println!("  SAFETY VIOLATION at {t} ms: {v}");
            }
        }
    }
    let abs = std::fs::canonicalize(out).unwrap_or_else(|_| out.to_path_buf());
    let unsafe_runs = reports.iter().filter(|r| !r.safe()).count();
    println!(
        "\n{} scenario(s) in {:.1} s: {} passed, {} failed{}",
        reports.len(),
        started.elapsed().as_secs_f64(),
        reports.len() - failed.len(),
        failed.len(),
        if unsafe_runs > 0 { format!(" ({unsafe_runs} with SAFETY VIOLATIONS)") } else { String::new() }
    );
    println!(
        "reports: {}/<scenario>.txt, plots .svg, line logs .log; a real host program (ROS 2 driver, configurator) \
         connects to the simulated arm with `cargo run -p sim --release -- live`",
        abs.display()
    );
    Ok(if failed.is_empty() { ExitCode::SUCCESS } else { ExitCode::FAILURE })
}
