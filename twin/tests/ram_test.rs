//! The boot RAM test on the shipped Serial1 image (evidence kind:
//! **emulated**): a cell stuck at 0 or 1 through the twin's memory hooks in
//! each region the test covers -- the tick's and the main loop's state
//! (`TICK_CTX`, `HOST`), the command/telemetry queues between them (`LINK`),
//! the logger's ring, the USB stack's state and buffers, the tick counter,
//! the vector table in DTCM and the main stack below the test's own frames;
//! the image must refuse to start: `FAULT HARDWARE SELF_TEST code=131`
//! (`firmware::code::RAM`) on Serial1, no tick, no STEP pulse, and again
//! after each watchdog reset.

mod common;

use std::cell::Cell;
use std::rc::Rc;

use common::{lines, run};
use twin::pit::IRQ_PIT;
use twin::{boot_twin, Twin};
use unicorn_engine::RegisterARM;

const RAM_FAULT: &str = "FAULT HARDWARE SELF_TEST code=131";

/// Where a stuck cell is injected: a static (a fragment of its mangled
/// name, `6target4LINK17h` for `parol6::target::LINK`) or a linker symbol,
/// plus a byte offset.
#[derive(Clone, Copy, Debug)]
enum At {
    Static(&'static str, u32),
    Linker(&'static str, u32),
}

fn addr(t: &Twin, at: At) -> u32 {
    match at {
        At::Static(name, off) => t.static_addr(name).unwrap_or_else(|| panic!("no symbol {name}")) + off,
        At::Linker(name, off) => t.linker_symbol(name).unwrap_or_else(|| panic!("no linker symbol {name}")) + off,
    }
}

/// Boots the image with bit `bit` of the word at `at` stuck at `value` and
/// requires the refusal; returns the time of the complete fault line (ms).
fn refuses(at: At, bit: u32, value: bool) -> u64 {
    let mut t = boot_twin().unwrap();
    let a = addr(&t, at);
    t.stuck_bit(a, bit, value).unwrap();
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
    let Some(ms) = seen else { panic!("{at:?} ({a:#x}) bit {bit} stuck at {value}: no RAM fault: {l:?}") };
    println!("RAM test: {at:?} ({a:#x}) bit {bit} stuck at {value}: fault line complete at {ms} ms after power-on");
    run(&mut t, 200);
    let l = lines(&t);
    assert!(!l.iter().any(|s| s.starts_with("BOOT") || s == "READY"), "the image started: {l:?}");
    assert!(l.iter().all(|s| s == RAM_FAULT), "{l:?}");
    assert_eq!(t.stats.pit_calls, 0, "a tick ran");
    assert!(t.stats.watchdog_resets >= 1, "no watchdog reset after the refusal");
    assert!(t.board().main_at.len() >= 2, "not tested again after the reset");
    assert!(l.len() >= 2, "the refusal is repeated after each reset: {l:?}");
    assert_eq!(t.board().step_pulses().iter().sum::<u64>(), 0, "a STEP pulse");
    ms
}

/// Cells stuck at 0 and at 1, near the start, inside and near the end of
/// the tick's and the main loop's state: each refuses the start within the
/// first boot.
#[test]
fn a_stuck_at_cell_fails_the_boot_ram_test_and_the_image_does_not_start() {
    for (at, bit, value) in [
        (At::Static("TICK_CTX", 0), 0u32, true),
        (At::Static("TICK_CTX", 0x400), 17, false),
        (At::Static("HOST", 0x20), 31, true),
        (At::Static("HOST", 0x80), 5, false),
    ] {
        refuses(at, bit, value);
    }
}

/// The command and telemetry queues between the main loop and the tick.
#[test]
fn a_stuck_at_cell_in_the_command_queues_fails_the_boot_ram_test() {
    refuses(At::Static("6target4LINK17h", 0x10), 3, true);
    refuses(At::Static("6target4LINK17h", 0x600), 30, false);
}

/// The logger's ring and the tick counter.
#[test]
fn a_stuck_at_cell_in_the_logger_ring_or_tick_counter_fails_the_boot_ram_test() {
    refuses(At::Static("6logger4RING17h", 0x800), 12, true);
    refuses(At::Static("6target5TICKS17h", 0), 0, true);
}

/// The USB stack's endpoint state, endpoint memory and bus.
#[test]
fn a_stuck_at_cell_in_the_usb_state_fails_the_boot_ram_test() {
    refuses(At::Static("4port8EP_STATE17h", 0x1000), 9, true);
    refuses(At::Static("4port9EP_MEMORY17h", 0x100), 22, false);
    refuses(At::Static("4port3BUS17h", 0x8), 1, true);
}

/// The PIT's entry of the vector table in DTCM (the tick's interrupt
/// vector, read by the core on every tick).
#[test]
fn a_stuck_at_cell_in_the_vector_table_fails_the_boot_ram_test() {
    refuses(At::Linker("__svector_table", 4 * (16 + IRQ_PIT)), 8, true);
}

/// The main stack: below the stack guard (the fatal path's kilobyte),
/// the middle, and 4 KiB below the top (boot's and the main loop's frames).
#[test]
fn a_stuck_at_cell_in_the_stack_fails_the_boot_ram_test() {
    refuses(At::Linker("__estack", 0x100), 4, true);
    refuses(At::Linker("__estack", 0x4000), 27, false);
    refuses(At::Linker("__estack", 0x7000), 15, true);
}

/// The same image with healthy RAM passes the test and starts; the test's
/// duration is the time from `main` to `start` (boot and the main loop),
/// which `main` calls right after it.
#[test]
fn healthy_ram_passes_the_boot_ram_test() {
    let mut t = boot_twin().unwrap();
    let start = t.static_addr("6target5start17h").expect("parol6::target::start");
    let at = Rc::new(Cell::new(None));
    let seen = at.clone();
    t.uc.add_code_hook(u64::from(start), u64::from(start), move |uc, _, _| {
        if seen.get().is_none() {
            seen.set(Some(uc.get_data().now));
        }
    })
    .unwrap();
    run(&mut t, 60);
    let l = lines(&t);
    assert!(l.iter().any(|s| s == "READY"), "{l:?}");
    assert!(!l.iter().any(|s| s == RAM_FAULT), "{l:?}");
    let main = *t.board().main_at.first().expect("main");
    let start = at.get().expect("start not reached");
    let first = t.stats.pit_entries.first().copied().expect("a tick");
    println!(
        "RAM test passed: main at {main} cycles, start at {start} cycles (the test: {} cycles), first tick at {first} cycles",
        start - main
    );
}

/// The run-time RAM test (`ram_test::RunTimeTest`): first measured on a
/// healthy run (its passes, the instructions it runs with interrupts masked
/// and the blocks of one round of the free stack), then a stack cell that
/// fails during operation (stuck at 1 from 400 ms after power-on, 4 KiB
/// above the stack's bottom, deeper than the tick and the main loop reach)
/// is found by the main loop's incremental March C- within one round: the
/// fatal stop (every STEP output low), the watchdog reset, then the boot
/// RAM test refuses the start.
#[test]
fn a_cell_failing_in_operation_fails_the_run_time_ram_test() {
    let mut t = boot_twin().unwrap();
    let stop = t.static_addr("6target10fatal_stop17h").expect("parol6::target::fatal_stop");
    let step = t.static_addr("11RunTimeTest4step17h").expect("RunTimeTest::step");
    // the masked span: from `cpsid i` to the `msr primask` that restores it
    // (read from ITCM once the runtime has copied the code there, before
    // the main loop first calls `step`)
    run(&mut t, 1);
    let mut code = [0u8; 0x100];
    t.uc.mem_read(u64::from(step), &mut code).unwrap();
    let hw: Vec<u16> = code.chunks(2).map(|c| u16::from_le_bytes([c[0], c[1]])).collect();
    let cpsid = hw.iter().position(|&h| h == 0xb672).expect("cpsid i in step");
    let msr =
        (cpsid..hw.len() - 1).find(|&i| hw[i] & 0xfff0 == 0xf380 && hw[i + 1] == 0x8810).expect("msr primask in step");
    let at = Rc::new(Cell::new(None));
    let seen = at.clone();
    t.uc.add_code_hook(u64::from(stop), u64::from(stop), move |uc, _, _| {
        if seen.get().is_none() {
            seen.set(Some(uc.get_data().now));
        }
    })
    .unwrap();
    // (steps, the step count at the last wrap of the cursor, blocks per round, last cursor)
    let stats = Rc::new(Cell::new((0u64, None::<u64>, 0u64, 0u32)));
    let (masked_from, masked_max) = (Rc::new(Cell::new(0u64)), Rc::new(Cell::new(0u64)));
    let (st, mf, mf2, mm) = (stats.clone(), masked_from.clone(), masked_from.clone(), masked_max.clone());
    let entry = u64::from(step);
    t.uc.add_code_hook(entry, entry, move |uc, _, _| {
        // `step(&mut self)`: r0 is the result's slot, r1 `self` (`next` first)
        let this = uc.reg_read(RegisterARM::R1).unwrap();
        let mut b = [0u8; 4];
        uc.mem_read(this, &mut b).unwrap();
        let next = u32::from_le_bytes(b);
        let (n, wrap, blocks, last) = st.get();
        let (wrap, blocks) = if next < last { (Some(n), wrap.map_or(blocks, |w| n - w)) } else { (wrap, blocks) };
        st.set((n + 1, wrap, blocks, next));
    })
    .unwrap();
    let a = entry + 2 * cpsid as u64;
    t.uc.add_code_hook(a, a, move |uc, _, _| mf.set(uc.get_data().now)).unwrap();
    let m = entry + 2 * msr as u64;
    t.uc.add_code_hook(m, m, move |uc, _, _| mm.set(mm.get().max(uc.get_data().now - mf2.get()))).unwrap();
    t.uc.ctl_flush_tb().unwrap();
    run(&mut t, 400);
    assert!(lines(&t).iter().any(|s| s == "READY"), "{:?}", lines(&t));
    let (steps, _, blocks, _) = stats.get();
    println!(
        "run-time RAM test, healthy, first 400 ms: {steps} passes, at most {} instructions with interrupts masked, {blocks} blocks of 32 B per round",
        masked_max.get()
    );
    assert!(blocks > 0, "no complete round of the free stack in 400 ms");
    let injected = t.now();
    let cell = t.linker_symbol("__estack").expect("__estack") + 0x1000;
    t.stuck_bit(cell, 6, true).unwrap();
    run(&mut t, 1900);
    let stopped = at.get().unwrap_or_else(|| panic!("no fatal stop: {:?}", lines(&t)));
    let ms = (stopped - injected) as f64 / twin::MS as f64;
    println!("run-time RAM test: cell {cell:#x} bit 6 stuck at 1 from {injected} cycles: fatal stop {ms:.1} ms later");
    assert!(ms < 1200.0, "detection took {ms} ms");
    let l = lines(&t);
    assert!(t.stats.watchdog_resets >= 1, "no watchdog reset after the stop");
    assert!(l.iter().any(|s| s == RAM_FAULT), "the boot RAM test after the reset: {l:?}");
    let started = l.iter().filter(|s| s.starts_with("BOOT")).count();
    assert_eq!(started, 1, "the image started again after the reset: {l:?}");
}
