//! The boot RAM test on the shipped Serial1 image (evidence kind:
//! **emulated**): a cell of the memory that will hold the tick's state
//! (`TICK_CTX`) or the main loop's (`HOST`) stuck at 0 or 1 through the
//! twin's memory hooks; the image must refuse to start:
//! `FAULT HARDWARE SELF_TEST code=131` (`firmware::code::RAM`) on Serial1,
//! no tick, no STEP pulse, and again after each watchdog reset.

mod common;

use common::{lines, run};
use twin::boot_twin;

const RAM_FAULT: &str = "FAULT HARDWARE SELF_TEST code=131";

/// Cells stuck at 0 and at 1, near the start, inside and near the end of
/// both statics: each refuses the start within the first boot.
#[test]
fn a_stuck_at_cell_fails_the_boot_ram_test_and_the_image_does_not_start() {
    for (name, offset, bit, value) in [
        ("TICK_CTX", 0u32, 0u32, true),
        ("TICK_CTX", 0x400, 17, false),
        ("HOST", 0x20, 31, true),
        ("HOST", 0x80, 5, false),
    ] {
        let mut t = boot_twin().unwrap();
        let base = t.static_addr(name).unwrap_or_else(|| panic!("no symbol {name}"));
        t.stuck_bit(base + offset, bit, value).unwrap();
        // detection: the fault line complete on Serial1
        let mut seen = None;
        for ms in 1..=60 {
            run(&mut t, ms);
            if lines(&t).iter().any(|l| l == RAM_FAULT) {
                seen = Some(ms);
                break;
            }
        }
        let l = lines(&t);
        let Some(ms) = seen else { panic!("{name}+{offset:#x} bit {bit} stuck at {value}: no RAM fault: {l:?}") };
        println!(
            "RAM test: {name}+{offset:#x} bit {bit} stuck at {value}: fault line complete at {ms} ms after power-on"
        );
        run(&mut t, 200);
        let l = lines(&t);
        assert!(!l.iter().any(|s| s.starts_with("BOOT") || s == "READY"), "the image started: {l:?}");
        assert!(l.iter().all(|s| s == RAM_FAULT), "{l:?}");
        assert_eq!(t.stats.pit_calls, 0, "a tick ran");
        assert!(t.stats.watchdog_resets >= 1, "no watchdog reset after the refusal");
        assert!(t.board().main_at.len() >= 2, "not tested again after the reset");
        assert!(l.len() >= 2, "the refusal is repeated after each reset: {l:?}");
        assert_eq!(t.board().step_pulses().iter().sum::<u64>(), 0, "a STEP pulse");
    }
}

/// The same image with healthy RAM passes the test and starts (the first
/// tick's entry is printed with its time: the RAM test is inside it).
#[test]
fn healthy_ram_passes_the_boot_ram_test() {
    let mut t = boot_twin().unwrap();
    run(&mut t, 60);
    let l = lines(&t);
    assert!(l.iter().any(|s| s == "READY"), "{l:?}");
    assert!(!l.iter().any(|s| s == RAM_FAULT), "{l:?}");
    let first = t.stats.pit_entries.first().copied().expect("a tick");
    println!("RAM test passed: main at {:?} cycles, first tick at {first} cycles", t.board().main_at);
}
