//! Enumeration of the kernel's per-axis functions on this machine
//! (`cargo run -p exhaustive --release`), each sweep labelled with what it
//! covers (docs/spec/evidence.md reserves "exhaustive" for whole domains):
//!
//! - **exhaustive**: every input of the function. Unwrapping (every pair
//!   of 12-bit readings), the HAL's step conversion (every `i32` rate, for
//!   the board's step configuration) and the HAL's frame decode (every
//!   `u16` high time x every period in the accepted range and one beyond
//!   each end; outside it both implementations return at the same first
//!   comparison) are swept whole. The two HAL sweeps compare the tick's
//!   division-free code with the straightforward reference code (tagged HAL, not a
//!   SAFETY.md requirement).
//! - **slice**: one argument of a multi-argument function enumerated
//!   completely (all 2^32 `I8F24` or `f32` bit patterns, NaNs, infinities,
//!   subnormals and both zeros included) with the others fixed, as each
//!   sweep's name says: the limit or gains at each distinct configured value,
//!   the feed-forward and estimate at 0, the observer from rest, the
//!   interpolator's first step with one segment length. A slice is evidence
//!   for that slice only; the rest of the domain is sampled (shim, proptests).
//!
//! A violation prints the first counterexample found and the run exits
//! non-zero.

use kernel::config::{AXES, PAROL6};
use kernel::control::control_law;
use kernel::interp::Interpolator;
use kernel::observer::{wrap_delta, AlphaBeta, ObserverGains, Unwrapper};
use kernel::{Fx, Scalar};
use rayon::prelude::*;
use std::time::Instant;

struct Sweep {
    requirement: &'static str,
    /// `exhaustive` (the whole domain) or `slice` (see the module doc).
    scope: &'static str,
    name: String,
    cases: u64,
    counterexample: Option<String>,
    seconds: f64,
}

/// Runs `prop` on every `u32`; returns the first failing input.
fn all_u32(prop: impl Fn(u32) -> bool + Sync) -> Option<u32> {
    (0..=u32::MAX).into_par_iter().find_any(|b| !prop(*b))
}

fn sweep(
    req: &'static str,
    scope: &'static str,
    name: String,
    cases: u64,
    f: impl FnOnce() -> Option<String>,
) -> Sweep {
    let t = Instant::now();
    let counterexample = f();
    let s = Sweep { requirement: req, scope, name, cases, counterexample, seconds: t.elapsed().as_secs_f64() };
    eprintln!(
        "  {:<6} {:<10} {:<58} {:>14} cases  {:>6.1} s  {}",
        s.requirement,
        s.scope,
        s.name,
        s.cases,
        s.seconds,
        if s.counterexample.is_none() { "holds" } else { "VIOLATED" }
    );
    s
}

/// The distinct values of a per-joint parameter, with the joints using each.
fn distinct(f: impl Fn(usize) -> (f32, f32)) -> Vec<((f32, f32), Vec<usize>)> {
    let mut out: Vec<((f32, f32), Vec<usize>)> = Vec::new();
    for j in 0..AXES {
        let v = f(j);
        match out.iter_mut().find(|(k, _)| *k == v) {
            Some((_, js)) => js.push(j + 1),
            None => out.push((v, vec![j + 1])),
        }
    }
    out
}

