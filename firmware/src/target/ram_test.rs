//! The boot RAM test: March C- (`hal_imxrt::pure::march`, two data
//! backgrounds) over every writable static of the image and the free part of
//! the stack, as the first thing `main` does, before any code but the
//! runtime's start-up has touched them.
//!
//! Covered, by construction (linker symbols, not a list of statics):
//!
//! - `.bss` (`__sbss..__ebss`, DTCM): every zero-initialised static, so
//!   every static the tick or the main loop reads or writes: the tick's and
//!   the main loop's state (`TICK_CTX`, `HOST`), the command/telemetry queues
//!   between them (`LINK`), the logger's ring, the USB stack's state and
//!   endpoint buffers, the tick counter, the peripheral-taken flags. Zeroed
//!   again afterwards, as the runtime left it.
//! - `.data` (`__sdata..__edata`): every static with a non-zero initial
//!   value (none in today's image, 0 B); copied again from its flash image
//!   afterwards.
//! - the vector table in DTCM (`__svector_table..__evector_table`), which
//!   the core reads on every exception (the tick's PIT interrupt); copied
//!   again from its flash image afterwards.
//! - the main stack below the current stack pointer less [`STACK_MARGIN`]
//!   (`__estack..SP - STACK_MARGIN`): every byte the boot, the main loop,
//!   the tick and the fault handlers will use below `main`'s own frame,
//!   the stack guard's 1 KiB included (the MPU is not on yet).
//!
//! `firmware/build.sh` checks on the built ELF that every writable static
//! lies in `.bss` or `.data` (the only exception is the panic marker in
//! `.uninit`, below), so a static added later is covered without an edit
//! here.
//!
//! Not covered: the top of the stack (`main`'s frame, this function's frame
//! and the [`STACK_MARGIN`] the test's own calls use: live while the test
//! runs); `.uninit` (the 4-byte panic marker in OCRAM: it must survive a
//! reset, so a destructive test would erase it; the tick never uses it);
//! `.rodata` in OCRAM (constants copied from flash, which the test's own code
//! may read while it runs); the code in ITCM (the test runs from it); the
//! unused heap.
//!
//! A failing cell refuses the start: `main` keeps the verdict and, once the
//! watchdog runs and Serial1 exists, prints `FAULT HARDWARE SELF_TEST
//! code=131` there, lights the LED and halts with every STEP output masked
//! low and no tick until the watchdog resets the chip; the next boot tests
//! again.
//!
//! During operation [`RunTimeTest`] tests the free stack again, a block per
//! main-loop pass (the memory the tick's interrupt frames and calls use;
//! the statics are in use and are not tested again at run time).

use core::ptr::{addr_of, addr_of_mut};

use hal_imxrt::periph::uart::Serial1;
use hal_imxrt::pure::march::{self, MarchFailure, Memory};

use super::ral;

/// Bytes left untested below the stack pointer read on entry to [`run`]:
/// the frames of the test's own calls (`march::test` and its per-element
/// loop) live there while it runs. The stack-size build shows them at a
/// few dozen bytes; `firmware/build.sh` checks that `run`'s callees need
/// less than this (firmware/tools/stack_analysis.py).
pub(super) const STACK_MARGIN: u32 = 256;

// imxrt-rt's linker script symbols: section bounds and load addresses.
extern "C" {
    static mut __sbss: u32;
    static mut __ebss: u32;
    static mut __sdata: u32;
    static mut __edata: u32;
    static __sidata: u32;
    static mut __svector_table: u32;
    static mut __evector_table: u32;
    static __sivector_table: u32;
    static mut __estack: u32;
}

/// A word-aligned region of RAM, accessed only through volatile reads and
/// writes of its own words.
struct Region {
    base: *mut u32,
    words: usize,
}

