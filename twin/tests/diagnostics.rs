//! The image's self-diagnostics, each fault injected into the running
//! release image on the twin (evidence kind: **emulated**). Build the image
//! first: `twin/test.sh` does (or `twin/build-image.sh`).
//!
//! Watchdog and program flow: the RTWDOG runs in window mode (a refresh
//! less than 0.5 ms after the previous one resets the chip), its
//! configuration is locked at boot (`CS[UPDATE] = 0`), and the tick
//! refreshes it only after a tick whose steps (sense, estimate, request,
//! supervise, act, step commands, telemetry) all ran once and in order.

use std::cell::Cell;
use std::rc::Rc;

use twin::machine::demangle;
use twin::{boot_twin, Twin, MS};
use unicorn_engine::RegisterARM;

/// RTWDOG `CNT` (refresh and unlock keys are written here), `CS`, `TOVAL`.
const RTWDOG_CNT: u32 = 0x400B_C004;
const RTWDOG_CS: u32 = 0x400B_C000;
const RTWDOG_TOVAL: u32 = 0x400B_C008;
const REFRESH: u32 = 0xB480_A602;
const UNLOCK: u32 = 0xD928_C520;
/// Unused OCRAM for the tests' own code.
const SCRATCH: u32 = 0x202F_0000;

fn run(t: &mut Twin, until_ms: u64) {
    if let Err(f) = t.run_until(until_ms * MS) {
        panic!("image stopped: {f}");
    }
}

fn run_cycles(t: &mut Twin, cycles: u64) {
    let end = t.now() + cycles;
    if let Err(f) = t.run_until(end) {
        panic!("image stopped: {f}");
    }
}

/// Complete lines on Serial1.
fn lines(t: &Twin) -> Vec<String> {
    let text = t.board().serial_text();
    let done = text.rfind('\n').map_or("", |i| &text[..i]);
    done.lines().map(str::to_owned).collect()
}

/// Boot, run past the first ticks, then stop in thread code right after a
/// tick refreshed the watchdog. Returns the time of that refresh.
fn booted_after_a_refresh(ms: u64) -> Twin {
    let mut t = boot_twin().unwrap();
    run(&mut t, ms);
    assert_eq!(t.stats.watchdog_resets, 0, "reset before the injection");
    let refreshes = t.board().wdog.refreshes;
    while t.board().wdog.refreshes == refreshes || t.board().in_pit {
        run_cycles(&mut t, 500);
    }
    t
}

/// Thumb code at `SCRATCH` that stores each `(address, value)` in turn and
/// returns: `LDR r0, [pc, #..]`, `LDR r1, [pc, #..]`, `STR r1, [r0]` per
/// store, `BX LR`, then the literal pool.
fn store_program(t: &mut Twin, stores: &[(u32, u32)]) {
    let n = stores.len();
    let code_len = n * 6 + 2;
    let pool = (code_len + 3) & !3;
    let mut code: Vec<u16> = Vec::new();
    for (i, _) in stores.iter().enumerate() {
        for (k, rt) in [(0usize, 0u16), (1, 1)] {
            let at = code.len() * 2;
            let lit = pool + (2 * i + k) * 4;
            let imm = (lit - ((at + 4) & !3)) / 4;
            code.push(0x4800 | (rt << 8) | imm as u16); // LDR rt, [pc, #imm*4]
        }
        code.push(0x6001); // STR r1, [r0]
    }
    code.push(0x4770); // BX LR
    let mut bytes: Vec<u8> = code.iter().flat_map(|h| h.to_le_bytes()).collect();
    bytes.resize(pool, 0);
    for &(a, v) in stores {
        bytes.extend(a.to_le_bytes());
        bytes.extend(v.to_le_bytes());
    }
    t.uc.mem_write(u64::from(SCRATCH), &bytes).unwrap();
    t.uc.ctl_remove_cache(u64::from(SCRATCH), u64::from(SCRATCH) + bytes.len() as u64).unwrap();
}

