//! The drivers' enable output (firmware feature `driver-enable`: pin 3,
//! active low to every TMC5160's `DRV_ENN`, pulled up at the drivers) on
//! the image built with it (evidence kind: **emulated**). The twin models
//! the line as the pad's GPIO output when pin 3 is one, else the external
//! pull-up (drivers off), and logs every change with its time.
//!
//! Each path is measured in ticks (PIT handler entries) and microseconds:
//! boot (off until a state that may move), `<HOME>` (on in the tick that
//! starts homing), a latched encoder fault, a panic, a HardFault and a
//! watchdog reset (off). Build the images first: `twin/test.sh` does (or
//! `twin/build-image.sh`).

mod common;

use common::{lines, run};
use twin::{Plant, Twin, MS};

/// A fresh twin running the driver-enable image, the arm at `START_Q`.
fn boot() -> Twin {
    let elf = twin::load_driver_enable_image().unwrap();
    Twin::new(&elf, Plant::new(&kernel::config::PAROL6, twin::START_Q)).unwrap()
}

fn us(cycles: u64) -> f64 {
    cycles as f64 * 1000.0 / MS as f64
}

/// PIT handler entries in `(from, to]`.
fn ticks_between(t: &Twin, from: u64, to: u64) -> usize {
    t.stats.pit_entries.iter().filter(|&&e| e > from && e <= to).count()
}

/// The time of the last change of the enable line, and whether it left the
/// drivers energised.
fn last_change(t: &Twin) -> Option<(u64, bool)> {
    t.board().driver_enable_log.last().copied()
}

/// Boot to 60 ms, send `<HOME>`, run until the drivers are energised (at
/// most 50 ms); returns the time `<HOME>` was sent and the time the line
/// went active.
fn homed(t: &mut Twin) -> (u64, u64) {
    run(t, 60);
    assert!(t.board().driver_enable_log.is_empty(), "energised before <HOME>: {:?}", t.board().driver_enable_log);
    t.board_mut().record_edges();
    t.board_mut().serial_send(b"<HOME>\n");
    let sent = t.now();
    for _ in 0..500 {
        let end = t.now() + MS / 10;
        if let Err(f) = t.run_until(end) {
            panic!("image stopped: {f}");
        }
        if t.board().drivers_energised() {
            break;
        }
    }
    let (at, on) = last_change(t).unwrap_or_else(|| {
        panic!(
            "the line never changed after <HOME>: pin 3 {:?}, pulses {:?}, {:?}",
            t.board().gpio_out(twin::pads::DRIVER_ENABLE_PIN),
            t.board().step_pulses(),
            lines(t)
        )
    });
    assert!(on, "{:?}", t.board().driver_enable_log);
    (sent, at)
}

/// The PIT entry the change at `at` happened in (the latest entry before
/// it) and the microseconds into that tick.
fn in_tick(t: &Twin, at: u64) -> (u64, f64) {
    let entry = t.stats.pit_entries.iter().copied().filter(|&e| e <= at).max().expect("no tick before the change");
    (entry, us(at - entry))
}

/// Boot: pin 3 is configured as an output driven inactive (high) before the
/// first tick and stays inactive through the self-test and the unhomed
/// state. An image without the output leaves the pin an input (the pull-up
/// alone holds the line inactive), so the test also checks that the pin is
/// driven high.
#[test]
fn driver_enable_inactive_from_power_on_until_enabled() {
    let mut t = boot();
    run(&mut t, 100);
    assert!(t.board().driver_enable_log.is_empty(), "{:?}", t.board().driver_enable_log);
    assert_eq!(t.board().gpio_out(twin::pads::DRIVER_ENABLE_PIN), Some(true), "pin 3 not driven inactive");
    let l = lines(&t);
    assert!(l.iter().any(|s| s.contains("BOOT PAROL6")), "{l:?}");
    println!("boot: drivers off for 100 ms ({} ticks), pin 3 driven high", t.stats.pit_calls);
}

/// `<HOME>` (a state that may move): the line goes active inside the tick
/// that starts homing, before that tick's first STEP edge.
#[test]
fn driver_enable_active_in_the_tick_homing_starts() {
    let mut t = boot();
    let (sent, at) = homed(&mut t);
    let (entry, into) = in_tick(&t, at);
    let ticks = ticks_between(&t, sent, at);
    run(&mut t, 200);
    assert!(t.board().drivers_energised(), "homing, drivers off: {:?}", t.board().driver_enable_log);
    assert_eq!(t.board().driver_enable_log.len(), 1, "{:?}", t.board().driver_enable_log);
    let first_step = (0..6).filter_map(|i| t.board().step_rises(i).first().copied()).min().expect("no STEP edge");
    println!(
        "<HOME> sent at {:.3} ms: drivers energised {:.3} ms later, in tick {ticks} after it, {into:.2} us into that tick; first STEP edge {:.1} us after the enable",
        us(sent) / 1000.0,
        us(at - sent) / 1000.0,
        us(first_step.saturating_sub(at))
    );
    assert!(into < 1000.0, "outside its tick: {into} us");
    assert!(entry > sent);
    assert!(first_step >= at, "STEP edge {:.3} us before the drivers were enabled", us(at - first_step));
}

