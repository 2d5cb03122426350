//! Register drivers, compiled only for `target_os = "none"`.
//!
//! Each driver owns its `imxrt-ral` instance(s) and touches registers only
//! through `imxrt_ral::{read_reg, modify_reg, write_reg}`; the DWT cycle counter
//! comes from `cortex-m`. All numbers come from [`crate::pure`].
//!
//! **None of this has run on hardware.** It compiles for
//! `thumbv7em-none-eabihf`; the register sequences follow the i.MXRT1060
//! reference-manual field descriptions as exposed by imxrt-ral and the Teensy
//! core. Items marked *bench* in the docs need confirmation on a board with a
//! scope before the arm is powered.
//!
//! Order of bring-up: [`clocks::configure`], [`iomux::configure_pins`],
//! [`cycles::CycleCounter::enable`], then the drivers; start
//! [`tick::Tick`] last and feed [`watchdog::Watchdog`] from its handler.

pub mod clock_check;
pub mod clocks;
pub mod cycles;
pub mod frame_capture;
pub mod gpio;
pub mod iomux;
pub mod lpspi;
pub mod panic_stop;
pub mod step;
pub mod tick;
pub mod uart;
pub mod watchdog;
