//! `twin boot [ms]`: boot the image, print Serial1 output and figures.
//! `twin home [ms]`: boot, send `<HOME>`, print joint angles and STEP counts.
//! `twin live`: LPUART6 on a pseudo-terminal (its path is printed); runs
//! until interrupted, at most at real time.
//! `twin run FILE.scn`: a simulator scenario on the image: its event lines
//! with times, the anchors, the final joint angles, the speed.

use std::time::Instant;

use twin::{load_image, Plant, Twin, MS};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let cmd = args.get(1).map(String::as_str).unwrap_or("boot");
    if cmd == "run" {
        let Some(file) = args.get(2) else {
            eprintln!("twin: run FILE.scn");
            std::process::exit(2);
        };
        if let Err(e) = run_scenario(file) {
            eprintln!("twin: {e}");
            std::process::exit(1);
        }
        return;
    }
    let ms: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(200);
    if let Err(e) = run(cmd, ms) {
        eprintln!("twin: {e}");
        std::process::exit(1);
    }
}

fn run(cmd: &str, ms: u64) -> Result<(), String> {
    let elf = load_image()?;
    let mut t = Twin::new(&elf, Plant::new(&kernel::config::PAROL6, twin::START_Q))?;
    if std::env::var_os("TWIN_FAULTS_INACTIVE").is_some() {
        t.board_mut().faults_forced_inactive = true;
    }
    let wall = Instant::now();
    match cmd {
        "boot" => {
            t.run_until(ms * MS).map_err(|f| f.to_string())?;
        }
        "home" => {
            t.run_until(100 * MS).map_err(|f| f.to_string())?;
            t.board_mut().serial_send(b"<HOME>\n");
            t.run_until((100 + ms) * MS).map_err(|f| f.to_string())?;
            println!("q = {:?}", t.board().plant.q());
            println!("STEP pulses = {:?}", t.board().step_pulses());
            for l in t.board().step_report() {
                println!("{l}");
            }
        }
        "live" => return live(t),
        other => return Err(format!("unknown command {other} (boot | home | live)")),
    }
    let secs = wall.elapsed().as_secs_f64();
    let b = t.board();
    for line in b.serial_text().lines() {
        println!("serial1> {line}");
    }
    println!(
        "simulated {:.1} ms = {} instructions in {:.2} s wall ({:.4} x real time, {:.1} M instr/s)",
        b.now as f64 / MS as f64,
        b.now,
        secs,
        b.now as f64 / MS as f64 / 1000.0 / secs,
        b.now as f64 / secs / 1e6
    );
    println!(
        "main reached at {:?} instructions; PIT handler calls {}; watchdog refreshes {}; watchdog resets {}; hints patched {}; stops deferred out of IT blocks {}; stop mismatches {}",
        b.main_at, t.stats.pit_calls, b.wdog.refreshes, t.stats.watchdog_resets, b.hints_patched, b.it_deferred, t.stats.stop_mismatch
    );
    if let Some(line) = twin::pit_instruction_summary(&t.stats.pit_instructions) {
        println!("{line}");
    }
    println!(
        "main loop slept (WFI): {} times, {:.1} % of simulated time; LPUART6 handler calls {}",
        b.wfi_count,
        100.0 * t.stats.sleep_cycles as f64 / b.now.max(1) as f64,
        t.stats.uart_calls
    );
    println!(
        "idle main loop skipped: {} times, {:.1} % of simulated time (TWIN_NO_IDLE_SKIP=1 turns it off)",
        t.stats.idle_skips,
        100.0 * t.stats.idle_cycles as f64 / b.now.max(1) as f64
    );
    Ok(())
}

fn run_scenario(file: &str) -> Result<(), String> {
    let sc = sim::scenario::Scenario::from_file(std::path::Path::new(file)).map_err(|e| format!("{e:#}"))?;
    let elf = load_image()?;
    let o = twin::scenario::run(&sc, &elf)?;
    println!("scenario {}: {}", sc.name, sc.description);
    for s in &o.skipped {
        println!("skipped (not supported by the twin): {s}");
    }
    for (t, l) in &o.events {
        println!("{t:>7} ms  {l}");
    }
    for a in sim::scenario::Anchor::ALL {
        println!("{}: {:?}", a.name(), o.anchors[a.index()]);
    }
    println!("q at {} ms = {:?}", o.end_ms, o.q);
    if let Some(line) = twin::pit_instruction_summary(&o.pit_instructions) {
        println!("{line}");
        let calls = o.pit_instructions.len().max(1) as f64;
        let total: u64 = o.pit_profile.iter().map(|(_, n)| n).sum();
        println!("PIT handler profile (function a block starts in; instructions per call, share):");
        for (f, n) in o.pit_profile.iter().take(20) {
            println!("  {:>8.0}  {:>5.1} %  {f}", *n as f64 / calls, 100.0 * *n as f64 / total.max(1) as f64);
        }
    }
    println!(
        "simulated {:.1} s in {:.1} s wall ({:.2} x real time)",
        o.end_ms as f64 / 1000.0,
        o.wall_s,
        o.end_ms as f64 / 1000.0 / o.wall_s
    );
    Ok(())
}

/// Serve LPUART6 on a pty: bytes written by a client go to the image's RX
/// line, the image's TX bytes come back, paced by simulated time.
fn live(mut t: Twin) -> Result<(), String> {
    let pty = twin::pty::Pty::open()?;
    println!("twin: Serial1 (LPUART6) on {}", pty.path);
    let mut sent = 0usize;
    let mut buf = [0u8; 256];
    let wall = Instant::now();
    loop {
        let n = pty.read(&mut buf);
        if n > 0 {
            t.board_mut().serial_send(&buf[..n]);
        }
        let next = (t.now() / MS + 1) * MS;
        t.run_until(next).map_err(|f| f.to_string())?;
        // never ahead of real time (idle skipping can make the twin faster
        // than the chip): a client sees the image's own timing
        let ahead = t.now() as f64 / (1000 * MS) as f64 - wall.elapsed().as_secs_f64();
        if ahead > 0.0 {
            std::thread::sleep(std::time::Duration::from_secs_f64(ahead));
        }
        let out: Vec<u8> = t.board().uart.tx_out[sent..].iter().map(|&(_, b)| b).collect();
        sent += out.len();
        pty.write(&out);
        if t.now().is_multiple_of(1000 * MS) {
            eprintln!(
                "twin: {:.1} s simulated, {:.3} x real time",
                t.now() as f64 / (1000 * MS) as f64,
                t.now() as f64 / (1000 * MS) as f64 / wall.elapsed().as_secs_f64()
            );
        }
    }
}