impl Region {
    /// The words in `[start, end)` (an empty region if `end < start`).
    fn between(start: *mut u32, end: *const u32) -> Self {
        let words = (end as usize).saturating_sub(start as usize) / 4;
        Region { base: start, words }
    }
    /// Every word set to the same word of `from` (`Some`) or to zero.
    fn fill(&mut self, from: Option<*const u32>) {
        for i in 0..self.words {
            let v = match from {
                // SAFETY: `from` is the region's load image in flash, as
                // long as the region (the linker's LOADADDR of the same
                // output section), word-aligned.
                Some(src) => unsafe { core::ptr::read_volatile(src.add(i)) },
                None => 0,
            };
            self.write(i, v);
        }
    }
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
        // `run` built from linker-placed section bounds (or the stack below
        // the live frames), or `RunTimeTest::step` from a block of the stack
        // below the live frames and outside the guard; nothing reads or
        // writes it while the test runs (see `run`, `step`).
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

/// March C- over `.bss`, `.data`, the vector table and the free stack, then
/// each restored to its start-up contents. Called once, as `main`'s first
/// statement, with no interrupt enabled in the NVIC and the MPU off. Not
/// inlined: its stack pointer reading is the bound of the tested stack.
#[inline(never)]
pub(super) fn run() -> Result<(), MarchFailure> {
    let sp = cortex_m::register::msp::read();
    // Only addresses are taken here (the accesses are `Region`'s). No code
    // but the runtime's start-up (which zeroed `.bss`, copied `.data` and
    // the vector table) has run, so no static has been read or written yet
    // and no reference to one exists; the stack below `sp - STACK_MARGIN`
    // holds no live frame (the test's own calls stay above it,
    // `STACK_MARGIN`); no interrupt is enabled, so the vector table is not
    // read unless the test itself faults. Each region is restored below
    // before `main` goes on.
    let mut bss = Region::between(addr_of_mut!(__sbss), addr_of!(__ebss));
    let mut data = Region::between(addr_of_mut!(__sdata), addr_of!(__edata));
    let mut vectors = Region::between(addr_of_mut!(__svector_table), addr_of!(__evector_table));
    let mut stack = Region::between(addr_of_mut!(__estack), sp.saturating_sub(STACK_MARGIN) as *const u32);
    let verdict = march::test(&mut bss)
        .and_then(|()| march::test(&mut data))
        .and_then(|()| march::test(&mut vectors))
        .and_then(|()| march::test(&mut stack));
    bss.fill(None);
    data.fill(Some(addr_of!(__sidata)));
    vectors.fill(Some(addr_of!(__sivector_table)));
    cortex_m::asm::dsb();
    verdict
}

/// Words of the free stack [`RunTimeTest::step`] tests per call.
pub(super) const RUN_WORDS: u32 = 8;

/// The run-time RAM test: March C- (both backgrounds) over [`RUN_WORDS`]
/// words of the free stack per main-loop pass, with interrupts masked, the
/// next block each pass, round the stack below the main loop's frames
/// (`__estack..SP - STACK_MARGIN`, the stack guard skipped), so every cell
/// of the stack the tick's interrupt frames and its calls will use is tested
/// again during operation. Nothing lives below the stack pointer and the
/// tick cannot run while the block is tested, so the test needs no copy of
/// the block. An idle main loop passes once per tick (the tick ends its
/// WFI), so a round then takes (stack words / `RUN_WORDS`) ticks; a busy
/// one passes more often.
pub(super) struct RunTimeTest {
    next: u32,
}

impl RunTimeTest {
    pub(super) const fn new() -> Self {
        Self { next: 0 }
    }

    /// Tests the next block; `Err` on a failing cell. Not inlined: its
    /// stack pointer reading bounds the block (`stack_analysis.py` checks
    /// its callees against `STACK_MARGIN`, as for `run`).
    #[inline(never)]
    pub(super) fn step(&mut self) -> Result<(), MarchFailure> {
        use hal_imxrt::pure::mpu::{GUARD_BASE, GUARD_SIZE};
        let bytes = RUN_WORDS * 4;
        cortex_m::interrupt::free(|_| {
            let top = cortex_m::register::msp::read().saturating_sub(STACK_MARGIN);
            let bottom = addr_of!(__estack) as u32;
            let mut at = self.next.max(bottom);
            // the guard is no-access (MPU): skip it
            if at < GUARD_BASE + GUARD_SIZE && at + bytes > GUARD_BASE {
                at = GUARD_BASE + GUARD_SIZE;
            }
            if at + bytes > top {
                at = bottom;
            }
            self.next = at + bytes;
            let mut block = Region { base: at as *mut u32, words: RUN_WORDS as usize };
            march::test(&mut block)
        })
    }
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
