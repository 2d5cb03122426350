//! Seeded defects for `tick_analysis.py`'s self-test
//! (`firmware/tools/tick_analysis_selftest.sh`): three roots, one with a
//! reachable panic path, one with a reachable 64-bit division, one with
//! neither. Built for thumbv7em-none-eabihf without the firmware.
#![no_std]
#![no_main]

/// A bounds-checked index: `core::panicking::panic_bounds_check` is reachable.
#[no_mangle]
#[inline(never)]
pub extern "C" fn seeded_panic(table: &[u32; 4], i: usize) -> u32 {
    let t: &[u32] = core::hint::black_box(table);
    t[i]
}

/// A 64-bit division: `__aeabi_uldivmod` is reachable.
#[no_mangle]
#[inline(never)]
pub extern "C" fn seeded_division(a: u64, b: u64) -> u64 {
    core::hint::black_box(a) / core::hint::black_box(b).max(1)
}

/// Neither: 32-bit arithmetic only.
#[no_mangle]
#[inline(never)]
pub extern "C" fn seeded_clean(a: u32, b: u32) -> u32 {
    core::hint::black_box(a).wrapping_mul(3).wrapping_add(b)
}

/// The entry keeps all three in the link.
#[no_mangle]
pub extern "C" fn seeded_entry() -> u32 {
    let t = [1, 2, 3, 4];
    let a = seeded_panic(&t, core::hint::black_box(7));
    let b = seeded_division(u64::from(a), 3) as u32;
    seeded_clean(a, b)
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    loop {
        core::hint::spin_loop();
    }
}