/// The address of the image's `firmware::root::Controller::<step>`.
fn step_fn(t: &Twin, step: &str) -> u32 {
    let want = format!("firmware::root::Controller::{step}");
    let mut found: Vec<u32> = t
        .image
        .symbols
        .iter()
        .filter(|(n, _)| {
            let d = demangle(n);
            d.starts_with(&want) || d.contains(&format!("Controller>::{step}"))
        })
        .map(|(_, &a)| a & !1)
        .collect();
    found.sort_unstable();
    found.dedup();
    assert_eq!(found.len(), 1, "{want}: {found:x?}");
    found[0]
}

/// The watchdog reset that followed `from`: its delay in ms.
fn reset_after_ms(t: &Twin, from: u64) -> f64 {
    assert_eq!(t.stats.watchdog_resets, 1, "watchdog resets");
    (t.stats.watchdog_reset_at[0] - from) as f64 / MS as f64
}

/// After the reset the image booted again and reports the watchdog reset.
fn assert_rebooted_with_fault(t: &Twin) {
    let l = lines(t);
    let banners = l.iter().filter(|s| s.contains("BOOT PAROL6")).count();
    assert_eq!(banners, 2, "{l:?}");
    assert!(l.iter().any(|s| s == "FAULT HARDWARE SELF_TEST code=129"), "{l:?}");
}

/// A tick that runs twice in a row (the PIT flag raised again right after
/// a tick, as a tick running at twice its rate or a spurious interrupt
/// would): both ticks are complete, so the program-flow check passes, but
/// the second refresh comes inside the closed window and the chip resets
/// at once. Fails on an image without the window (no reset).
#[test]
fn watchdog_window_tick_running_twice_resets() {
    let mut t = booted_after_a_refresh(60);
    let at = t.now();
    t.board_mut().pit.ch[0].tif = true;
    run_cycles(&mut t, 2 * MS);
    let after = reset_after_ms(&t, at);
    println!("tick run twice: reset {after:.3} ms after the injection");
    assert!(after < 0.2, "reset {after} ms after the injection");
    run(&mut t, 150);
    assert_rebooted_with_fault(&t);
}

/// A refresh from the main loop (thread code stores the refresh key, as a
/// stray call of the feed would): right after the tick's refresh it is
/// inside the window and resets at once; late in the period it is accepted
/// by the hardware, but then the tick's own refresh falls inside the
/// window and resets. Either way the chip resets within a tick. Fails on
/// an image without the window.
#[test]
fn watchdog_window_main_loop_refresh_resets() {
    for delay_us in [20u64, 750] {
        let mut t = booted_after_a_refresh(60);
        run_cycles(&mut t, delay_us * MS / 1000);
        while t.board().in_pit {
            run_cycles(&mut t, 200);
        }
        store_program(&mut t, &[(RTWDOG_CNT, REFRESH)]);
        let at = t.now();
        t.call_at(SCRATCH, &[]).unwrap();
        run_cycles(&mut t, 3 * MS);
        let after = reset_after_ms(&t, at);
        println!("main-loop refresh {delay_us} us after the tick's: reset {after:.3} ms after it");
        assert!(after < 1.1, "{delay_us} us: reset {after} ms after the stray refresh");
        run(&mut t, 150);
        assert_rebooted_with_fault(&t);
    }
}

