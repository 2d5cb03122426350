//! The last reset's cause on the wire, on the shipped Serial1 image
//! (evidence kind: **emulated**): the twin's SRC `SRSR` reads `IPP_RESET_B`
//! at power-on and `WDOG3_RST_B` after a watchdog reset it performs; the
//! image decodes it (`hal_imxrt::pure::reset_cause::decode`), clears it,
//! names it in the boot banner (`reset=`) and, after a watchdog reset,
//! latches `FAULT HARDWARE SELF_TEST code=129` until `<ENABLE>`.

mod common;

use common::{lines, run};
use twin::{boot_twin, Twin, MS};

const WATCHDOG_FAULT: &str = "FAULT HARDWARE SELF_TEST code=129";

/// The time (cycles) at which the `n`-th (from 1) line on Serial1 that
/// contains `text` was complete (a reset may cut the line before it short,
/// so a banner can follow a partial line).
fn line_done_at(t: &Twin, text: &str, n: usize) -> Option<u64> {
    let out = &t.board().uart.tx_out;
    let mut line = Vec::new();
    let mut seen = 0;
    for &(at, b) in out {
        if b == b'\n' {
            if line.windows(text.len()).any(|w| w == text.as_bytes()) {
                seen += 1;
                if seen == n {
                    return Some(at);
                }
            }
            line.clear();
        } else {
            line.push(b);
        }
    }
    None
}

/// Power-on: the banner says `reset=POWER_ON` and no fault follows. Then a
/// watchdog reset (the PIT flag raised again right after a tick: the
/// second refresh falls inside the RTWDOG's closed window): the image
/// boots again, its banner says `reset=WATCHDOG`, the watchdog fault line
/// follows, `<HOME>` moves nothing while the fault is latched, and after
/// `<ENABLE>` the arm homes. Fails on an image without the banner field.
#[test]
fn reset_cause_power_on_then_watchdog_in_banner_and_fault_until_enable() {
    let mut t = boot_twin().unwrap();
    run(&mut t, 60);
    let l = lines(&t);
    let banner = l.iter().find(|s| s.starts_with("BOOT PAROL6")).cloned().unwrap_or_default();
    assert!(banner.ends_with(" reset=POWER_ON"), "power-on banner: {l:?}");
    assert!(!l.iter().any(|s| s.starts_with("FAULT")), "fault after power-on: {l:?}");
    assert_eq!(t.stats.watchdog_resets, 0);

    // wait for a tick's refresh, leave the interrupt, then run the tick twice
    let refreshes = t.board().wdog.refreshes;
    while t.board().wdog.refreshes == refreshes || t.board().in_pit {
        let end = t.now() + 500;
        t.run_until(end).unwrap();
    }
    t.board_mut().pit.ch[0].tif = true;
    run(&mut t, 70);
    assert_eq!(t.stats.watchdog_resets, 1, "no watchdog reset");
    let reset_at = t.stats.watchdog_reset_at[0];
    run(&mut t, 200);
    let l = lines(&t);
    let banners: Vec<&String> = l.iter().filter(|s| s.contains("BOOT PAROL6")).collect();
    assert_eq!(banners.len(), 2, "{l:?}");
    assert!(banners[1].ends_with(" reset=WATCHDOG"), "banner after the watchdog reset: {l:?}");
    let second = l.iter().position(|s| s == banners[1]).unwrap_or(l.len());
    assert!(l[second..].iter().any(|s| s == WATCHDOG_FAULT), "no watchdog fault after the reboot: {l:?}");
    let ms = |c: u64| (c - reset_at) as f64 / MS as f64;
    let banner_at = line_done_at(&t, "BOOT PAROL6", 2).map(ms).unwrap_or(f64::NAN);
    let fault_at = line_done_at(&t, WATCHDOG_FAULT, 1).map(ms).unwrap_or(f64::NAN);
    println!("watchdog reset: banner reset=WATCHDOG complete {banner_at:.2} ms, {WATCHDOG_FAULT} {fault_at:.2} ms after the reset");
    assert!(banner_at < 100.0 && fault_at < 100.0, "banner {banner_at} ms, fault {fault_at} ms");

    // latched: <HOME> moves nothing until <ENABLE>
    t.board_mut().serial_send(b"<HOME>\n");
    run(&mut t, 400);
    assert_eq!(t.board().step_pulses(), [0; 6], "STEP pulses with the watchdog fault latched");
    let l = lines(&t);
    assert!(!l.iter().any(|s| s.starts_with("ENABLED")), "{l:?}");
    t.board_mut().serial_send(b"<ENABLE>\n");
    run(&mut t, 450);
    let l = lines(&t);
    assert!(l.iter().any(|s| s.starts_with("ENABLED")), "<ENABLE> refused: {l:?}");
    let faults = l.iter().filter(|s| s.as_str() == WATCHDOG_FAULT).count();
    t.board_mut().serial_send(b"<HOME>\n");
    run(&mut t, 900);
    let l = lines(&t);
    assert!(t.board().step_pulses().iter().any(|&p| p > 0), "no STEP pulse after <ENABLE> and <HOME>: {l:?}");
    assert_eq!(l.iter().filter(|s| s.as_str() == WATCHDOG_FAULT).count(), faults, "the fault came back: {l:?}");
    assert_eq!(t.stats.watchdog_resets, 1, "another reset");
}
