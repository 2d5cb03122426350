//! IOMUXC pad multiplexing and pad electrical configuration.
//!
//! ALT values and select-input (daisy) values come from [`crate::pure::pins`];
//! see its docs for sources and which values need bench confirmation.
//! Written against the raw `SW_MUX_CTL`/`SW_PAD_CTL` registers because the
//! type-state pin API of `imxrt-iomuxc` does not fit a pin map chosen by a
//! `const` table.

use crate::pure::pins::{self, Pad, PinMap, PinMapError, GPIO_ALT};
use imxrt_ral as ral;
use ral::{iomuxc, iomuxc_gpr};

/// `SW_MUX_CTL[SION]`: force the input path on.
const SION: u32 = 1 << 4;

// SW_PAD_CTL fields (i.MXRT1060 RM, IOMUXC chapter): SRE bit 0, DSE 5:3,
// SPEED 7:6, ODE 11, PKE 12, PUE 13, PUS 15:14, HYS 16.
const DSE_R0_6: u32 = 6 << 3;
const SPEED_100MHZ: u32 = 2 << 6;
const PKE: u32 = 1 << 12;
const PUE: u32 = 1 << 13;
const PUS_100K_DOWN: u32 = 0 << 14;
const PUS_22K_UP: u32 = 3 << 14;
const HYS: u32 = 1 << 16;

/// Push-pull output, R0/6 drive, 100 MHz, keeper (NXP's usual 0x10B0).
pub const PAD_OUTPUT: u32 = DSE_R0_6 | SPEED_100MHZ | PKE;
/// Input with 22 k pull-up and hysteresis (limit switches, UART RX).
pub const PAD_INPUT_PULLUP: u32 = PKE | PUE | PUS_22K_UP | HYS;
/// Input with 100 k pull-down and hysteresis (encoder PWM): a disconnected
/// encoder reads stuck low -> `LossReason::NoSignal`.
pub const PAD_INPUT_PULLDOWN: u32 = PKE | PUE | PUS_100K_DOWN | HYS;

macro_rules! pad_table {
    ($($pad:ident => $mux:ident, $ctl:ident;)*) => {
        /// Write `SW_MUX_CTL` of a pad.
        pub fn set_mux(io: &iomuxc::IOMUXC, pad: Pad, value: u32) {
            match pad {
                $(Pad::$pad => ral::write_reg!(ral::iomuxc, io, $mux, value),)*
            }
        }
        /// Write `SW_PAD_CTL` of a pad.
        pub fn set_pad(io: &iomuxc::IOMUXC, pad: Pad, value: u32) {
            match pad {
                $(Pad::$pad => ral::write_reg!(ral::iomuxc, io, $ctl, value),)*
            }
        }
    };
}