/// Thread code unlocks the RTWDOG and writes a disabled configuration with
/// a long timeout, then the tick stalls: the locked watchdog ignored the
/// reconfiguration and still resets the chip within its 20 ms timeout.
/// Fails on an image that leaves updates allowed (`UPDATE = 1`: the
/// watchdog is disabled and nothing resets).
#[test]
fn watchdog_locked_reconfiguration_does_not_take() {
    let mut t = booted_after_a_refresh(60);
    let cs = t.board().wdog.cs;
    // unlock, TOVAL = 0xFFFF, CS: EN = 0, UPDATE = 1, CMD32EN = 1, LPO
    store_program(&mut t, &[(RTWDOG_CNT, UNLOCK), (RTWDOG_TOVAL, 0xFFFF), (RTWDOG_CS, 0x2120)]);
    t.call_at(SCRATCH, &[]).unwrap();
    run_cycles(&mut t, 100_000);
    assert_eq!(t.stats.watchdog_resets, 0);
    assert_eq!(t.board().wdog.cs, cs, "CS changed");
    assert_eq!(t.board().wdog.locked_unlocks, 1);
    t.board_mut().nvic_en = [0; 8]; // the tick never runs again
    let at = t.now();
    run(&mut t, 150);
    let after = reset_after_ms(&t, at);
    println!("reconfiguration attempted, tick stalled: reset {after:.3} ms after the stall");
    assert!(after < 21.0, "reset {after} ms after the stall");
    assert_rebooted_with_fault(&t);
}

/// One step of the tick skipped (its function patched to return at once,
/// in the running copy in ITCM): the program-flow check fails, the tick
/// stops refreshing (latched), and the watchdog resets the chip within its
/// timeout; the image boots again from flash, intact. Fails on an image
/// that refreshes unconditionally (no reset).
#[test]
fn program_flow_skipped_step_resets() {
    for step in ["sense_step", "kernel_step", "act_step", "telemetry_step"] {
        let mut t = booted_after_a_refresh(60);
        let f = step_fn(&t, step);
        t.uc.mem_write(u64::from(f), &0x4770_u16.to_le_bytes()).unwrap(); // BX LR
        t.uc.ctl_remove_cache(u64::from(f), u64::from(f) + 2).unwrap();
        let at = t.now();
        run(&mut t, 150);
        let after = reset_after_ms(&t, at);
        println!("{step} skipped: reset {after:.3} ms after the patch");
        assert!((19.0..22.0).contains(&after), "{step}: reset {after} ms after the patch");
        assert_eq!(t.board().wdog.early_refreshes, 0);
        assert_rebooted_with_fault(&t);
    }
}

/// One step of one tick run twice (its function entered a second time
/// with the same arguments when it returns, through a code hook at its
/// entry): the program-flow check fails and is latched, the watchdog
/// resets the chip within its timeout, although every later tick is
/// complete. Fails on an image that refreshes unconditionally.
#[test]
fn program_flow_repeated_step_resets() {
    for step in ["kernel_step", "act_step", "telemetry_step"] {
        let mut t = booted_after_a_refresh(60);
        let f = step_fn(&t, step);
        let fired = Rc::new(Cell::new(0u32));
        let hook_fired = fired.clone();
        let mut saved: Option<[u64; 5]> = None;
        let regs = [RegisterARM::R0, RegisterARM::R1, RegisterARM::R2, RegisterARM::R3, RegisterARM::LR];
        t.uc.add_code_hook(u64::from(f), u64::from(f) + 1, move |uc, _addr, _size| {
            if hook_fired.get() >= 2 {
                return;
            }
            match saved.take() {
                None => {
                    // first entry: remember the call, return into the entry
                    let mut v = [0u64; 5];
                    for (x, r) in v.iter_mut().zip(regs) {
                        *x = uc.reg_read(r).unwrap();
                    }
                    saved = Some(v);
                    uc.reg_write(RegisterARM::LR, u64::from(f | 1)).unwrap();
                }
                Some(v) => {
                    // second entry: the same call again, back to the caller
                    for (x, r) in v.iter().zip(regs) {
                        uc.reg_write(r, *x).unwrap();
                    }
                }
            }
            hook_fired.set(hook_fired.get() + 1);
        })
        .unwrap();
        t.uc.ctl_remove_cache(u64::from(f), u64::from(f) + 2).unwrap();
        let at = t.now();
        run(&mut t, 150);
        assert_eq!(fired.get(), 2, "{step}: entries seen by the hook");
        let after = reset_after_ms(&t, at);
        println!("{step} repeated once: reset {after:.3} ms after the injection");
        assert!((19.0..23.0).contains(&after), "{step}: reset {after} ms after the injection");
        assert_eq!(t.board().wdog.early_refreshes, 0);
        assert_rebooted_with_fault(&t);
    }
}

