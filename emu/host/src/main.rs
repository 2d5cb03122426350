//! Host side of the emulator evidence.
//!
//! ```text
//! emu-host record  DIR            record scenario_f32.bin / scenario_fx.bin
//! emu-host replay  DIR            print the trace the target must print
//! emu-host analyze DIR COUNTS     instruction-count statistics (markdown)
//! emu-host stream-range DIR       tick indices of the streamed trajectory
//! ```
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use emu_common::{encode_tick, header, replay, Bits, Hooks, Reader};
use kernel::config::{ArmConfig, Direction, Validated, AXES, PAROL6_VALIDATED};
use kernel::homing::Phase;
use kernel::{EncoderSample, Fx, HardwareFault, Kernel, Sense, State};
use protocol::{DialectLock, Parser};

const TAU: f64 = std::f64::consts::TAU;
const COUNTS_PER_REV: f64 = kernel::config::COUNTS_PER_REV as f64;
/// Power-on encoder offsets (arbitrary, as in proofs/src/setup.rs).
const OFFSET: [f64; AXES] = [1000.0, 2000.0, 3000.0, 500.0, 1500.0, 2500.0];

/// A rigid arm: every joint moves exactly as its step rate says, encoders
/// are ideal 12-bit readings of the motor-side angle, and each limit switch
/// is closed at and beyond its configured switch position.
struct Plant {
    q: [f64; AXES],
    cfg: ArmConfig,
}

impl Plant {
    fn new(cfg: &ArmConfig) -> Self {
        // Start 0.03 rad inside each switch, so homing is short.
        let q = std::array::from_fn(|i| {
            let h = &cfg.joints[i].homing;
            f64::from(h.switch_position) - f64::from(h.direction.sign()) * 0.03
        });
        Plant { q, cfg: *cfg }
    }
    fn sense(&self) -> Sense {
        let mut limits = 0u8;
        let mut encoders = [EncoderSample::Lost; AXES];
        for i in 0..AXES {
            let j = &self.cfg.joints[i];
            let motor = self.q[i] * f64::from(j.gear_ratio);
            let c = (motor / TAU * COUNTS_PER_REV + OFFSET[i]).floor().rem_euclid(COUNTS_PER_REV);
            encoders[i] = EncoderSample::Count(c as u16);
            let sw = f64::from(j.homing.switch_position);
            let closed = match j.homing.direction {
                Direction::Negative => self.q[i] <= sw,
                Direction::Positive => self.q[i] >= sw,
            };
            if closed {
                limits |= 1 << i;
            }
        }
        Sense { encoders, limits, hardware_fault: None, link_lost: false }
    }
    fn apply(&mut self, step_rate: &[i32; AXES]) {
        let dt = 1.0 / f64::from(self.cfg.tick_hz);
        for ((q, j), rate) in self.q.iter_mut().zip(self.cfg.joints.iter()).zip(step_rate.iter()) {
            let dir = if j.motor_reversed { -1.0 } else { 1.0 };
            *q += dir * f64::from(*rate) / j.steps_per_rad() * dt;
        }
    }
}

fn driver_frame(seq: u32, p: &[f64; AXES], v: &[f64; AXES]) -> String {
    let mut s = format!("<{seq}");
    for i in 0..AXES {
        write!(s, ",{:.3},{:.3}", p[i], v[i]).unwrap();
    }
    s.push('>');
    s
}

