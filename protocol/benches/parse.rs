//! Parser throughput on the host. Criterion prints time per frame and
//! throughput (bytes of input per second); nothing is asserted.
//!
//! Each parser group also times the pre-issue-14 parser (numbers converted
//! from their text by `Scalar::parse_decimal`, `tests/reference`) in the
//! same process, so the before/after ratio holds even on a loaded machine.
//!
//! On a busy machine wall-clock times swing with the load; CPU cycles spent
//! in user mode do not. `PARSE_LOOP=<case> <bench binary>` skips criterion
//! and parses one frame 10^7 times (`PARSE_ITERS` to change), printing the
//! time per frame the thread spent on a CPU (Linux schedstat) beside the
//! wall-clock time; cases: `driver_f32`, `driver_fx`, `driver_f32_before`,
//! `driver_fx_before`, and the same with `config_`. E.g.
//! `PARSE_LOOP=driver_f32 target/release/deps/parse-<hash>` (the path
//! `cargo bench -p protocol --bench parse --no-run` prints).

#[path = "../tests/reference/mod.rs"]
mod reference;

use criterion::{black_box, criterion_group, Criterion, Throughput};
use kernel::config::PAROL6_VALIDATED;
use kernel::Fx;
use protocol::receiver::Receiver;
use protocol::{DialectLock, Parser, ProtocolConfig};

const DRIVER: &[u8] = b"<1532,0.123,0.050,-0.500,-0.200,1.000,0.000,0.250,0.000,-1.571,0.300,3.142,-0.000>";
const CONFIG: &[u8] = b"<42,0.1234,-0.5000,1.0000,0.2500,-1.5708,3.1416,0.0500,-0.2000,0.0000,0.0000,0.3000,-0.0000>";

fn bench(c: &mut Criterion) {
    let pf: Parser<f32> = Parser::new(&PAROL6_VALIDATED, DialectLock::Auto);
    let px: Parser<Fx> = Parser::new(&PAROL6_VALIDATED, DialectLock::Auto);
    for (name, frame) in [("parse_driver_frame", DRIVER), ("parse_configurator_frame", CONFIG)] {
        assert!(pf.parse(frame).is_ok() && px.parse(frame).is_ok());
        let mut g = c.benchmark_group(name);
        g.throughput(Throughput::Bytes(frame.len() as u64));
        g.bench_function("f32", |b| b.iter(|| pf.parse(black_box(frame))));
        g.bench_function("fx", |b| b.iter(|| px.parse(black_box(frame))));
        g.bench_function("f32_before", |b| b.iter(|| reference::parse(&pf, black_box(frame))));
        g.bench_function("fx_before", |b| b.iter(|| reference::parse(&px, black_box(frame))));
        g.finish();
    }

    // framer + parser + sequence filter, byte by byte, one frame per iteration
    let mut line = DRIVER.to_vec();
    line.push(b'\n');
    let mut g = c.benchmark_group("receiver_driver_line");
    g.throughput(Throughput::Bytes(line.len() as u64));
    let mut rx: Receiver<f32> = Receiver::new(&PAROL6_VALIDATED, ProtocolConfig::DEFAULT);
    g.bench_function("f32", |b| {
        b.iter(|| {
            let mut n = 0u32;
            for &byte in black_box(&line) {
                if rx.push(byte, 0).is_some() {
                    n += 1;
                }
            }
            n
        })
    });
    g.finish();
}

/// Parses one frame `PARSE_ITERS` times (default 10^7) with the parser
/// `case` names; prints the wall-clock time per frame.
fn parse_loop(case: &str) {
    let iters: u64 = std::env::var("PARSE_ITERS").ok().and_then(|s| s.parse().ok()).unwrap_or(10_000_000);
    let pf: Parser<f32> = Parser::new(&PAROL6_VALIDATED, DialectLock::Auto);
    let px: Parser<Fx> = Parser::new(&PAROL6_VALIDATED, DialectLock::Auto);
    let (frame, rest) = match case.split_once('_') {
        Some(("driver", r)) => (DRIVER, r),
        Some(("config", r)) => (CONFIG, r),
        _ => panic!("unknown case {case}"),
    };
    let t = std::time::Instant::now();
    let cpu0 = cpu_ns();
    let mut ok = 0u64;
    for _ in 0..iters {
        let f = black_box(frame);
        ok += u64::from(match rest {
            "f32" => pf.parse(f).is_ok(),
            "fx" => px.parse(f).is_ok(),
            "f32_before" => reference::parse(&pf, f).is_ok(),
            "fx_before" => reference::parse(&px, f).is_ok(),
            _ => panic!("unknown case {case}"),
        });
    }
    assert_eq!(ok, iters);
    let wall = t.elapsed().as_nanos() as f64 / iters as f64;
    match (cpu0, cpu_ns()) {
        (Some(a), Some(b)) => {
            let cpu = b.saturating_sub(a) as f64 / iters as f64;
            println!("{case}: {iters} frames, {cpu:.1} ns per frame on the CPU ({wall:.1} ns wall clock)")
        }
        _ => println!("{case}: {iters} frames, {wall:.1} ns per frame (wall clock)"),
    }
}

/// Time this thread has run on a CPU (ns; Linux `/proc/thread-self/schedstat`):
/// unlike wall-clock time, it does not count the time other processes had
/// the core.
fn cpu_ns() -> Option<u64> {
    std::fs::read_to_string("/proc/thread-self/schedstat").ok()?.split_whitespace().next()?.parse().ok()
}

criterion_group!(benches, bench);

fn main() {
    match std::env::var("PARSE_LOOP") {
        Ok(case) => parse_loop(&case),
        Err(_) => {
            benches();
            Criterion::default().configure_from_args().final_summary();
        }
    }
}