fn main() {
    let full = 1u64 << 32;
    let mut results = Vec::new();
    eprintln!("exhaustive sweeps ({} threads)", rayon::current_num_threads());

    // SR-12: unwrapping over every pair of readings.
    results.push(sweep(
        "SR-12",
        "exhaustive",
        "unwrap: every (previous, next) 12-bit reading pair".into(),
        4096 * 4096,
        || {
            (0u32..4096 * 4096)
                .into_par_iter()
                .find_any(|i| {
                    let (a, b) = ((i >> 12) as u16, (i & 0xfff) as u16);
                    let d = wrap_delta(a, b);
                    let mut u = Unwrapper::new(a);
                    u.update(b);
                    !((-2048..=2047).contains(&d)
                        && (i32::from(a) + d).rem_euclid(4096) == i32::from(b)
                        && u.total() == i32::from(a) + d
                        && u.last() == b)
                })
                .map(|i| format!("prev {}, next {}", i >> 12, i & 0xfff))
        },
    ));

    // SR-2, SR-3: saturation, both variants, each distinct max velocity.
    for ((vmax, _), joints) in distinct(|j| (PAROL6.joints[j].max_velocity, 0.0)) {
        let l = Fx::from_f32(vmax);
        results.push(sweep(
            "SR-2",
            "slice",
            format!("saturate I8F24: every x, limit = {vmax} only (J{joints:?})"),
            full,
            || {
                all_u32(|b| {
                    let x = Fx::from_bits(b as i32);
                    let y = x.saturate(l);
                    Scalar::abs(y) <= l && (y == x || (x > l && y == l) || (x < -l && y == -l))
                })
                .map(|b| format!("x bits {b:#010x}"))
            },
        ));
        results.push(sweep(
            "SR-2/3",
            "slice",
            format!("saturate f32: every x bit pattern, limit = {vmax} only (J{joints:?})"),
            full,
            || {
                all_u32(|b| {
                    let x = f32::from_bits(b);
                    let y = x.saturate(vmax);
                    y.is_finite()
                        && y.abs() <= vmax
                        && if !x.is_finite() { y.to_bits() == 0 } else { y == x.clamp(-vmax, vmax) }
                })
                .map(|b| format!("x bits {b:#010x}"))
            },
        ));
    }

    // SR-2, SR-3: control law over every position error.
    for ((kp, vmax), joints) in distinct(|j| (PAROL6.joints[j].kp, PAROL6.joints[j].max_velocity)) {
        let (kpx, vx) = (Fx::from_f32(kp), Fx::from_f32(vmax));
        results.push(sweep(
            "SR-2",
            "slice",
            format!("control law I8F24: every set-point; ff = x = deadband = 0, Kp {kp}, vmax {vmax} (J{joints:?})"),
            full,
            || {
                all_u32(|b| {
                    let sp = Fx::from_bits(b as i32);
                    let (v, ok) = control_law(sp, Fx::ZERO, Fx::ZERO, kpx, vx, Fx::ZERO);
                    // Exactly the saturated law, with the sign of the error.
                    ok && v == kpx.saturating_mul(sp).saturate(vx) && (v >= Fx::ZERO) == (sp >= Fx::ZERO)
                })
                .map(|b| format!("set-point bits {b:#010x}"))
            },
        ));
        results.push(sweep(
            "SR-2/3",
            "slice",
            format!("control law f32: every set-point bit pattern; ff = x = deadband = 0, Kp {kp}, vmax {vmax}"),
            full,
            || {
                all_u32(|b| {
                    let sp = f32::from_bits(b);
                    let (v, ok) = control_law(sp, 0.0, 0.0, kp, vmax, 0.0);
                    // A finite set-point whose Kp * e overflows is absurd: zero, not ok.
                    let sane = sp.is_finite() && (kp * sp).is_finite();
                    v.is_finite() && v.abs() <= vmax && ok == sane && (ok || v.to_bits() == 0)
                })
                .map(|b| format!("set-point bits {b:#010x}"))
            },
        ));
    }

    // SR-18/SR-27: the first set-point step from rest toward every target,
    // for each distinct (speed, acceleration). A slice: the state (set-point,
    // velocity) is fixed at rest at 0 and the cruising speed at vmax.
    // The profile is the kernel's own (`interp::joint_profile`, at the
    // set-point acceleration).
    for ((vmax, amax), joints) in
        distinct(|j| (PAROL6.joints[j].max_velocity, PAROL6.joints[j].setpoint_acceleration()))
    {
        let k = kernel::interp::profile::<Fx>(vmax, amax, PAROL6.tick_hz);
        // `distinct` names joints from 1.
        let same =
            joints.iter().all(|&j| kernel::interp::joint_profile::<Fx>(&PAROL6.joints[j - 1], PAROL6.tick_hz) == k);
        assert!(same, "the sweep's profile is not the kernel's for J{joints:?}");
        let dv = k.dv;
        results.push(sweep(
            "SR-18/27",
            "slice",
            format!(
                "set-point I8F24: first step from rest at 0 toward every target, cruising at vmax {vmax}, amax {amax} (J{joints:?})"
            ),
            full,
            || {
                all_u32(|b| {
                    let target = Fx::from_bits(b as i32);
                    let mut it = Interpolator::hold(Fx::ZERO);
                    it.retarget(target, k.vmax, &k);
                    let (sp, v) = it.advance(&k);
                    let (lo, hi) = (Ord::min(target, Fx::ZERO), Ord::max(target, Fx::ZERO));
                    sp >= lo && sp <= hi && Scalar::abs(v) <= dv.plus(k.eps.times_int(2000)) && (v >= Fx::ZERO) == (target >= Fx::ZERO) || (v == Fx::ZERO && sp == Fx::ZERO)
                })
                .map(|b| format!("target bits {b:#010x}"))
            },
        ));
    }

    // Observer: the corrected estimate lies between prediction and measurement.
    let g = ObserverGains {
        alpha: Fx::from_f32(PAROL6.alpha()),
        beta_hz: Fx::from_f32(PAROL6.beta() * PAROL6.tick_hz as f32),
        dt: Fx::from_f32(1.0 / PAROL6.tick_hz as f32),
    };
    results.push(sweep(
        "SR-3",
        "slice",
        "observer I8F24: one step from rest (x = v = 0), every measurement".into(),
        full,
        || {
            all_u32(|b| {
                let z = Fx::from_bits(b as i32);
                let mut o = AlphaBeta::at(Fx::ZERO);
                o.step(z, &g);
                let (lo, hi) = (Ord::min(z, Fx::ZERO), Ord::max(z, Fx::ZERO));
                o.x >= lo && o.x <= hi && (o.v >= Fx::ZERO) == (z >= Fx::ZERO)
            })
            .map(|b| format!("z bits {b:#010x}"))
        },
    ));

    // The tick's step conversion: `StepPlan::command`, with no 64-bit
    // division, equals the reference conversion for every i32
    // rate, for the board's configuration. Not a safety requirement of
    // SAFETY.md (tagged HAL): the equality that lets the faster code replace
    // the tested one. Rates beyond the maximum are AboveMax in both, decided
    // by the same comparison: the reference is called inside the range.
    {
        use hal_imxrt::pure::step::{reference_step_command, StepConfig, StepPlan, StepRateError};
        let cfg = StepConfig::DEFAULT;
        let plan = StepPlan::DEFAULT;
        results.push(sweep(
            "HAL",
            "exhaustive",
            "step conversion: StepPlan::command == the 64-bit-division reference, every i32 rate (board config)".into(),
            full,
            || {
                all_u32(|b| {
                    let rate = b as i32;
                    let got = plan.command(rate);
                    if rate.unsigned_abs() > cfg.max_rate_mhz {
                        got == Err(StepRateError::AboveMax)
                    } else {
                        got == reference_step_command(rate, &cfg)
                    }
                })
                .map(|b| format!("rate {} mHz", b as i32))
            },
        ));
    }

    // The tick's frame decode: `decode_frame`, on 32-bit
    // arithmetic, equals `decode_window` with the frame config (one u64
    // division) for every u16 high time and every period from one below
    // MIN_PERIOD_CYCLES to one above MAX_PERIOD_CYCLES; outside that range
    // both return WindowTooShort / WindowTooLong at the same first
    // comparison, before any arithmetic. Tagged HAL like the step
    // conversion: the equality that lets the faster code replace the tested
    // one (the decoder's other former 64-bit divisions are checked in
    // hal-imxrt's tests against the kept reference code).
    {
        use hal_imxrt::pure::encoder::decode_window;
        use hal_imxrt::pure::frame::{decode_frame, FRAME_DECODE, MAX_PERIOD_CYCLES, MIN_PERIOD_CYCLES};
        let periods = (MIN_PERIOD_CYCLES - 1)..=(MAX_PERIOD_CYCLES + 1);
        let cases = (periods.end() - periods.start() + 1) as u64 * (1 << 16);
        let differs = |p: u32, h: u16| decode_frame(h, p) != decode_window(h as u32, p, &FRAME_DECODE);
        results.push(sweep(
            "HAL",
            "exhaustive",
            "frame decode: decode_frame == decode_window (u64), every u16 high x period MIN-1..=MAX+1".into(),
            cases,
            || {
                periods.into_par_iter().find_any(|&p| (0..=u16::MAX).any(|h| differs(p, h))).and_then(|p| {
                    (0..=u16::MAX).find(|&h| differs(p, h)).map(|h| format!("period {p} cycles, high {h} ticks"))
                })
            },
        ));
    }

    let failed: Vec<&Sweep> = results.iter().filter(|s| s.counterexample.is_some()).collect();
    let total: u64 = results.iter().map(|s| s.cases).sum();
    let secs: f64 = results.iter().map(|s| s.seconds).sum();
    let whole = results.iter().filter(|s| s.scope == "exhaustive").count();
    println!(
        "enumeration: {} sweeps ({whole} exhaustive over a whole domain, {} slices of a multi-argument domain), {total} cases, {secs:.1} s, {} violated",
        results.len(),
        results.len() - whole,
        failed.len()
    );
    for s in &failed {
        println!("VIOLATED {} {}: {}", s.requirement, s.name, s.counterexample.as_deref().unwrap_or(""));
    }
    if let Ok(dir) = std::env::var("EVIDENCE_DIR") {
        let mut tsv = String::new();
        for s in &results {
            let ok = if s.counterexample.is_none() { "holds" } else { "VIOLATED" };
            tsv.push_str(&format!("{}\t{}\t{}\t{}\t{}\n", s.requirement, s.scope, s.cases, ok, s.name));
        }
        if let Err(e) = std::fs::write(std::path::Path::new(&dir).join("exhaustive.tsv"), tsv) {
            eprintln!("exhaustive: cannot write the evidence file in {dir}: {e}");
            std::process::exit(1);
        }
    }
    if !failed.is_empty() {
        std::process::exit(1);
    }
}
