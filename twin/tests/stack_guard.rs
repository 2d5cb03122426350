//! The stack guard (`hal_imxrt::pure::mpu`): a no-access MPU region of
//! 1 KiB, 1 KiB above the main stack's bottom, on the release image
//! (evidence kind: **emulated**). The twin models the MPU registers the
//! image writes and protects the region's pages in Unicorn; an access there
//! is taken as the HardFault the image's MemManage escalates to (see
//! `twin/src/mpu.rs`).
//!
//! The overflow is injected by driving the stack pointer to 16 bytes above
//! the guard, in the tick (at the PIT handler's entry, before its
//! prologue pushes) and in the main loop (between two ticks): the next push
//! lands in the guard. Each fails on an image without the guard: the
//! pushes land in ordinary RAM and the image runs on, stepping.

mod common;

use std::cell::Cell;
use std::rc::Rc;

use common::{lines, run};
use twin::{boot_twin, Twin, MS};
use unicorn_engine::RegisterARM;

/// The main stack (imxrt-rt: the first 32 KiB of DTCM) and the guard the
/// image documents (SAFETY.md SR-39): 1 KiB of no access, 1 KiB above the
/// stack's bottom.
const STACK_BOTTOM: u32 = 0x2000_0000;
const STACK_SIZE: u32 = 32 * 1024;
const GUARD_BASE: u32 = 0x2000_0400;
const GUARD_SIZE: u32 = 1024;
/// The stack pointer the injection sets: 16 bytes above the guard.
const LOW_SP: u32 = GUARD_BASE + GUARD_SIZE + 16;

fn us(cycles: u64) -> f64 {
    cycles as f64 * 1000.0 / MS as f64
}

/// Runs in 1 us steps until the MPU refused an access, at most `max_us`.
fn run_to_fault(t: &mut Twin, max_us: u64) {
    let end = t.now() + max_us * MS / 1000;
    while t.stats.mpu_faults.is_empty() && t.now() < end {
        run_cycles(t, MS / 1000);
    }
}

fn run_cycles(t: &mut Twin, cycles: u64) {
    let end = t.now() + cycles;
    if let Err(f) = t.run_until(end) {
        panic!("image stopped: {f}");
    }
}

/// Boot, `<HOME>` at 60 ms, run to 160 ms: J6 is stepping.
fn homing() -> Twin {
    let mut t = boot_twin().unwrap();
    run(&mut t, 60);
    t.board_mut().serial_send(b"<HOME>\n");
    run(&mut t, 160);
    assert!(t.board().step_pulses()[5] > 100, "J6 is not stepping");
    assert!(t.stats.mpu_faults.is_empty(), "{:?}", t.stats.mpu_faults);
    t
}

/// After a stack-guard fault at `from`: every STEP pin a GPIO output driven
/// low within `max_us`, no STEP pulse in the next 10 ms; then the watchdog
/// resets the chip and the image boots again into the latched panic fault
/// (`FAULT HARDWARE SELF_TEST code=128`). Returns the microseconds to STEP
/// low.
fn assert_fatal_stop(t: &mut Twin, from: u64, what: &str, max_us: f64) -> f64 {
    let pins = twin::pads::wiring().step;
    let low = |t: &Twin| pins.iter().all(|&p| t.board().gpio_out(p) == Some(false));
    while !low(t) && us(t.now() - from) < 1000.0 {
        run_cycles(t, 60); // 0.1 us
    }
    let to_low = us(t.now() - from);
    assert!(low(t), "{what}: STEP pins not low 1 ms after the fault:\n{}", t.board().step_report().join("\n"));
    let before = t.board().step_pulses();
    run_cycles(t, 10 * MS);
    assert_eq!(t.board().step_pulses(), before, "{what}: STEP pulses after the fatal stop");
    assert!(to_low <= max_us, "{what}: STEP low {to_low} us after the fault");
    let end = t.now() / MS + 150;
    run(t, end);
    assert_eq!(t.stats.watchdog_resets, 1, "{what}: watchdog resets");
    let l = lines(t);
    assert!(l.iter().any(|s| s == "FAULT HARDWARE SELF_TEST code=128"), "{what}: {l:?}");
    to_low
}

/// The image programs the guard at boot: MPU on with the default map
/// elsewhere, off in the HardFault handler (`HFNMIENA = 0`), one no-access
/// region of 1 KiB that lies inside the ELF's `.stack` (imxrt-rt's
/// `__estack` .. `_stack_start`) with 1 KiB of stack below it.
#[test]
fn stack_guard_region_is_programmed_at_boot() {
    let mut t = boot_twin().unwrap();
    run(&mut t, 5);
    let mpu = &t.board().mpu;
    assert!(mpu.enabled(), "MPU off: CTRL {:#x}", mpu.ctrl);
    assert!(!mpu.on_in_hardfault(), "HFNMIENA set: CTRL {:#x}", mpu.ctrl);
    assert_eq!(mpu.ctrl & 4, 4, "PRIVDEFENA clear: CTRL {:#x}", mpu.ctrl);
    let guard = (u64::from(GUARD_BASE), u64::from(GUARD_BASE + GUARD_SIZE));
    assert_eq!(mpu.no_access(), vec![guard]);
    let sym = |n: &str| t.image.linker_symbols.get(n).copied().unwrap_or_else(|| panic!("no {n}"));
    let (bottom, top) = (sym("__estack"), sym("_stack_start"));
    assert_eq!((bottom, top), (STACK_BOTTOM, STACK_BOTTOM + STACK_SIZE), "the linker's stack moved");
    assert!(u64::from(bottom) + 1024 <= guard.0 && guard.1 < u64::from(top));
    println!("guard {:#x}..{:#x} in the stack {bottom:#x}..{top:#x}, MPU_CTRL {:#x}", guard.0, guard.1, mpu.ctrl);
}