/// Runs the scripted session closed-loop against the plant and records every
/// tick's inputs. The script: boot; a motion frame while unhomed (refused);
/// HOME; homing to completion (the plant's switches close physically, as
/// `proofs/src/setup.rs::run_homing` closes them by hand); a 1.5 s streamed
/// trajectory with one lost encoder sample and one malformed frame; silence
/// (timeout soft stop, ramp, latched); ENABLE; a 0.3 s stream holding
/// position; a hardware fault (tick overrun); ENABLE; idle.
fn record<S: Bits>(v: &Validated) -> (Vec<u8>, u32, Vec<State>) {
    let cfg = v.config();
    let (mut k, authority) = Kernel::<S>::new(v);
    let parser = Parser::<S>::new(v, DialectLock::Auto);
    let mut plant = Plant::new(cfg);
    let mut body = Vec::new();
    let mut ticks = 0u32;
    let mut states = Vec::new();
    let mut last_pos = [0.0f64; AXES];
    let mut step = |k: &mut Kernel<S>, plant: &mut Plant, frame: Option<String>, tweak: &dyn Fn(&mut Sense)| {
        let mut sense = plant.sense();
        tweak(&mut sense);
        let fb = frame.as_ref().map(|f| f.as_bytes());
        encode_tick(&mut body, &sense, fb);
        let req = fb.and_then(|f| parser.parse(f).ok()).map(|c| c.into_request(&authority));
        let out = k.tick(&sense, req);
        plant.apply(&out.act.step_rate);
        ticks += 1;
        if states.last() != Some(&out.status.state) {
            states.push(out.status.state);
        }
        out.status.position.map(|x| f64::from(x.to_f32()))
    };
    let none = |_: &mut Sense| {};
    for n in 0..10 {
        let f = match n {
            3 => Some(driver_frame(1, &[0.0; AXES], &[0.0; AXES])),
            5 => Some("<HOME>".to_string()),
            _ => None,
        };
        last_pos = step(&mut k, &mut plant, f, &none);
    }
    let mut guard = 0;
    while k.state() == State::Homing && guard < 60_000 {
        last_pos = step(&mut k, &mut plant, None, &none);
        guard += 1;
    }
    assert_eq!(k.state(), State::Operational, "homing did not finish");
    assert!(k.homing_phases().iter().all(|p| *p == Phase::Done || *p == Phase::Idle));
    for _ in 0..SETTLE_TICKS {
        last_pos = step(&mut k, &mut plant, None, &none);
    }
    // Streamed trajectory: every joint goes 0.2 rad toward the middle of its
    // range and back (raised cosine over 1.5 s), a frame every 10 ms.
    let p0 = last_pos;
    let sign: [f64; AXES] = std::array::from_fn(|i| -f64::from(cfg.joints[i].homing.direction.sign()));
    let (amp, period, every) = (0.2f64, 1.5f64, 10u32);
    let mut seq = 2u32;
    let n_stream = (period * 1000.0) as u32;
    for n in 0..n_stream {
        let frame = if n % every == 0 {
            let t = f64::from(n + every) / 1000.0;
            let ph = TAU * t / period;
            let p: [f64; AXES] = std::array::from_fn(|i| p0[i] + sign[i] * amp * (1.0 - ph.cos()) / 2.0);
            let v: [f64; AXES] = std::array::from_fn(|i| sign[i] * amp * std::f64::consts::PI / period * ph.sin());
            seq += 1;
            let mut f = driver_frame(seq, &p, &v);
            if n == 700 {
                // A malformed frame: one number with 4 decimals (mixed dialect).
                f = f.replacen('.', ".0", 1);
            }
            Some(f)
        } else {
            None
        };
        let lost = |s: &mut Sense| s.encoders[2] = EncoderSample::Lost;
        last_pos = step(&mut k, &mut plant, frame, if n == 555 { &lost } else { &none });
    }
    // A last sample 0.12 rad ahead of the previous one (inside the
    // sample-to-sample continuity bound, SAFETY.md SR-30), then silence: the
    // set-point still travels toward it when the command timeout expires, so
    // the timeout starts the soft-stop ramp and latches (a stream whose
    // set-points are at rest on their targets holds instead, SR-29).
    seq += 1;
    let ahead: [f64; AXES] = std::array::from_fn(|i| p0[i] + sign[i] * 0.12);
    step(&mut k, &mut plant, Some(driver_frame(seq, &ahead, &[0.0; AXES])), &none);
    // Silence: command timeout, soft-stop ramp, latched soft E-stop.
    for _ in 0..300 {
        last_pos = step(&mut k, &mut plant, None, &none);
    }
    assert_eq!(k.state(), State::SoftEstop);
    step(&mut k, &mut plant, Some("<ENABLE>".into()), &none);
    let hold = last_pos;
    for n in 0..300u32 {
        let f = (n % every == 0).then(|| {
            seq += 1;
            driver_frame(seq, &hold, &[0.0; AXES])
        });
        last_pos = step(&mut k, &mut plant, f, &none);
    }
    let overrun = |s: &mut Sense| s.hardware_fault = Some(HardwareFault::TickOverrun);
    step(&mut k, &mut plant, None, &overrun);
    assert_eq!(k.state(), State::Fault);
    for _ in 0..20 {
        step(&mut k, &mut plant, None, &none);
    }
    step(&mut k, &mut plant, Some("<ENABLE>".into()), &none);
    for _ in 0..50 {
        last_pos = step(&mut k, &mut plant, None, &none);
    }
    let _ = last_pos;
    assert_eq!(states, SCENARIO_PATH, "the scenario script no longer runs as labelled");
    let mut data = header(ticks).to_vec();
    data.extend(body);
    (data, ticks, states)
}