/// A latched fault (J1's encoder cut while homing): the line goes inactive
/// in the tick whose kernel step latches the fault; the `FAULT` line that
/// tick queued follows on Serial1 from the main loop right after it.
#[test]
fn driver_enable_inactive_in_the_tick_a_fault_latches() {
    let mut t = boot();
    homed(&mut t);
    run(&mut t, 160);
    assert!(t.board().drivers_energised());
    let serial_before = t.board().uart.tx_out.len();
    let cut = t.now();
    t.board_mut().plant.joints[0].encoder_cut = true;
    run(&mut t, 400);
    let (at, on) = last_change(&t).unwrap();
    assert!(!on, "{:?}", t.board().driver_enable_log);
    assert!(at > cut);
    let (_, into) = in_tick(&t, at);
    // the first byte of the FAULT line on Serial1
    let sent: Vec<(u64, u8)> = t.board().uart.tx_out[serial_before..].to_vec();
    let bytes: Vec<u8> = sent.iter().map(|&(_, b)| b).collect();
    let at_fault = bytes.windows(6).position(|w| w == b"FAULT ").map(|i| sent[i].0).expect("no FAULT line");
    let l = lines(&t);
    let fault = l.iter().find(|s| s.starts_with("FAULT")).cloned();
    println!(
        "J1 encoder cut: drivers off {:.3} ms ({} ticks) after the cut, {into:.2} us into its tick; {fault:?} begins {:.1} us after the change",
        us(at - cut) / 1000.0,
        ticks_between(&t, cut, at),
        us(at_fault.saturating_sub(at))
    );
    assert!(into < 1000.0);
    assert!(at_fault > at, "the FAULT line began before the drivers went off");
    let steps = t.board().step_pulses();
    run(&mut t, 450);
    assert_eq!(t.board().step_pulses(), steps, "STEP pulses with the drivers off");
    assert!(!t.board().drivers_energised());
}

/// Runs `ms` after a fatal event and checks the line went inactive at once
/// (within `max_us` of `from`) and stayed so through the watchdog reset and
/// the next boot.
fn assert_off_after(t: &mut Twin, from: u64, what: &str, max_us: f64) {
    let end = t.now() / MS + 100;
    run(t, end);
    let log = &t.board().driver_enable_log;
    let off = log.iter().find(|&&(c, on)| c >= from && !on).map(|&(c, _)| c);
    let Some(off) = off else { panic!("{what}: the drivers stayed energised: {log:?}") };
    let again = log.iter().any(|&(c, on)| c > off && on);
    println!(
        "{what}: drivers off {:.2} us after it; watchdog resets since: {}; energised again within 100 ms: {again}",
        us(off - from),
        t.stats.watchdog_resets
    );
    assert!(us(off - from) <= max_us, "{what}: off {} us after", us(off - from));
    assert!(!again, "{what}: energised again after the fatal stop (reboot): {log:?}");
    assert!(!t.board().drivers_energised());
}

/// The panic handler (as an `unwrap` on `None` reaches it): the line goes
/// inactive in the fatal stop, before the watchdog reset; the next boot
/// keeps it inactive (the panic is a latched boot fault).
#[test]
fn driver_enable_inactive_on_panic() {
    let mut t = boot();
    homed(&mut t);
    run(&mut t, 160);
    assert!(t.board().drivers_energised());
    let name = t
        .image
        .symbols
        .keys()
        .find(|n| n.ends_with("9panicking5panic") || n.contains("9panicking5panic17h"))
        .cloned()
        .expect("panic symbol");
    let at = t.now();
    t.call_symbol(&name, &[0x2000_0000, 4, 0x2000_0000]).unwrap();
    assert_off_after(&mut t, at, "panic", 5.0);
}

/// A HardFault (vector 3, entered as the core would): the same fatal stop.
#[test]
fn driver_enable_inactive_on_hardfault() {
    let mut t = boot();
    homed(&mut t);
    run(&mut t, 160);
    assert!(t.board().drivers_energised());
    let at = t.now();
    t.take_exception(3).unwrap();
    assert_off_after(&mut t, at, "HardFault", 5.0);
}

/// A watchdog reset (the tick stalls while homing: its interrupt disabled):
/// nothing in the image runs to switch the line off, so the drivers stay
/// energised until the reset, which returns pin 3 to an input and the
/// pull-up switches them off; the next boot keeps them off (watchdog reset
/// is a boot fault).
#[test]
fn driver_enable_inactive_after_a_watchdog_reset() {
    let mut t = boot();
    homed(&mut t);
    run(&mut t, 160);
    assert!(t.board().drivers_energised());
    t.board_mut().nvic_en = [0; 8];
    let stall = t.now();
    run(&mut t, 400);
    assert_eq!(t.stats.watchdog_resets, 1);
    let reset = t.stats.watchdog_reset_at[0];
    let log = t.board().driver_enable_log.clone();
    let off = log.iter().find(|&&(c, on)| c >= stall && !on).map(|&(c, _)| c).expect("never off");
    println!(
        "tick stalled: watchdog reset {:.3} ms later, drivers off {:.1} us after the reset; energised again: {}",
        us(reset - stall) / 1000.0,
        us(off - reset),
        log.iter().any(|&(c, on)| c > off && on)
    );
    assert_eq!(off, reset, "{log:?}");
    assert!(!log.iter().any(|&(c, on)| c > off && on), "{log:?}");
    let l = lines(&t);
    assert!(l.iter().any(|s| s == "FAULT HARDWARE SELF_TEST code=129"), "{l:?}");
}

/// The default image (no `driver-enable` feature) never drives pin 3: the
/// line is the pull-up's through boot and homing.
#[test]
fn driver_enable_default_image_leaves_pin_3_alone() {
    let mut t = twin::boot_twin().unwrap();
    homed_default(&mut t);
    assert_eq!(t.board().gpio_out(twin::pads::DRIVER_ENABLE_PIN), None);
    assert!(t.board().driver_enable_log.is_empty(), "{:?}", t.board().driver_enable_log);
    assert!(t.board().step_pulses()[5] > 0, "J6 did not home");
}

fn homed_default(t: &mut Twin) {
    run(t, 60);
    t.board_mut().serial_send(b"<HOME>\n");
    run(t, 200);
}
