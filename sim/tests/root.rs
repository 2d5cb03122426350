//! The shared composition root, in simulated time: the simulator runs the
//! firmware's own root type; both clients on one stream never take each
//! other's lines; a flood that fills the transmit path loses nothing
//! silently and never a fault line.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};

use firmware::root::{Controller, HostConfig};
use kernel::config::{PAROL6, PAROL6_VALIDATED};
use sim::client::{configurator_matches, configurator_values, driver_line, driver_view};
use sim::encoder::Line;
use sim::plant::PlantOptions;
use sim::rng::Rng;
use sim::root::{Root, SimPort};

/// The simulator holds the firmware's `Controller` (a compile-time fact:
/// this function only type-checks if it is the same type), and the
/// firmware's target builds the same root with `root::new` and drives it
/// with `Controller::tick`, with no protocol or kernel logic of its own.
#[test]
fn firmware_and_simulator_share_the_root() {
    let root = Root::new(&PAROL6_VALIDATED, PlantOptions::new(&PAROL6), HostConfig::USB);
    let c: &Controller<'static> = root.controller();
    assert_eq!(c.kernel().state(), kernel::State::Boot);
    let target = include_str!("../../firmware/src/target/mod.rs");
    assert!(target.contains("root::new(&PAROL6_VALIDATED, link, HOST_CFG)"), "the image builds firmware::root");
    assert!(target.contains("ctx.controller.tick(&mut ctx.board)"), "the PIT handler runs Controller::tick");
    assert!(target.contains("host.poll(&mut proto, now_ms)"), "the main loop runs Host::poll");
    for logic in ["Receiver", "KernelF32", "FeedbackDivider", "driver_line", "Telemetry", "Debounce", "FrameDecoder"] {
        assert!(!target.contains(logic), "firmware/src/target/mod.rs holds logic again: {logic}");
    }
}

/// A pty-like transport: the firmware writes into a buffer of `cap` bytes;
/// a host empties it when it reads.
#[derive(Clone)]
struct Pipe(Arc<Mutex<VecDeque<u8>>>, usize);

impl Pipe {
    fn new(cap: usize) -> Self {
        Pipe(Arc::new(Mutex::new(VecDeque::new())), cap)
    }
    fn port(&self) -> SimPort {
        let p = self.clone();
        SimPort::with_sink(Box::new(move |b: &[u8]| {
            let mut q = p.0.lock().unwrap();
            let n = b.len().min(p.1.saturating_sub(q.len()));
            q.extend(&b[..n]);
            n
        }))
    }
    /// Takes up to `max` bytes.
    fn read(&self, max: usize) -> Vec<u8> {
        let mut q = self.0.lock().unwrap();
        let n = max.min(q.len());
        q.drain(..n).collect()
    }
}

/// A reader that splits the stream into lines as a host does (a partial
/// line waits for its end).
#[derive(Default)]
struct Lines {
    acc: Vec<u8>,
}

impl Lines {
    fn feed(&mut self, bytes: &[u8]) -> Vec<String> {
        self.acc.extend_from_slice(bytes);
        let mut out = Vec::new();
        while let Some(i) = self.acc.iter().position(|b| *b == b'\n') {
            let l: Vec<u8> = self.acc.drain(..=i).collect();
            out.push(String::from_utf8(l).expect("ASCII output"));
        }
        out
    }
}