/// The tick's stack overflows: at the PIT handler's entry the stack
/// pointer is 16 bytes above the guard, so the prologue's push reaches
/// into it. The access faults at once (no write lands in the guard), the
/// HardFault handler stops every STEP output, and the watchdog reset
/// follows.
#[test]
fn stack_guard_tick_overflow_stops_stepping_at_once() {
    let mut t = homing();
    let vtor = t.board().vtor;
    let mut v = [0u8; 4];
    t.uc.mem_read(u64::from(vtor) + 4 * (16 + u64::from(twin::pit::IRQ_PIT)), &mut v).unwrap();
    let pit = u32::from_le_bytes(v) & !1;
    let armed = Rc::new(Cell::new(true));
    let lowered_at = Rc::new(Cell::new(0u64));
    let (a, l) = (armed.clone(), lowered_at.clone());
    t.uc.add_code_hook(u64::from(pit), u64::from(pit) + 1, move |uc, _, _| {
        if a.replace(false) {
            uc.reg_write(RegisterARM::SP, u64::from(LOW_SP)).unwrap();
            l.set(uc.get_data().now);
        }
    })
    .unwrap();
    t.uc.ctl_remove_cache(u64::from(pit), u64::from(pit) + 2).unwrap();
    run_to_fault(&mut t, 2000);
    assert!(!armed.get(), "the tick did not run");
    let f = *t.stats.mpu_faults.first().unwrap_or_else(|| {
        panic!("no stack-guard fault within 2 ms of SP {LOW_SP:#x} in the tick; pulses {:?}", t.board().step_pulses())
    });
    let guard = GUARD_BASE..GUARD_BASE + GUARD_SIZE;
    assert!(guard.contains(&f.addr), "fault at {:#x}", f.addr);
    let from = lowered_at.get();
    let to_fault = us(f.at - from);
    let to_low = assert_fatal_stop(&mut t, f.at, "tick overflow", 20.0);
    println!(
        "tick overflow: {} at {:#x} (SP {:#x}) {to_fault:.3} us after the PIT entry; STEP low {to_low:.2} us after the fault",
        if f.write { "write" } else { "read" },
        f.addr,
        f.sp
    );
    assert!(to_fault < 1.0, "fault {to_fault} us after the PIT entry");
}

/// The main loop's stack overflows: at the entry of `firmware::tx::Tx::flush`
/// (the main loop's transmit step, called on every pass) the stack pointer
/// is 16 bytes above the guard, so its prologue's push reaches into it.
#[test]
fn stack_guard_main_loop_overflow_stops_stepping_at_once() {
    let mut t = homing();
    let flush = t
        .image
        .symbols
        .iter()
        .find(|(n, _)| twin::machine::demangle(n) == "firmware::tx::Tx::flush")
        .map(|(_, &a)| a & !1)
        .expect("firmware::tx::Tx::flush");
    let armed = Rc::new(Cell::new(true));
    let lowered_at = Rc::new(Cell::new(0u64));
    let (a, l) = (armed.clone(), lowered_at.clone());
    t.uc.add_code_hook(u64::from(flush), u64::from(flush) + 1, move |uc, _, _| {
        if !uc.get_data().in_pit && a.replace(false) {
            uc.reg_write(RegisterARM::SP, u64::from(LOW_SP)).unwrap();
            l.set(uc.get_data().now);
        }
    })
    .unwrap();
    t.uc.ctl_remove_cache(u64::from(flush), u64::from(flush) + 2).unwrap();
    run_to_fault(&mut t, 20_000);
    assert!(!armed.get(), "the main loop did not flush");
    let f = *t.stats.mpu_faults.first().unwrap_or_else(|| {
        panic!(
            "no stack-guard fault within 20 ms of SP {LOW_SP:#x} in the main loop; pulses {:?}",
            t.board().step_pulses()
        )
    });
    let guard = GUARD_BASE..GUARD_BASE + GUARD_SIZE;
    assert!(guard.contains(&f.addr), "fault at {:#x}", f.addr);
    let to_fault = us(f.at - lowered_at.get());
    let to_low = assert_fatal_stop(&mut t, f.at, "main-loop overflow", 20.0);
    println!(
        "main-loop overflow: {} at {:#x} (SP {:#x}) {to_fault:.3} us after the entry of Tx::flush; STEP low {to_low:.2} us after the fault",
        if f.write { "write" } else { "read" },
        f.addr,
        f.sp
    );
    assert!(to_fault < 1.0, "fault {to_fault} us after SP was lowered");
}