/// The flash address of the image byte that runs (or is read) at `vaddr`.
fn load_address(t: &Twin, vaddr: u32) -> u32 {
    let s = t
        .image
        .segments
        .iter()
        .find(|s| s.paddr >= 0x6000_0000 && (s.vaddr..s.vaddr + s.data.len() as u32).contains(&vaddr))
        .expect("loaded from flash");
    s.paddr + (vaddr - s.vaddr)
}

/// Image CRC: one bit of the loaded image flipped in flash before power-on
/// (in the tick's code, which boot copies to ITCM; in a constant of
/// `.rodata`; in the stamped CRC itself): the image refuses to run. It
/// prints `FAULT HARDWARE IMAGE_CRC` on Serial1, never starts the tick
/// (no PIT interrupt, no banner), never resets, and no STEP pin pulses
/// although `<HOME>` is sent.
/// Fails on an image without the check (it boots and ticks).
#[test]
fn image_crc_one_bit_flipped_refuses_to_run() {
    let probe = boot_twin().unwrap();
    let code = load_address(&probe, step_fn(&probe, "kernel_step") + 8);
    let rodata = probe.image.segments.iter().filter(|s| s.paddr >= 0x6000_0000).max_by_key(|s| s.paddr).unwrap();
    let constant = rodata.paddr + rodata.data.len() as u32 / 2;
    let stamp_crc = probe.symbol("PAROL6_IMAGE_STAMP").map(|a| a + 8);
    drop(probe);
    let mut cases = vec![("tick code", code, 3u8), ("constant", constant, 0)];
    if let Some(a) = stamp_crc {
        cases.push(("stamped CRC", a, 7));
    }
    for (what, addr, bit) in cases {
        let mut t = boot_twin().unwrap();
        let mut b = [0u8; 1];
        t.uc.mem_read(u64::from(addr), &mut b).unwrap();
        b[0] ^= 1 << bit;
        t.uc.mem_write(u64::from(addr), &b).unwrap();
        run(&mut t, 100);
        t.board_mut().serial_send(b"<HOME>\n");
        run(&mut t, 250);
        let text = t.board().serial_text();
        let at = text.find("FAULT HARDWARE IMAGE_CRC");
        assert!(at.is_some(), "{what} at {addr:#x}: no IMAGE_CRC fault line: {text:?}");
        assert!(!text.contains("BOOT PAROL6"), "{what}: banner: {text:?}");
        assert_eq!(t.stats.pit_calls, 0, "{what}: the tick ran");
        assert_eq!(t.stats.watchdog_resets, 0, "{what}: reset");
        let lines = text.matches("FAULT HARDWARE IMAGE_CRC").count();
        assert!(lines >= 2, "{what}: {lines} fault lines in 250 ms");
        assert_eq!(t.board().step_pulses(), [0; 6], "{what}: STEP pulses after <HOME>");
        let out = &t.board().uart.tx_out;
        let first_byte = out.first().map(|(c, _)| *c as f64 / MS as f64).unwrap();
        let line_done = out.iter().find(|(_, b)| *b == b'\n').map(|(c, _)| *c as f64 / MS as f64).unwrap();
        assert!(line_done < 18.0, "{what}: fault line complete {line_done} ms after power-on");
        println!(
            "{what}: bit {bit} at {addr:#x} flipped: IMAGE_CRC line from {first_byte:.2} to {line_done:.2} ms after power-on, {lines} in 250 ms, no tick"
        );
    }
}
