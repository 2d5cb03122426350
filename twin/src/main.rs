//! `twin`: the shipped Serial1 image on the register-level board model.
//! Commands: see [`USAGE`].

use std::io::Write as _;
use std::time::{Duration, Instant};

use twin::{load_image, Plant, Twin, MS};

const USAGE: &str = "\
usage:
  twin [boot [MS]]          boot the image for MS simulated ms (default 200): Serial1 output, speed, figures
  twin home [MS]            boot, send <HOME>, run MS ms more: joint angles, STEP pulses, per-pin STEP state
  twin run FILE.scn         a simulator scenario on the image: its event lines, anchors, final angles; checks the
                            expectations the twin observes (exit 1 if one fails, as `sim run`)
  twin live [--pose P1,..,P6] [--for SECONDS] [--pace X]
                            Serial1 (LPUART6) on a pseudo-terminal (its path printed as `PTY <path>`), paced by
                            the wall clock: at most X x real time (default 1); prints the real-time factor and
                            the capacity (simulated time per CPU second) every simulated second and at the end
  twin help                 this text
--pace X < 1 slows the twin only: it cannot slow a client's clock, so a client that sends on wall-clock time
(the ROS 2 driver's 100 Hz) must divide its own rates by 1/X itself; at X = 1 no client needs to.
environment: TWIN_ELF=path (another image), TWIN_J6_PIN=36, TWIN_WFI_NOP=1, TWIN_NO_IDLE_SKIP=1, TWIN_FAULTS_INACTIVE=1";

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let cmd = args.first().map(String::as_str).unwrap_or("boot");
    let r = match cmd {
        "help" | "-h" | "--help" => {
            println!("{USAGE}");
            Ok(0)
        }
        "run" => match args.get(1) {
            Some(file) if args.len() == 2 => run_scenario(file),
            _ => Err(format!("run needs one scenario file\n{USAGE}")),
        },
        "live" => LiveOptions::parse(&args[1..]).and_then(live),
        "boot" | "home" => {
            let ms = match args.get(1) {
                None => Ok(200),
                Some(s) => s.parse::<u64>().map_err(|_| format!("{cmd} MS: MS must be a whole number, not {s}")),
            };
            ms.and_then(|ms| run(cmd, ms)).map(|()| 0)
        }
        other => Err(format!("unknown command {other}\n{USAGE}")),
    };
    match r {
        Ok(code) => std::process::exit(code),
        Err(e) => {
            eprintln!("twin: {e}");
            std::process::exit(2);
        }
    }
}

