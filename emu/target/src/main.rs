//! The recorded scenario replayed on a Cortex-M7 (QEMU `mps2-an500`).
//!
//! stdout (semihosting): exactly the trace `emu-host replay` prints on the
//! host, compared byte for byte by `emu/test.sh`.
//! stderr (semihosting): FPU and stack checks.
//! Exit status (semihosting SYS_EXIT): success only if the FPU is enabled and
//! computes IEEE results, and both replays ran to the end.
//!
//! Instruction counting: the `emu_*_start` / `emu_*_stop` functions are empty
//! markers around `Parser::parse` and `Kernel::tick`; the project's QEMU
//! plugin (`emu/plugin/count.c`) counts the instructions executed between
//! the entry of a start marker and the entry of the matching stop marker.
#![no_std]
#![no_main]

use core::fmt::Write as _;
use core::ptr::{addr_of, addr_of_mut};

use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hio};
use emu_common::{replay, Hooks, LineBuf};
use kernel::config::PAROL6_VALIDATED;
use kernel::Fx;
use panic_semihosting as _;

static SCENARIO_F32: &[u8] = include_bytes!("../../data/scenario_f32.bin");
static SCENARIO_FX: &[u8] = include_bytes!("../../data/scenario_fx.bin");

/// Written by every marker, so no two markers are identical functions.
static mut MARK: u32 = 0;

macro_rules! marker {
    ($name:ident, $v:expr) => {
        #[inline(never)]
        #[no_mangle]
        pub extern "C" fn $name() {
            // An asm statement without `nomem` may touch any memory: the
            // compiler cannot move loads or stores of the measured code
            // across the call.
            unsafe {
                core::arch::asm!("", options(nostack, preserves_flags));
                core::ptr::write_volatile(addr_of_mut!(MARK), $v);
            }
        }
    };
}
marker!(emu_cal_start, 1);
marker!(emu_cal_stop, 2);
marker!(emu_tick_f32_start, 3);
marker!(emu_tick_f32_stop, 4);
marker!(emu_parse_f32_start, 5);
marker!(emu_parse_f32_stop, 6);
marker!(emu_tick_fx_start, 7);
marker!(emu_tick_fx_stop, 8);
marker!(emu_parse_fx_start, 9);
marker!(emu_parse_fx_stop, 10);

/// Buffers stdout so each semihosting call writes many lines.
struct Out {
    stdout: hio::HostStream,
    buf: [u8; 8192],
    len: usize,
    /// Which marker set to use (0 f32, 1 fx).
    variant: u8,
    /// Stack pointer just before the current tick.
    tick_sp: usize,
    /// Deepest stack use of one tick, per variant (bytes below `tick_sp`).
    tick_stack: [usize; 2],
}

/// Stack window painted below the caller before every tick.
const TICK_WINDOW: usize = 8 * 1024;

impl Out {
    fn flush(&mut self) {
        let _ = self.stdout.write_all(&self.buf[..self.len]);
        self.len = 0;
    }
    fn push(&mut self, b: &[u8]) {
        if self.len + b.len() > self.buf.len() {
            self.flush();
        }
        if b.len() > self.buf.len() {
            let _ = self.stdout.write_all(b);
            return;
        }
        self.buf[self.len..self.len + b.len()].copy_from_slice(b);
        self.len += b.len();
    }
}

impl Hooks for Out {
    fn line(&mut self, text: &str) {
        self.push(text.as_bytes());
        self.push(b"\n");
    }
    fn before_parse(&mut self) {
        if self.variant == 0 {
            emu_parse_f32_start()
        } else {
            emu_parse_fx_start()
        }
    }
    fn after_parse(&mut self) {
        if self.variant == 0 {
            emu_parse_f32_stop()
        } else {
            emu_parse_fx_stop()
        }
    }
    fn before_tick(&mut self) {
        // Paint the window below the current stack pointer; after the tick
        // the lowest overwritten word gives that tick's stack depth.
        self.tick_sp = sp();
        let mut a = self.tick_sp - TICK_WINDOW;
        while a < self.tick_sp - 16 {
            unsafe { core::ptr::write_volatile(a as *mut u32, PAINT) };
            a += 4;
        }
        if self.variant == 0 {
            emu_tick_f32_start()
        } else {
            emu_tick_fx_start()
        }
    }
    fn after_tick(&mut self) {
        if self.variant == 0 {
            emu_tick_f32_stop()
        } else {
            emu_tick_fx_stop()
        }
        let low = stack_low_water(self.tick_sp - TICK_WINDOW, self.tick_sp - 16);
        let used = self.tick_sp - low;
        let v = usize::from(self.variant);
        self.tick_stack[v] = self.tick_stack[v].max(used);
    }
}

const CPACR: *mut u32 = 0xE000_ED88 as *mut u32;
const MVFR0: *const u32 = 0xE000_EF40 as *const u32;
const MVFR1: *const u32 = 0xE000_EF44 as *const u32;
const MVFR2: *const u32 = 0xE000_EF48 as *const u32;
const PAINT: u32 = 0xC0DE_5AFE;

extern "C" {
    static _stack_start: u32;
    static __sheap: u32;
}

fn sp() -> usize {
    let sp: usize;
    unsafe { core::arch::asm!("mov {}, sp", out(reg) sp, options(nomem, nostack, preserves_flags)) };
    sp
}

