#![no_std]
#![forbid(unsafe_code)]
//! Thin register-level HAL for the PAROL6 controller on a Teensy 4.1
//! (i.MXRT1062, Cortex-M7 at 600 MHz).
//!
//! # Split
//!
//! * [`pure`] — all arithmetic and tables, no registers, no dependencies,
//!   host-tested with `cargo test -p hal-imxrt`:
//!   [`pure::frame`] (edge-aligned whole-frame MT6816 capture decode and
//!   frame-period measurement), [`pure::encoder`] (MT6816 readings, the
//!   decode's definition, the continuity tracker), [`pure::channel`]
//!   (decoder + tracker: one encoder input as the firmware ships it),
//!   [`pure::mt6816`] (the sensor's frame, clock and counts per revolution),
//!   [`pure::clock`] (PIT load, QuadTimer prescaler, DIR settle, watchdog),
//!   [`pure::clock_check`] (the core clock against the 32.768 kHz crystal),
//!   [`pure::march`] (the March C- RAM test),
//!   [`pure::uart`] (LPUART OSR/SBR search), [`pure::step`] (step rate ->
//!   FlexPWM period/prescaler), [`pure::pins`] (Teensy 4.1 pin database and
//!   the compile-time-checked pin map), [`pure::debounce`] (limit switches),
//!   [`pure::tmc5160`] (the TMC5160 SPI datagram, its decoding, the boot
//!   check and the run-time poll; `periph::lpspi` drives LPSPI3 for it).
//! * `periph` — compiled **only when `target_os = "none"`** (i.e. for
//!   `thumbv7em-none-eabihf`); no feature flag, so a host build can never
//!   pull in register code by accident. Thin drivers that own their
//!   `imxrt-ral` instance and touch registers only through `imxrt-ral`'s
//!   `read_reg!`/`modify_reg!`/`write_reg!`; the DWT cycle counter comes from
//!   the `cortex-m` crate. Every number they program comes from [`pure`].
//!   Build: `cargo build -p hal-imxrt --target thumbv7em-none-eabihf`.
//!
//! # `unsafe`
//!
//! The crate is `#![forbid(unsafe_code)]`: `imxrt-ral` register access through
//! an owned instance is safe. The one unsafe step — creating the instances
//! (`imxrt_ral::pit::PIT::instance()` etc.) — is the caller's, once at boot;
//! its `// SAFETY:` argument is that each instance is created exactly once and
//! moved into exactly one driver here (`periph::gpio::Gpios` is the single
//! owner of GPIO1..4, shared by DIR and limits via atomic set/clear and
//! read-only PSR access).
//!
//! # Dependencies
//!
//! `imxrt-ral` 0.6 (register access), `cortex-m` 0.7 (DWT/DCB, critical
//! section), both target-only. Hand-written instead of a crate: the baud
//! search (imxrt-hal's is not a pure function), the MT6816 decoder and the pin
//! database (no crate knows this board); `imxrt-iomuxc`'s type-state pins do
//! not fit a pin map chosen by a `const` table.
//!
//! # What this crate does not do
//!
//! It does not set up the ARM PLL (600 MHz), AHB/IPG dividers (IPG 150 MHz)
//! or the boot image; the firmware's boot code does that and [`pure::clock`]
//! states the assumed tree. `periph::clocks` only selects PERCLK and
//! UART_CLK_ROOT (both 24 MHz from the crystal) and opens clock gates.
//!
//! # Register facts the C++ design has wrong
//!
//! * QuadTimer gated count is `CTRL[CM] = 0b011` ("count rising edges of
//!   primary source while secondary input high", imxrt-ral field docs from
//!   NXP's SVD). `CM = 6` is "edge of secondary source triggers primary count
//!   until compare", which does not gate. `periph` uses 3.
//! * Serial1 on pins 0/1 is **LPUART6** (pads GPIO_AD_B0_03/02, ALT2), not
//!   LPUART1 (which is on pins 24/25, here limit switches).
//! * An MT6816 is read over whole frames, edge-aligned (QuadTimer gated count
//!   plus capture on the rising edge, [`pure::frame`]), not as a duty average
//!   over a fixed window: a window that is not a whole number of frames
//!   has a phase error (the part of a frame it misses may be high or low),
//!   and one that spans the 0/4095 wrap reads a valid-looking angle in
//!   between.

pub mod pure;

#[cfg(target_os = "none")]
pub mod periph;