fn run(cmd: &str, ms: u64) -> Result<(), String> {
    let elf = load_image()?;
    let mut t = Twin::new(&elf, Plant::new(&kernel::config::PAROL6, twin::START_Q))?;
    if std::env::var_os("TWIN_FAULTS_INACTIVE").is_some() {
        t.board_mut().faults_forced_inactive = true;
    }
    let wall = Instant::now();
    let cpu0 = cpu_s();
    if cmd == "home" {
        t.run_until(100 * MS).map_err(|f| f.to_string())?;
        t.board_mut().serial_send(b"<HOME>\n");
        t.run_until((100 + ms) * MS).map_err(|f| f.to_string())?;
        println!("q = {:?}", t.board().plant.q());
        println!("STEP pulses = {:?}", t.board().step_pulses());
        for l in t.board().step_report() {
            println!("{l}");
        }
    } else {
        t.run_until(ms * MS).map_err(|f| f.to_string())?;
    }
    let secs = wall.elapsed().as_secs_f64();
    let cpu = cpu_s() - cpu0;
    let b = t.board();
    for line in b.serial_text().lines() {
        println!("serial1> {line}");
    }
    let sim_s = b.now as f64 / MS as f64 / 1000.0;
    println!(
        "simulated {:.1} ms = {} instructions in {secs:.2} s wall ({:.4} x real time) and {cpu:.2} s of CPU \
         ({:.2} x real time per CPU second, {:.1} M simulated instructions per CPU second)",
        b.now as f64 / MS as f64,
        b.now,
        sim_s / secs,
        sim_s / cpu.max(1e-9),
        b.now as f64 / cpu.max(1e-9) / 1e6
    );
    println!(
        "main reached at {:?} instructions; PIT handler calls {}; watchdog refreshes {}; watchdog resets {}; hints patched {}; stops deferred out of IT blocks {}; stop mismatches {}",
        b.main_at, t.stats.pit_calls, b.wdog.refreshes, t.stats.watchdog_resets, b.hints_patched, b.it_deferred, t.stats.stop_mismatch
    );
    if let Some(line) = twin::pit_instruction_summary(&t.stats.pit_instructions) {
        println!("{line}");
    }
    // The first entry is left out: it comes when the image unmasks the
    // PIT, late if the boot self-test left the flag set.
    let lat = t.stats.pit_latency.get(1..).unwrap_or(&[]);
    let worst = lat.iter().enumerate().max_by_key(|(_, l)| **l);
    if let (Some(lo), Some((k, hi))) = (lat.iter().min(), worst) {
        let others = lat.iter().enumerate().filter(|(i, _)| *i != k).map(|(_, l)| *l).max().unwrap_or(0);
        let from = t.stats.pit_from.get(k + 1).map(|&a| t.image.symbolize(a)).unwrap_or_default();
        println!(
            "PIT entry latency (expiry to handler entry) over {} ticks after the first: {lo}..{hi} cycles, mean {:.1}; \
             the largest at tick {} (interrupted at {from}), the others at most {others}",
            lat.len(),
            lat.iter().sum::<u64>() as f64 / lat.len() as f64,
            k + 1
        );
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

fn run_scenario(file: &str) -> Result<i32, String> {
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
    let checks = twin::scenario::check(&sc, &o);
    println!(
        "\nexpectations{}:",
        if sc.informational { " (informational: they do not decide the exit code)" } else { "" }
    );
    for c in &checks {
        let verdict = match c.held {
            Some(true) => "ok",
            Some(false) => "FAIL",
            None => "not checked",
        };
        println!("  [{verdict}] {}: {}", c.what, c.detail);
    }
    let failed = checks.iter().filter(|c| c.held == Some(false)).count();
    let unchecked = checks.iter().filter(|c| c.held.is_none()).count();
    println!(
        "{} expectation(s): {} held, {failed} failed, {unchecked} not observable on the twin",
        checks.len(),
        checks.len() - failed - unchecked
    );
    Ok(if failed > 0 && !sc.informational { 1 } else { 0 })
}

/// `twin live`'s options.
struct LiveOptions {
    pose: [f64; 6],
    run_for: Option<f64>,
    pace: f64,
}

impl LiveOptions {
    fn parse(args: &[String]) -> Result<Self, String> {
        let mut o = LiveOptions { pose: twin::START_Q, run_for: None, pace: 1.0 };
        let mut it = args.iter();
        while let Some(a) = it.next() {
            let mut value = || it.next().cloned().ok_or(format!("{a} needs a value\n{USAGE}"));
            match a.as_str() {
                "--pose" => {
                    let v = value()?;
                    let p: Vec<f64> = v
                        .split(',')
                        .map(|x| x.trim().parse::<f64>())
                        .collect::<Result<_, _>>()
                        .map_err(|_| format!("--pose needs six comma-separated numbers, not {v}"))?;
                    o.pose = p.try_into().map_err(|_| format!("--pose needs exactly six numbers, not {v}"))?;
                }
                "--for" => {
                    let v = value()?;
                    o.run_for = Some(
                        v.parse().ok().filter(|s: &f64| *s > 0.0).ok_or(format!("--for needs seconds > 0, not {v}"))?,
                    );
                }
                "--pace" => {
                    let v = value()?;
                    o.pace = v
                        .parse()
                        .ok()
                        .filter(|s: &f64| *s > 0.0 && *s <= 100.0)
                        .ok_or(format!("--pace needs a factor in (0, 100], not {v}"))?;
                }
                _ => return Err(format!("unknown live option {a}\n{USAGE}")),
            }
        }
        Ok(o)
    }
}

/// One simulated second of `twin live`: wall time, the CPU time the twin
/// used, and the bytes the client sent.
#[derive(Default)]
struct Second {
    wall: f64,
    cpu: f64,
    bytes_in: usize,
}

/// CPU time of this thread (s): what the emulation costs, whatever else
/// the machine runs (wall time spent waiting for a core is not in it).
fn cpu_s() -> f64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: `clock_gettime` writes one `timespec` into the live local.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    if rc != 0 {
        return 0.0;
    }
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

/// Serve LPUART6 on a pty: bytes written by a client go to the image's RX
/// line, the image's TX bytes come back, paced by simulated time.
fn live(o: LiveOptions) -> Result<i32, String> {
    let elf = load_image()?;
    let mut t = Twin::new(&elf, Plant::new(&kernel::config::PAROL6, o.pose))?;
    let pty = twin::pty::Pty::open()?;
    println!("PTY {}", pty.path);
    let _ = std::io::stdout().flush();
    eprintln!(
        "twin: Serial1 (LPUART6) on {} at up to {} x real time{}",
        pty.path,
        o.pace,
        if o.pace < 1.0 { " (a client must slow its own clock by the same factor: the twin cannot)" } else { "" }
    );
    let end = o.run_for.map(|s| (s * 1000.0).round() as u64 * MS);
    let mut sent = 0usize;
    let mut buf = [0u8; 256];
    let wall = Instant::now();
    let mut second = Second::default();
    let mut second_start = Instant::now();
    let mut cpu_start = cpu_s();
    let mut seconds: Vec<Second> = Vec::new();
    loop {
        let n = pty.read(&mut buf);
        if n > 0 {
            t.board_mut().serial_send(&buf[..n]);
            second.bytes_in += n;
        }
        let next = (t.now() / MS + 1) * MS;
        t.run_until(next).map_err(|f| f.to_string())?;
        // never ahead of real time x pace (sleeping lets the twin run
        // faster than the chip): a client sees the image's own timing
        let sim_s = t.now() as f64 / (1000 * MS) as f64;
        let ahead = sim_s / o.pace - wall.elapsed().as_secs_f64();
        if ahead > 0.0 {
            std::thread::sleep(Duration::from_secs_f64(ahead));
        }
        let out: Vec<u8> = t.board().uart.tx_out[sent..].iter().map(|&(_, b)| b).collect();
        sent += out.len();
        pty.write(&out);
        if t.now().is_multiple_of(1000 * MS) {
            second.wall = second_start.elapsed().as_secs_f64();
            second_start = Instant::now();
            let cpu = cpu_s();
            second.cpu = cpu - cpu_start;
            cpu_start = cpu;
            eprintln!(
                "twin: {sim_s:.0} s simulated: {:.2} x real time this second, capacity {:.2} x (simulated time per \
                 CPU second of the twin), {} bytes in",
                1.0 / second.wall.max(1e-9),
                1.0 / second.cpu.max(1e-9),
                second.bytes_in
            );
            seconds.push(std::mem::take(&mut second));
        }
        if end.is_some_and(|e| t.now() >= e) {
            break;
        }
    }
    let total = wall.elapsed().as_secs_f64();
    let sim_s = t.now() as f64 / (1000 * MS) as f64;
    let capacity = |f: &dyn Fn(&Second) -> bool| {
        let (n, cpu) = seconds.iter().filter(|s| f(s)).fold((0usize, 0.0), |a, s| (a.0 + 1, a.1 + s.cpu));
        if n == 0 {
            "-".to_string()
        } else {
            format!("{:.2} x over {n} s", n as f64 / cpu.max(1e-9))
        }
    };
    println!(
        "twin live: {sim_s:.1} s simulated in {total:.1} s wall ({:.2} x real time, paced at {} x); capacity idle \
         {}, while bytes arrived {}",
        sim_s / total,
        o.pace,
        capacity(&|s: &Second| s.bytes_in == 0),
        capacity(&|s: &Second| s.bytes_in > 0)
    );
    Ok(0)
}