/// The states the scenario goes through, in order (each entry a run of one
/// or more ticks): what `record` scripts and what the benchmark's rows are
/// labelled with. `replay` fails when the committed recording no longer
/// follows it (a kernel change made the open-loop replay diverge: re-record
/// with emu/record.sh), so the figures are never about a different run.
const SCENARIO_PATH: [State; 8] = [
    State::Unhomed,
    State::Homing,
    State::Operational,
    State::Stopping,
    State::SoftEstop,
    State::Operational,
    State::Fault,
    State::Operational,
];

/// Ticks at rest between the end of homing and the stream's first frame.
const SETTLE_TICKS: usize = 20;

/// The runs of equal consecutive states.
fn state_runs(states: &[State]) -> Vec<State> {
    let mut runs: Vec<State> = Vec::new();
    for s in states {
        if runs.last() != Some(s) {
            runs.push(*s);
        }
    }
    runs
}

/// The ticks of the streamed trajectory: the first Operational run (after
/// homing, until the command timeout starts the soft stop), less the tick
/// that ended homing and the [`SETTLE_TICKS`] at rest before the stream's
/// first frame.
fn stream_range(states: &[State]) -> std::ops::Range<usize> {
    let first_op = states.iter().position(|s| *s == State::Operational).unwrap_or(0);
    let op_len = states[first_op..].iter().take_while(|s| **s == State::Operational).count();
    first_op + 1 + SETTLE_TICKS..first_op + op_len
}

/// Fails unless the replayed states follow [`SCENARIO_PATH`].
fn check_path(var: &str, states: &[State]) -> Result<(), String> {
    let runs = state_runs(states);
    if runs != SCENARIO_PATH {
        return Err(format!(
            "{var}: the recorded scenario no longer follows its script: replayed states {runs:?}, \
             expected {SCENARIO_PATH:?} (the kernel's behaviour changed; re-record with emu/record.sh)"
        ));
    }
    Ok(())
}

fn scenario_path(dir: &Path, name: &str) -> PathBuf {
    dir.join(format!("scenario_{name}.bin"))
}

struct Print(String);
impl Hooks for Print {
    fn line(&mut self, text: &str) {
        self.0.push_str(text);
        self.0.push('\n');
    }
}

fn run(args: &[String]) -> Result<(), String> {
    let cmd = args.first().map(String::as_str).unwrap_or("");
    let dir = PathBuf::from(args.get(1).cloned().unwrap_or_else(|| "emu/data".into()));
    match cmd {
        "record" => {
            std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
            for (name, (data, ticks, states)) in
                [("f32", record::<f32>(&PAROL6_VALIDATED)), (<Fx as Bits>::NAME, record::<Fx>(&PAROL6_VALIDATED))]
            {
                let path = scenario_path(&dir, name);
                std::fs::write(&path, &data).map_err(|e| format!("{}: {e}", path.display()))?;
                eprintln!("{}: {} ticks, {} bytes, states {:?}", path.display(), ticks, data.len(), states);
            }
            Ok(())
        }
        "replay" => {
            let mut p = Print(String::new());
            let f32s = read(&scenario_path(&dir, "f32"))?;
            let fxs = read(&scenario_path(&dir, "fx"))?;
            replay::<f32, _>(&PAROL6_VALIDATED, &f32s, &mut p).map_err(|e| format!("{e:?}"))?;
            replay::<Fx, _>(&PAROL6_VALIDATED, &fxs, &mut p).map_err(|e| format!("{e:?}"))?;
            check_path("f32", &classify::<f32>(&f32s)?.0)?;
            check_path("fx", &classify::<Fx>(&fxs)?.0)?;
            print!("{}", p.0);
            Ok(())
        }
        "stream-range" => {
            // The tick indices FROM TO (TO exclusive) of the streamed
            // trajectory, for count.c's prof=FILE:NAME:FROM:TO.
            let (states, _) = classify::<f32>(&read(&scenario_path(&dir, "f32"))?)?;
            check_path("f32", &states)?;
            let r = stream_range(&states);
            println!("{} {}", r.start, r.end);
            Ok(())
        }
        "analyze" => {
            let counts = args.get(2).ok_or("analyze DIR COUNTS")?;
            analyze(&dir, Path::new(counts))
        }
        _ => Err("usage: emu-host record|replay|stream-range DIR | analyze DIR COUNTS".into()),
    }
}

