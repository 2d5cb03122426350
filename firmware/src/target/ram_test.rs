//! The boot RAM test: March C- (`hal_imxrt::pure::march`) over the memory
//! that will hold the tick's and the main loop's state (`TICK_CTX`, `HOST`,
//! in DTCM), while it is still uninitialised: `init_root` runs it after the
//! boot self-test, before it writes the root there, so it destroys nothing.
//! (The
//! runtime's own `__pre_init` belongs to imxrt-rt, which configures the
//! FlexRAM banks in it, so the test runs from `main` rather than before
//! `.bss` and `.data` are initialised; the statics it tests are
//! `MaybeUninit` and meaningless until `init_root` writes them.)
//!
//! A failing cell refuses the start: no tick, every STEP output still
//! masked low, `FAULT HARDWARE SELF_TEST code=131` on Serial1, the LED on,
//! then the watchdog resets the chip and the next boot tests again.

use core::mem::size_of_val;
use core::ptr::addr_of_mut;

use hal_imxrt::periph::uart::Serial1;
use hal_imxrt::pure::march::{self, MarchFailure, Memory};

use super::ral;

use super::{HOST, TICK_CTX};

/// A word-aligned region of RAM, accessed only through volatile reads and
/// writes of its own words.
struct Region {
    base: *mut u32,
    words: usize,
}

impl Memory for Region {
    fn words(&self) -> usize {
        self.words
    }
    fn read(&mut self, i: usize) -> u32 {
        if i >= self.words {
            return 0;
        }
        // SAFETY: `i < words`, so the word lies inside the region, which
        // `run` built from one static's own address and size; nothing else
        // uses that static before `init_root` (see `run`).
        unsafe { core::ptr::read_volatile(self.base.add(i)) }
    }
    fn write(&mut self, i: usize, v: u32) {
        if i >= self.words {
            return;
        }
        // SAFETY: as in `read`.
        unsafe { core::ptr::write_volatile(self.base.add(i), v) }
    }
}

/// March C- over `TICK_CTX` and `HOST`, each once per data background.
/// Called once from `init_root` before it writes them, interrupts masked.
/// Not inlined: its loops stay out of `main`.
#[inline(never)]
pub(super) fn run() -> Result<(), MarchFailure> {
    // SAFETY: only the addresses and sizes are taken here; both statics are
    // `MaybeUninit`, not yet written (`init_root` writes them after this
    // test returns) and not referenced by anything else until then, so overwriting
    // their bytes with test patterns destroys nothing. Both are at least
    // word-aligned (they contain `u32` fields), and the region covers whole
    // words inside each static only.
    let regions = unsafe {
        let t = addr_of_mut!(TICK_CTX);
        let h = addr_of_mut!(HOST);
        [
            Region { base: t.cast::<u32>(), words: size_of_val(&*t) / 4 },
            Region { base: h.cast::<u32>(), words: size_of_val(&*h) / 4 },
        ]
    };
    for mut r in regions {
        march::test(&mut r)?;
    }
    Ok(())
}

/// The refusal: the fault line on Serial1 (`firmware::RAM_FAULT_LINE`,
/// the kernel's wording), the LED, then the halt until the watchdog resets
/// the chip. Each byte waits at most a bounded number of polls for room in
/// the transmit FIFO.
pub(super) fn refuse(serial1: &mut Serial1, io: &ral::iomuxc::RegisterBlock) -> ! {
    for &b in firmware::RAM_FAULT_LINE.as_bytes() {
        let mut polls = 0u32;
        while !serial1.try_write(b) && polls < 1_000_000 {
            polls = polls.wrapping_add(1);
        }
    }
    super::led_on(io, &super::unsafe_gpio2());
    super::halt()
}