pad_table! {
    GPIO_AD_B0_02 => SW_MUX_CTL_PAD_GPIO_AD_B0_02, SW_PAD_CTL_PAD_GPIO_AD_B0_02;
    GPIO_AD_B0_03 => SW_MUX_CTL_PAD_GPIO_AD_B0_03, SW_PAD_CTL_PAD_GPIO_AD_B0_03;
    GPIO_AD_B0_12 => SW_MUX_CTL_PAD_GPIO_AD_B0_12, SW_PAD_CTL_PAD_GPIO_AD_B0_12;
    GPIO_AD_B0_13 => SW_MUX_CTL_PAD_GPIO_AD_B0_13, SW_PAD_CTL_PAD_GPIO_AD_B0_13;
    GPIO_AD_B1_00 => SW_MUX_CTL_PAD_GPIO_AD_B1_00, SW_PAD_CTL_PAD_GPIO_AD_B1_00;
    GPIO_AD_B1_01 => SW_MUX_CTL_PAD_GPIO_AD_B1_01, SW_PAD_CTL_PAD_GPIO_AD_B1_01;
    GPIO_AD_B1_02 => SW_MUX_CTL_PAD_GPIO_AD_B1_02, SW_PAD_CTL_PAD_GPIO_AD_B1_02;
    GPIO_AD_B1_03 => SW_MUX_CTL_PAD_GPIO_AD_B1_03, SW_PAD_CTL_PAD_GPIO_AD_B1_03;
    GPIO_AD_B1_04 => SW_MUX_CTL_PAD_GPIO_AD_B1_04, SW_PAD_CTL_PAD_GPIO_AD_B1_04;
    GPIO_AD_B1_05 => SW_MUX_CTL_PAD_GPIO_AD_B1_05, SW_PAD_CTL_PAD_GPIO_AD_B1_05;
    GPIO_AD_B1_06 => SW_MUX_CTL_PAD_GPIO_AD_B1_06, SW_PAD_CTL_PAD_GPIO_AD_B1_06;
    GPIO_AD_B1_07 => SW_MUX_CTL_PAD_GPIO_AD_B1_07, SW_PAD_CTL_PAD_GPIO_AD_B1_07;
    GPIO_AD_B1_08 => SW_MUX_CTL_PAD_GPIO_AD_B1_08, SW_PAD_CTL_PAD_GPIO_AD_B1_08;
    GPIO_AD_B1_09 => SW_MUX_CTL_PAD_GPIO_AD_B1_09, SW_PAD_CTL_PAD_GPIO_AD_B1_09;
    GPIO_AD_B1_10 => SW_MUX_CTL_PAD_GPIO_AD_B1_10, SW_PAD_CTL_PAD_GPIO_AD_B1_10;
    GPIO_AD_B1_11 => SW_MUX_CTL_PAD_GPIO_AD_B1_11, SW_PAD_CTL_PAD_GPIO_AD_B1_11;
    GPIO_AD_B1_12 => SW_MUX_CTL_PAD_GPIO_AD_B1_12, SW_PAD_CTL_PAD_GPIO_AD_B1_12;
    GPIO_AD_B1_13 => SW_MUX_CTL_PAD_GPIO_AD_B1_13, SW_PAD_CTL_PAD_GPIO_AD_B1_13;
    GPIO_AD_B1_14 => SW_MUX_CTL_PAD_GPIO_AD_B1_14, SW_PAD_CTL_PAD_GPIO_AD_B1_14;
    GPIO_AD_B1_15 => SW_MUX_CTL_PAD_GPIO_AD_B1_15, SW_PAD_CTL_PAD_GPIO_AD_B1_15;
    GPIO_B0_00 => SW_MUX_CTL_PAD_GPIO_B0_00, SW_PAD_CTL_PAD_GPIO_B0_00;
    GPIO_B0_01 => SW_MUX_CTL_PAD_GPIO_B0_01, SW_PAD_CTL_PAD_GPIO_B0_01;
    GPIO_B0_02 => SW_MUX_CTL_PAD_GPIO_B0_02, SW_PAD_CTL_PAD_GPIO_B0_02;
    GPIO_B0_03 => SW_MUX_CTL_PAD_GPIO_B0_03, SW_PAD_CTL_PAD_GPIO_B0_03;
    GPIO_B0_10 => SW_MUX_CTL_PAD_GPIO_B0_10, SW_PAD_CTL_PAD_GPIO_B0_10;
    GPIO_B0_11 => SW_MUX_CTL_PAD_GPIO_B0_11, SW_PAD_CTL_PAD_GPIO_B0_11;
    GPIO_B0_12 => SW_MUX_CTL_PAD_GPIO_B0_12, SW_PAD_CTL_PAD_GPIO_B0_12;
    GPIO_B1_00 => SW_MUX_CTL_PAD_GPIO_B1_00, SW_PAD_CTL_PAD_GPIO_B1_00;
    GPIO_B1_01 => SW_MUX_CTL_PAD_GPIO_B1_01, SW_PAD_CTL_PAD_GPIO_B1_01;
    GPIO_B1_02 => SW_MUX_CTL_PAD_GPIO_B1_02, SW_PAD_CTL_PAD_GPIO_B1_02;
    GPIO_B1_03 => SW_MUX_CTL_PAD_GPIO_B1_03, SW_PAD_CTL_PAD_GPIO_B1_03;
    GPIO_B1_12 => SW_MUX_CTL_PAD_GPIO_B1_12, SW_PAD_CTL_PAD_GPIO_B1_12;
    GPIO_B1_13 => SW_MUX_CTL_PAD_GPIO_B1_13, SW_PAD_CTL_PAD_GPIO_B1_13;
    GPIO_EMC_04 => SW_MUX_CTL_PAD_GPIO_EMC_04, SW_PAD_CTL_PAD_GPIO_EMC_04;
    GPIO_EMC_05 => SW_MUX_CTL_PAD_GPIO_EMC_05, SW_PAD_CTL_PAD_GPIO_EMC_05;
    GPIO_EMC_06 => SW_MUX_CTL_PAD_GPIO_EMC_06, SW_PAD_CTL_PAD_GPIO_EMC_06;
    GPIO_EMC_07 => SW_MUX_CTL_PAD_GPIO_EMC_07, SW_PAD_CTL_PAD_GPIO_EMC_07;
    GPIO_EMC_08 => SW_MUX_CTL_PAD_GPIO_EMC_08, SW_PAD_CTL_PAD_GPIO_EMC_08;
    GPIO_EMC_31 => SW_MUX_CTL_PAD_GPIO_EMC_31, SW_PAD_CTL_PAD_GPIO_EMC_31;
    GPIO_EMC_32 => SW_MUX_CTL_PAD_GPIO_EMC_32, SW_PAD_CTL_PAD_GPIO_EMC_32;
    GPIO_EMC_36 => SW_MUX_CTL_PAD_GPIO_EMC_36, SW_PAD_CTL_PAD_GPIO_EMC_36;
    GPIO_EMC_37 => SW_MUX_CTL_PAD_GPIO_EMC_37, SW_PAD_CTL_PAD_GPIO_EMC_37;
}