/// How long the two-client run lasts (simulated seconds): ten minutes by
/// default (about 10 s of test time), `CLIENTS_SECONDS` to change it.
fn client_seconds() -> u64 {
    std::env::var("CLIENTS_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(600)
}

/// Both clients on the USB build's stream (the live simulator's default):
/// the driver reads every 10 ms (with jitter, and in random-sized chunks so
/// lines are split across reads) and keeps the newest complete line that
/// starts with `<`; the configurator applies its regex to every line after
/// stripping. Neither ever takes a line it would reject.
#[test]
fn both_clients_read_one_stream_without_a_race() {
    let pipe = Pipe::new(4096);
    let mut root = Root::with_port(&PAROL6_VALIDATED, PlantOptions::new(&PAROL6), HostConfig::USB, pipe.port());
    let mut rng = Rng::new(7);
    let (mut driver, mut config) = (Lines::default(), Lines::default());
    let mut pending_driver: VecDeque<u8> = VecDeque::new();
    let (mut driver_reads, mut driver_taken, mut config_taken) = (0u64, 0u64, 0u64);
    let mut rejected: Vec<String> = Vec::new();
    let mut homed_at = None;
    let mut next_read = 10u64;
    let mut seq = 0u32;
    let mut input: Vec<u8> = b"<HOME>\n".to_vec();
    let end_ms = client_seconds() * 1000;
    let mut last_pos = [0.0f64; 6];
    for t in 0..end_ms {
        // The driver streams at 100 Hz once homed: a slow sine about the
        // home pose (inside every joint's limits).
        if let Some(h) = homed_at {
            if t % 10 == 0 {
                let s = ((t - h) as f64 / 1000.0 * 0.5).sin();
                let p: [f64; 6] = std::array::from_fn(|i| last_pos[i] + 0.2 * s);
                input.extend(driver_line(seq, &p, &[0.0; 6]).as_bytes());
                seq = seq.wrapping_add(1);
            }
        }
        let _ = root.step(&std::mem::take(&mut input));
        if t < next_read {
            continue;
        }
        next_read = t + 9 + (rng.uniform() * 3.0) as u64;
        // One read of the port by the host process, in chunks; both client
        // rules see the same bytes.
        let chunk = pipe.read(1 + (rng.uniform() * 4095.0) as usize);
        pending_driver.extend(&chunk);
        let take: Vec<u8> = pending_driver.drain(..).collect();
        driver_reads += 1;
        let lines = driver.feed(&take);
        if let Some(newest) = lines.iter().rev().find(|l| l.starts_with('<')) {
            driver_taken += 1;
            match driver_view(newest) {
                Some(v) => {
                    if homed_at.is_none() && v.homing == Some(2) {
                        homed_at = Some(t);
                        last_pos = v.position;
                    }
                }
                None => rejected.push(format!("driver at {t} ms: {newest:?}")),
            }
        }
        for l in config.feed(&chunk) {
            if configurator_matches(&l) {
                config_taken += 1;
                match configurator_values(&l) {
                    Some(v) if v.len() == 15 && (v[13] == 1.0 || v[13] == 2.0 || v[13] == 3.0) => {}
                    _ => rejected.push(format!("configurator at {t} ms: {l:?}")),
                }
            } else if l.trim_start().starts_with("<ACK") && !l.starts_with("<ACK") {
                rejected.push(format!("an indented ACK line the configurator cannot read at {t} ms: {l:?}"));
            }
        }
    }
    let secs = end_ms as f64 / 1000.0;
    let tx = root.tx_counters();
    println!(
        "two clients, {secs} s simulated: driver took {driver_taken} newest lines in {driver_reads} reads, \
         configurator matched {config_taken} lines ({:.1}/s); homed at {homed_at:?} ms; {} frames streamed; \
         tx queued {} dropped {}; rejected {}",
        config_taken as f64 / secs,
        seq,
        tx.queued,
        tx.dropped,
        rejected.len()
    );
    assert!(rejected.is_empty(), "{} rejected lines, first: {:?}", rejected.len(), &rejected[..rejected.len().min(5)]);
    assert!(homed_at.is_some(), "the driver never saw H2");
    assert!(seq as f64 >= (secs - 20.0) * 100.0 * 0.9, "the driver streamed only {seq} frames");
    // Both clients got their feedback at the USB rate (50 Hz).
    assert!(driver_taken as f64 >= secs * 50.0 * 0.95, "driver feedback missing: {driver_taken}");
    assert!(config_taken as f64 >= secs * 50.0 * 0.95, "configurator feedback missing: {config_taken}");
    assert_eq!(tx.dropped, 0, "a reader at 100 Hz loses nothing");
}

/// 2000 `<ENABLE>` in one write while an encoder is cut, and a host that
/// reads only 200 bytes every 10 ms: the transmit path overflows. Every
/// line that was dropped is counted and reported as `TX_LOST n=..`, the
/// numbers add up exactly, and the FAULT line is never lost.
#[test]
fn a_flood_loses_nothing_silently_and_never_a_fault_line() {
    let pipe = Pipe::new(4096);
    let mut root = Root::with_port(&PAROL6_VALIDATED, PlantOptions::new(&PAROL6), HostConfig::USB, pipe.port());
    let mut lines = Lines::default();
    let mut got: Vec<String> = Vec::new();
    let flood = "<ENABLE>\n".repeat(2000);
    for t in 0..6000u64 {
        let input = if t == 100 { flood.as_bytes() } else { b"" as &[u8] };
        if t == 150 {
            root.plant().set_line(2, Line::StuckLow);
        }
        let _ = root.step(input);
        if t % 10 == 0 {
            // A slow reader during the flood, then one that catches up.
            let max = if t < 3000 { 200 } else { 1 << 20 };
            got.extend(lines.feed(&pipe.read(max)));
        }
    }
    got.extend(lines.feed(&pipe.read(1 << 20)));
    let tx = root.tx_counters();
    let reported: u32 = got
        .iter()
        .filter_map(|l| l.strip_prefix("TX_LOST n="))
        .map(|r| r.split_whitespace().next().unwrap().parse::<u32>().unwrap())
        .sum();
    let reports = got.iter().filter(|l| l.starts_with("TX_LOST")).count() as u32;
    let faults: Vec<&String> = got.iter().filter(|l| l.starts_with("FAULT")).collect();
    let answered = got.iter().filter(|l| l.contains("ENABLE")).count();
    println!(
        "flood: {} lines received ({answered} about ENABLE), {} dropped and reported in {reports} TX_LOST lines, \
         critical dropped {}, faults {:?}",
        got.len(),
        tx.dropped,
        tx.critical_dropped,
        faults
    );
    assert!(tx.dropped > 100, "the flood must overflow the transmit path (dropped {})", tx.dropped);
    assert_eq!(reported, tx.dropped, "every dropped line is reported, exactly");
    assert_eq!(reports, tx.reports);
    assert_eq!(got.len() as u32, tx.queued, "every queued line reached the reader");
    assert_eq!(tx.critical_dropped, 0);
    assert_eq!(faults.len(), 1, "exactly one FAULT line: {faults:?}");
    assert!(faults[0].contains("J3"), "{}", faults[0]);
    // The host that caught up sees the state in the feedback too.
    let last_cfg = got.iter().rev().find_map(|l| configurator_values(l)).unwrap();
    assert_eq!(last_cfg[13], 3.0, "state byte 3 (fault) after the flood");
}
