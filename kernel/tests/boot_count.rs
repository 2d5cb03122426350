//! The kernel keeps its count of Boot ticks (toward the boot timeout) after
//! Boot, and its `Hash` includes it, but nothing reads it there: two kernels
//! whose boots lasted one and three ticks, otherwise alike, behave alike on
//! every input sequence. The model check (`proofs/model/src/boot.rs`)
//! merges such states on this fact; the source argument (the count is read
//! only in the boot step while the mode is Boot, and no transition enters
//! Boot again) is what makes it hold on every sequence; this test checks
//! the consequence on every sequence of up to three ticks drawn from nine
//! inputs, from the end of Boot and after 300 ticks of a fixed
//! pseudo-random input stream.

use kernel::config::{AXES, PAROL6_VALIDATED};
use kernel::{EncoderSample, Fx, HardwareFault, Kernel, MotionKind, MotionTarget, Request, Sense, State};

const COUNTS: [u16; AXES] = [1000, 2000, 3000, 500, 1500, 1000];

fn sense(input: u8) -> Sense {
    let mut s = Sense { encoders: COUNTS.map(EncoderSample::Count), limits: 0, hardware_fault: None, link_lost: false };
    match input {
        1 => s.encoders[0] = EncoderSample::Lost,
        2 => s.limits = 1,
        3 => s.hardware_fault = Some(HardwareFault::TickOverrun),
        4 => s.encoders[0] = EncoderSample::Count(COUNTS[0] + 1500),
        5 => s.link_lost = true,
        _ => {}
    }
    s
}

/// Input `i`: a sensor perturbation (inputs 0..=5, no request) or a
/// request on still sensors (6: `<HOME>`, 7: `<ENABLE>`, 8: a motion to the
/// readings' angles).
fn tick(k: &mut Kernel<Fx>, auth: &kernel::Authority, i: u8) -> kernel::TickOutput<Fx> {
    let req = match i {
        6 => Some(Request::Home),
        7 => Some(Request::Enable(auth.enable())),
        8 => Some(Request::Motion(MotionTarget {
            position: k.status(0).position,
            velocity: [Fx::ZERO; AXES],
            kind: MotionKind::Stream,
        })),
        _ => None,
    };
    k.tick(&sense(if i >= 6 { 0 } else { i }), req)
}

/// The `Debug` text without the values of `tick` (the counter, the
/// fault's timestamp and the status's tick: labels only) and `boot_ticks`.
fn without_counters(k: &impl core::fmt::Debug) -> String {
    let text = format!("{k:?}");
    let mut out = String::new();
    let mut rest = text.as_str();
    while let Some(i) = rest.find("tick") {
        let before = &rest[..i];
        out.push_str(before);
        let after = &rest[i..];
        let whole = !before.ends_with(|c: char| c.is_alphanumeric() || c == '_');
        let key = if whole && after.starts_with("tick: ") {
            Some("tick: ")
        } else if out.ends_with("boot_") && after.starts_with("ticks: ") {
            Some("ticks: ")
        } else {
            None
        };
        match key {
            Some(k) => {
                out.push_str(k);
                rest = after[k.len()..].trim_start_matches(|c: char| c.is_ascii_digit());
            }
            None => {
                out.push_str("tick");
                rest = &after[4..];
            }
        }
    }
    out.push_str(rest);
    out
}

/// Every sequence of up to `depth` inputs from `a` and `b` gives outputs
/// (actuation, status, events) and kernels equal but for the two counters; returns how many
/// sequences were compared.
fn alike(a: &Kernel<Fx>, b: &Kernel<Fx>, auth: &kernel::Authority, depth: u32) -> usize {
    assert_eq!(without_counters(a), without_counters(b));
    if depth == 0 {
        return 1;
    }
    let mut n = 1;
    for i in 0..9 {
        let (mut a, mut b) = (a.clone(), b.clone());
        let (x, y) = (tick(&mut a, auth, i), tick(&mut b, auth, i));
        assert_eq!(without_counters(&x), without_counters(&y), "input {i}");
        n += alike(&a, &b, auth, depth - 1);
    }
    n
}

#[test]
fn the_boot_count_is_forgotten_after_boot() {
    let (k0, auth) = Kernel::<Fx>::new(&PAROL6_VALIDATED);
    // A boot of one tick, and one of three (J1's encoder lost twice).
    let mut short = k0.clone();
    tick(&mut short, &auth, 0);
    let mut long = k0.clone();
    for i in [1, 1, 0] {
        tick(&mut long, &auth, i);
    }
    assert_eq!((short.state(), long.state()), (State::Unhomed, State::Unhomed));
    // The count is there, and differs: the kernels' `Debug` texts differ.
    assert!(format!("{long:?}").contains("boot_ticks: 2"), "{long:?}");
    assert_ne!(format!("{short:?}"), format!("{long:?}"));
    let mut compared = alike(&short, &long, &auth, 3);
    // And after a fixed pseudo-random stream of inputs (a linear
    // congruential generator), on whatever state it reaches.
    let mut x: u32 = 12345;
    for _ in 0..300 {
        x = x.wrapping_mul(1_103_515_245).wrapping_add(12_345);
        let i = ((x >> 16) % 9) as u8;
        let (x, y) = (tick(&mut short, &auth, i), tick(&mut long, &auth, i));
        assert_eq!(without_counters(&x), without_counters(&y));
    }
    compared += alike(&short, &long, &auth, 3);
    // 1 + 9 + 81 + 729 sequences (of up to three ticks) from each start.
    assert_eq!(compared, 2 * 820);
}