fn read(p: &Path) -> Result<Vec<u8>, String> {
    std::fs::read(p).map_err(|e| format!("{}: {e}", p.display()))
}

/// Frames of a scenario in order: (length in bytes, is a motion frame).
fn frames(data: &[u8]) -> Result<Vec<(usize, bool)>, String> {
    let mut rd = Reader::new(data).map_err(|e| format!("{e:?}"))?;
    let mut v = Vec::new();
    while let Some(t) = rd.next_tick().map_err(|e| format!("{e:?}"))? {
        if let Some(f) = t.frame {
            v.push((f.len(), f.get(1).is_some_and(u8::is_ascii_digit)));
        }
    }
    Ok(v)
}

/// Replays a scenario on the host: the state after each tick, and for each
/// frame whether the parser accepted it as a motion frame.
fn classify<S: Bits>(data: &[u8]) -> Result<(Vec<State>, Vec<bool>), String> {
    let mut rd = Reader::new(data).map_err(|e| format!("{e:?}"))?;
    let (mut k, authority) = Kernel::<S>::new(&PAROL6_VALIDATED);
    let parser = Parser::<S>::new(&PAROL6_VALIDATED, DialectLock::Auto);
    let (mut states, mut motion_ok) = (Vec::new(), Vec::new());
    while let Some(t) = rd.next_tick().map_err(|e| format!("{e:?}"))? {
        let req = t.frame.and_then(|f| {
            let r = parser.parse(f);
            motion_ok.push(matches!(r, Ok(protocol::Command::Motion { .. })));
            r.ok().map(|c| c.into_request(&authority))
        });
        states.push(k.tick(&t.sense, req).status.state);
    }
    Ok((states, motion_ok))
}

#[derive(Debug)]
struct Stats {
    n: usize,
    min: u64,
    median: u64,
    max: u64,
    mean: f64,
}

fn stats(v: &[u64]) -> Option<Stats> {
    if v.is_empty() {
        return None;
    }
    let mut s = v.to_vec();
    s.sort_unstable();
    let mean = s.iter().sum::<u64>() as f64 / s.len() as f64;
    Some(Stats { n: s.len(), min: s[0], median: s[s.len() / 2], max: s[s.len() - 1], mean })
}

