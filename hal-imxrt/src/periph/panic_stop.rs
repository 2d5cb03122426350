//! Last-resort STEP shutdown for a panic handler: no driver state needed.
//!
//! The caller (the firmware's panic handler) creates the register-block
//! references itself (it cannot own the drivers, which belong to the tick).
//! Order per STEP pin: mask the FlexPWM output and stop its submodule, drive
//! the pin's GPIO bit low and make it an output, then switch the pad's mux
//! from FlexPWM to GPIO. The pin is low after each step, so it is never
//! driven high by this sequence. Assumes the pads' GPIO bits are routed to
//! the standard GPIO1..4 (IOMUXC_GPR26..29 bits 0, the reset value, which
//! this firmware never changes for STEP pins).

use super::iomux::set_mux;
use crate::pure::pins::{step_fn, teensy41_pin, EnablePin, PinMap, PwmOutput, GPIO_ALT};
use imxrt_ral as ral;
use ral::{gpio, iomuxc, pwm};

/// Force every STEP pin of `map` low. `pwm` = FlexPWM1..4, `gpio` =
/// GPIO1..4 (the standard GPIO ports of the Teensy pin database).
pub fn force_steps_low(
    pwm: [&pwm::RegisterBlock; 4],
    gpio: [&gpio::RegisterBlock; 4],
    io: &iomuxc::IOMUXC,
    map: &PinMap,
) {
    for &p in map.step.iter() {
        if let Some(f) = step_fn(p) {
            if let Some(rb) = pwm.get(usize::from(f.module.wrapping_sub(1) & 3)) {
                let bit = 1u16 << (f.submodule & 3);
                let m = match f.output {
                    PwmOutput::A => bit << 8,
                    PwmOutput::B => bit << 4,
                };
                ral::modify_reg!(ral::pwm, rb, MASK, |v| v | m | (bit << 12));
                ral::modify_reg!(ral::pwm, rb, MCTRL, |v| v & !(bit << 8));
            }
        }
        if let Some(tp) = teensy41_pin(p) {
            let m = 1u32 << (tp.gpio.bit & 31);
            if let Some(g) = gpio.get(usize::from(tp.gpio.port.wrapping_sub(1) & 3)) {
                ral::write_reg!(ral::gpio, g, DR_CLEAR, m);
                ral::modify_reg!(ral::gpio, g, GDIR, |v| v | m);
            }
            set_mux(io, tp.pad, u32::from(GPIO_ALT));
        }
    }
}

/// Drive the drivers' enable output to its inactive level (the fatal path:
/// torque off). The bit is made an output at that level, and the pad
/// switched to GPIO, so the line is inactive whatever state the enable
/// driver left it in.
pub fn force_enable_inactive(gpio: [&gpio::RegisterBlock; 4], io: &iomuxc::IOMUXC, e: EnablePin) {
    if let Some(tp) = teensy41_pin(e.pin) {
        let m = 1u32 << (tp.gpio.bit & 31);
        if let Some(g) = gpio.get(usize::from(tp.gpio.port.wrapping_sub(1) & 3)) {
            if e.active_high {
                ral::write_reg!(ral::gpio, g, DR_CLEAR, m);
            } else {
                ral::write_reg!(ral::gpio, g, DR_SET, m);
            }
            ral::modify_reg!(ral::gpio, g, GDIR, |v| v | m);
        }
        set_mux(io, tp.pad, u32::from(GPIO_ALT));
    }
}