/// Fills the unused stack (from the end of .bss up to 256 bytes below the
/// current stack pointer) with a pattern, to measure the deepest stack use.
fn paint_stack() -> (usize, usize) {
    let lo = addr_of!(__sheap) as usize;
    let hi = sp() - 256;
    let mut a = lo;
    while a < hi {
        unsafe { core::ptr::write_volatile(a as *mut u32, PAINT) };
        a += 4;
    }
    (lo, hi)
}

/// Lowest address whose painted word was overwritten.
fn stack_low_water(lo: usize, hi: usize) -> usize {
    let mut a = lo;
    while a < hi && unsafe { core::ptr::read_volatile(a as *const u32) } == PAINT {
        a += 4;
    }
    a
}

#[entry]
fn main() -> ! {
    let mut err = hio::hstderr().ok();
    let mut ok = true;
    macro_rules! note {
        ($($t:tt)*) => {{
            if let Some(e) = err.as_mut() {
                let mut l = LineBuf::new();
                let _ = write!(l, $($t)*);
                let _ = e.write_all(l.as_str().as_bytes());
                let _ = e.write_all(b"\n");
            }
        }};
    }

    // FPU: cortex-m-rt's reset handler already grants CP10/CP11 full access
    // on an `eabihf` target; do it again explicitly (idempotent) and check.
    let before = unsafe { core::ptr::read_volatile(CPACR) };
    unsafe {
        core::ptr::write_volatile(CPACR, before | (0b1111 << 20));
        core::arch::asm!("dsb", "isb", options(nostack, preserves_flags));
    }
    let cpacr = unsafe { core::ptr::read_volatile(CPACR) };
    let (m0, m1, m2) = unsafe { (MVFR0.read_volatile(), MVFR1.read_volatile(), MVFR2.read_volatile()) };
    note!("fpu: CPACR at entry {before:#010x}, now {cpacr:#010x}; MVFR0 {m0:#010x} MVFR1 {m1:#010x} MVFR2 {m2:#010x}");
    if (cpacr >> 20) & 0xF != 0xF {
        note!("FAIL: CP10/CP11 not enabled");
        ok = false;
    }
    // IEEE single precision in hardware: 1/3 rounds to 0x3eaaaaab; a*b+c
    // rounded twice (no fusion) differs from the fused result here.
    let third = core::hint::black_box(1.0f32) / core::hint::black_box(3.0f32);
    let (a, b, c) = (
        core::hint::black_box(1.0f32 + f32::EPSILON),
        core::hint::black_box(1.0f32 - f32::EPSILON),
        core::hint::black_box(-1.0f32),
    );
    let unfused = a * b + c;
    note!("fpu: 1/3 = {:#010x}, (1+e)(1-e)-1 = {:#010x} (separately rounded: 0x00000000; fused would be -e^2 = 0xa5000000)", third.to_bits(), unfused.to_bits());
    if third.to_bits() != 0x3eaa_aaab || unfused.to_bits() != 0 {
        note!("FAIL: unexpected floating-point result");
        ok = false;
    }

    note!(
        "ram: size_of Kernel<f32> {} B, Kernel<Fx> {} B, Parser<f32> {} B, Parser<Fx> {} B, TickOutput<f32> {} B, TickOutput<Fx> {} B",
        core::mem::size_of::<kernel::KernelF32>(),
        core::mem::size_of::<kernel::KernelFx>(),
        core::mem::size_of::<protocol::Parser<f32>>(),
        core::mem::size_of::<protocol::Parser<Fx>>(),
        core::mem::size_of::<kernel::TickOutput<f32>>(),
        core::mem::size_of::<kernel::TickOutput<Fx>>()
    );
    let (lo, hi) = paint_stack();
    let top = addr_of!(_stack_start) as usize;

    // Marker overhead: 16 empty measured regions.
    for _ in 0..16 {
        emu_cal_start();
        emu_cal_stop();
    }

    let mut out = Out {
        stdout: match hio::hstdout() {
            Ok(s) => s,
            Err(()) => {
                debug::exit(debug::EXIT_FAILURE);
                // Not reached under QEMU (semihosting exit ends the run).
                loop {
                    cortex_m::asm::wfi();
                }
            }
        },
        buf: [0; 8192],
        len: 0,
        variant: 0,
        tick_sp: 0,
        tick_stack: [0; 2],
    };
    match replay::<f32, _>(&PAROL6_VALIDATED, SCENARIO_F32, &mut out) {
        Ok(n) => note!("f32: {n} ticks replayed"),
        Err(e) => {
            note!("FAIL: f32 scenario: {e:?}");
            ok = false;
        }
    }
    out.variant = 1;
    match replay::<Fx, _>(&PAROL6_VALIDATED, SCENARIO_FX, &mut out) {
        Ok(n) => note!("fx: {n} ticks replayed"),
        Err(e) => {
            note!("FAIL: fx scenario: {e:?}");
            ok = false;
        }
    }
    out.flush();

    let low = stack_low_water(lo, hi);
    for (v, name) in ["f32", "fx"].iter().enumerate() {
        let d = out.tick_stack[v];
        note!(
            "stack: {name} tick, deepest use {d} bytes below the caller's stack pointer{}",
            if d + 16 >= TICK_WINDOW { " (window full: at least this)" } else { "" }
        );
    }
    note!("stack: whole program (main, replay, formatting, tick), deepest use {} bytes (top {top:#x}, low-water {low:#x}, painted {lo:#x}..{hi:#x})", top - low);
    note!("{}", if ok { "emu-target: PASS" } else { "emu-target: FAIL" });
    debug::exit(if ok { debug::EXIT_SUCCESS } else { debug::EXIT_FAILURE });
    loop {
        cortex_m::asm::wfi();
    }
}