/// Reads the plugin's output (`CHANNEL COUNT` per line, in execution order),
/// subtracts the marker overhead measured by the empty `cal` channel and
/// prints markdown tables.
fn analyze(dir: &Path, counts: &Path) -> Result<(), String> {
    let text = std::fs::read_to_string(counts).map_err(|e| format!("{}: {e}", counts.display()))?;
    let mut ch: std::collections::BTreeMap<&str, Vec<u64>> = Default::default();
    for l in text.lines() {
        let mut it = l.split_whitespace();
        if let (Some(c), Some(n)) = (it.next(), it.next()) {
            ch.entry(c).or_default().push(n.parse().map_err(|_| format!("bad line {l:?}"))?);
        }
    }
    let cal = ch.get("cal").and_then(|v| stats(v)).ok_or("no cal samples")?;
    if cal.min != cal.max {
        return Err(format!("marker overhead not constant: {cal:?}"));
    }
    let ovh = cal.min;
    let f32s = read(&scenario_path(dir, "f32"))?;
    let fxs = read(&scenario_path(dir, "fx"))?;
    let mut out = String::new();
    writeln!(out, "Marker overhead (empty measured region): {ovh} instructions, subtracted below.\n").unwrap();
    writeln!(out, "| measured | variant | samples | min | median | max | max/min | mean |").unwrap();
    writeln!(out, "|---|---|---:|---:|---:|---:|---:|---:|").unwrap();
    let row = |out: &mut String, what: &str, var: &str, v: &[u64]| {
        let net: Vec<u64> = v.iter().map(|x| x.saturating_sub(ovh)).collect();
        if let Some(s) = stats(&net) {
            writeln!(
                out,
                "| {what} | {var} | {} | {} | {} | {} | {:.2} | {:.0} |",
                s.n,
                s.min,
                s.median,
                s.max,
                s.max as f64 / s.min.max(1) as f64,
                s.mean
            )
            .unwrap();
        }
    };
    let mut per_byte = String::new();
    let mut per_state = String::new();
    for (var, data) in [("f32", &f32s), ("fx", &fxs)] {
        let ticks = ch.get(format!("tick_{var}").as_str()).cloned().unwrap_or_default();
        let n_ticks = Reader::new(data).map_err(|e| format!("{e:?}"))?.ticks as usize;
        if ticks.len() != n_ticks {
            return Err(format!("{var}: {} tick samples, scenario has {n_ticks} ticks", ticks.len()));
        }
        let (states, motion_ok) = if var == "f32" { classify::<f32>(data)? } else { classify::<Fx>(data)? };
        check_path(var, &states)?;
        row(&mut out, "full six-axis tick, whole scenario", var, &ticks);
        let stream = ticks.get(stream_range(&states)).unwrap_or(&[]);
        row(&mut out, "tick while following the stream (1.5 s, a frame every 10 ms)", var, stream);
        let mut seen: Vec<State> = Vec::new();
        for s in &states {
            if !seen.contains(s) {
                seen.push(*s);
            }
        }
        for st in seen {
            let v: Vec<u64> = ticks.iter().zip(&states).filter(|(_, s)| **s == st).map(|(c, _)| *c).collect();
            row(&mut per_state, &format!("tick ending in {st:?}"), var, &v);
        }
        let parses = ch.get(format!("parse_{var}").as_str()).cloned().unwrap_or_default();
        let fr = frames(data)?;
        if parses.len() != fr.len() || motion_ok.len() != fr.len() {
            return Err(format!("{var}: {} parse samples, scenario has {} frames", parses.len(), fr.len()));
        }
        let motion: Vec<(u64, usize)> = parses
            .iter()
            .zip(&fr)
            .zip(&motion_ok)
            .filter(|(_, ok)| **ok)
            .map(|((c, f), _)| (c.saturating_sub(ovh), f.0))
            .collect();
        let rejected: Vec<u64> =
            parses.iter().zip(&fr).zip(&motion_ok).filter(|((_, f), ok)| f.1 && !**ok).map(|((c, _), _)| *c).collect();
        row(&mut out, "parse one accepted driver motion frame", var, &motion.iter().map(|m| m.0).collect::<Vec<_>>());
        row(&mut out, "parse one rejected motion frame", var, &rejected);
        let bytes: usize = motion.iter().map(|m| m.1).sum();
        let instr: u64 = motion.iter().map(|m| m.0).sum();
        let (lmin, lmax) =
            (motion.iter().map(|m| m.1).min().unwrap_or(0), motion.iter().map(|m| m.1).max().unwrap_or(0));
        let ppb: Vec<f64> = motion.iter().map(|m| m.0 as f64 / m.1 as f64).collect();
        let pmin = ppb.iter().cloned().fold(f64::INFINITY, f64::min);
        let pmax = ppb.iter().cloned().fold(0.0, f64::max);
        writeln!(
            per_byte,
            "| {var} | {} | {lmin}..{lmax} | {:.1} | {:.1} | {pmin:.1} | {pmax:.1} |",
            motion.len(),
            bytes as f64 / motion.len().max(1) as f64,
            instr as f64 / bytes.max(1) as f64
        )
        .unwrap();
    }
    writeln!(out, "\nTick cost by the state the tick ends in:\n").unwrap();
    writeln!(out, "| measured | variant | samples | min | median | max | max/min | mean |").unwrap();
    writeln!(out, "|---|---|---:|---:|---:|---:|---:|---:|").unwrap();
    out.push_str(&per_state);
    writeln!(
        out,
        "\nParser cost per byte (accepted driver motion frames of the scenario, marker overhead subtracted):\n"
    )
    .unwrap();
    writeln!(out, "| variant | frames | bytes per frame | mean bytes | instructions per byte (total/total) | min per frame | max per frame |").unwrap();
    writeln!(out, "|---|---:|---|---:|---:|---:|---:|").unwrap();
    out.push_str(&per_byte);
    print!("{out}");
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("emu-host: {e}");
            ExitCode::FAILURE
        }
    }
}