/// Route a standard-GPIO bit to GPIO1..4 (not the fast GPIO6..9) by clearing
/// its bit in IOMUXC_GPR26..29 (boot code such as the Teensy core sets them).
fn select_standard_gpio(gpr: &iomuxc_gpr::IOMUXC_GPR, b: pins::GpioBit) {
    let mask = 1u32 << (b.bit & 31);
    match b.port {
        1 => ral::modify_reg!(ral::iomuxc_gpr, gpr, GPR26, |r| r & !mask),
        2 => ral::modify_reg!(ral::iomuxc_gpr, gpr, GPR27, |r| r & !mask),
        3 => ral::modify_reg!(ral::iomuxc_gpr, gpr, GPR28, |r| r & !mask),
        _ => ral::modify_reg!(ral::iomuxc_gpr, gpr, GPR29, |r| r & !mask),
    }
}

fn qtimer_daisy(io: &iomuxc::IOMUXC, f: pins::QtimerFn) {
    let Some(v) = f.daisy else { return };
    let v = v as u32;
    match (f.module, f.channel) {
        (2, 0) => ral::write_reg!(ral::iomuxc, io, QTIMER2_TIMER0_SELECT_INPUT, v),
        (2, 1) => ral::write_reg!(ral::iomuxc, io, QTIMER2_TIMER1_SELECT_INPUT, v),
        (2, 2) => ral::write_reg!(ral::iomuxc, io, QTIMER2_TIMER2_SELECT_INPUT, v),
        (2, 3) => ral::write_reg!(ral::iomuxc, io, QTIMER2_TIMER3_SELECT_INPUT, v),
        (3, 0) => ral::write_reg!(ral::iomuxc, io, QTIMER3_TIMER0_SELECT_INPUT, v),
        (3, 1) => ral::write_reg!(ral::iomuxc, io, QTIMER3_TIMER1_SELECT_INPUT, v),
        (3, 2) => ral::write_reg!(ral::iomuxc, io, QTIMER3_TIMER2_SELECT_INPUT, v),
        (3, 3) => ral::write_reg!(ral::iomuxc, io, QTIMER3_TIMER3_SELECT_INPUT, v),
        _ => {}
    }
}

/// Configure every pin of `map` plus Serial1 (pins 0/1, LPUART6).
///
/// STEP: FlexPWM ALT, push-pull. DIR: GPIO (ALT5), push-pull. Encoder:
/// QuadTimer ALT1 + SION, pull-down, daisy for TMR2/TMR3. Limit: GPIO,
/// pull-up. Serial1: ALT2, LPUART6 RX/TX select-input = 1.
pub fn configure_pins(io: &iomuxc::IOMUXC, gpr: &iomuxc_gpr::IOMUXC_GPR, map: &PinMap) -> Result<(), PinMapError> {
    pins::check(map)?;
    for &p in &map.step {
        let (Some(tp), Some(f)) = (pins::teensy41_pin(p), pins::step_fn(p)) else {
            return Err(PinMapError::NotStepCapable(p));
        };
        set_pad(io, tp.pad, PAD_OUTPUT);
        if let pins::PwmRoute::Xbar { inout, .. } = f.route {
            // XBAR1_INOUT<n> as an output: IOMUXC_GPR6 bit 12 + n
            // (IOMUXC_XBAR_DIR_SEL_4..19 at bits 16..31).
            if (4..=19).contains(&inout) {
                let bit = 1u32 << (12 + u32::from(inout));
                ral::modify_reg!(ral::iomuxc_gpr, gpr, GPR6, |r| r | bit);
            } else {
                return Err(PinMapError::NotStepCapable(p));
            }
        }
        set_mux(io, tp.pad, f.alt as u32);
    }
    for &p in &map.dir {
        let Some(tp) = pins::teensy41_pin(p) else {
            return Err(PinMapError::UnknownPin(p));
        };
        select_standard_gpio(gpr, tp.gpio);
        set_pad(io, tp.pad, PAD_OUTPUT);
        set_mux(io, tp.pad, GPIO_ALT as u32);
    }
    for &p in &map.encoder {
        let (Some(tp), Some(f)) = (pins::teensy41_pin(p), pins::encoder_fn(p)) else {
            return Err(PinMapError::NotEncoderCapable(p));
        };
        set_pad(io, tp.pad, PAD_INPUT_PULLDOWN);
        set_mux(io, tp.pad, f.alt as u32 | SION);
        qtimer_daisy(io, f);
    }
    for &p in &map.limit {
        let Some(tp) = pins::teensy41_pin(p) else {
            return Err(PinMapError::UnknownPin(p));
        };
        select_standard_gpio(gpr, tp.gpio);
        set_pad(io, tp.pad, PAD_INPUT_PULLUP);
        set_mux(io, tp.pad, GPIO_ALT as u32);
    }
    // Serial1 = LPUART6: pin 0 RX = GPIO_AD_B0_03, pin 1 TX = GPIO_AD_B0_02.
    set_pad(io, Pad::GPIO_AD_B0_03, PAD_INPUT_PULLUP);
    set_mux(io, Pad::GPIO_AD_B0_03, pins::SERIAL_ALT as u32);
    set_pad(io, Pad::GPIO_AD_B0_02, PAD_OUTPUT);
    set_mux(io, Pad::GPIO_AD_B0_02, pins::SERIAL_ALT as u32);
    ral::write_reg!(ral::iomuxc, io, LPUART6_RX_SELECT_INPUT, pins::SERIAL_DAISY as u32);
    ral::write_reg!(ral::iomuxc, io, LPUART6_TX_SELECT_INPUT, pins::SERIAL_DAISY as u32);
    Ok(())
}

/// Configure the drivers' enable output ([`pins::EnablePin`]): its GPIO bit
/// is first set to the inactive level and made an output, then the pad is
/// switched to a push-pull GPIO. The pad was a GPIO input since reset (the
/// external pull held the line inactive), so the line never sees the
/// active level on the way.
pub fn configure_enable_pin(
    io: &iomuxc::IOMUXC,
    gpr: &iomuxc_gpr::IOMUXC_GPR,
    gpios: &super::gpio::Gpios,
    e: pins::EnablePin,
) -> Result<pins::GpioBit, PinMapError> {
    let Some(tp) = pins::teensy41_pin(e.pin) else {
        return Err(PinMapError::UnknownPin(e.pin));
    };
    gpios.write(tp.gpio, !e.active_high);
    gpios.make_output(tp.gpio);
    select_standard_gpio(gpr, tp.gpio);
    set_pad(io, tp.pad, PAD_OUTPUT);
    set_mux(io, tp.pad, GPIO_ALT as u32);
    Ok(tp.gpio)
}

/// Configure the TMC5160 link's pads (`pins::TMC_WIRING`): LPSPI3 SCK and
/// SDO push-pull, SDI with the 22 k pull-up (a missing driver reads all
/// ones), their select inputs; the chip selects as standard GPIO outputs
/// with the keeper (the caller drives them high before making them
/// outputs: `periph::lpspi::TmcLink::new`).
pub fn configure_tmc_pins(io: &iomuxc::IOMUXC, gpr: &iomuxc_gpr::IOMUXC_GPR, w: &pins::TmcWiring) {
    set_pad(io, w.sck.pad, PAD_OUTPUT);
    set_mux(io, w.sck.pad, u32::from(w.sck.alt));
    set_pad(io, w.sdo.pad, PAD_OUTPUT);
    set_mux(io, w.sdo.pad, u32::from(w.sdo.alt));
    set_pad(io, w.sdi.pad, PAD_INPUT_PULLUP);
    set_mux(io, w.sdi.pad, u32::from(w.sdi.alt));
    ral::write_reg!(ral::iomuxc, io, LPSPI3_SCK_SELECT_INPUT, u32::from(w.sck.daisy));
    ral::write_reg!(ral::iomuxc, io, LPSPI3_SDO_SELECT_INPUT, u32::from(w.sdo.daisy));
    ral::write_reg!(ral::iomuxc, io, LPSPI3_SDI_SELECT_INPUT, u32::from(w.sdi.daisy));
    for &p in &w.cs {
        if let Some(tp) = pins::teensy41_pin(p) {
            select_standard_gpio(gpr, tp.gpio);
            set_pad(io, tp.pad, PAD_OUTPUT);
            set_mux(io, tp.pad, GPIO_ALT as u32);
        }
    }
}
