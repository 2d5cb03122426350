//! Teensy 4.1 pin database and the PAROL6 pin map, checked at compile time.
//!
//! # Default map: the original wiring
//!
//! | axis | STEP | timer                                   | DIR | encoder | TMR ch  | limit |
//! |------|-----:|-----------------------------------------|----:|--------:|---------|------:|
//! | J1   | 2    | FlexPWM4 sm2 A                          | 30  | 10      | TMR1 ch0 | 20 |
//! | J2   | 5    | FlexPWM2 sm1 A                          | 31  | 11      | TMR1 ch2 | 21 |
//! | J3   | 6    | FlexPWM2 sm2 A                          | 32  | 12      | TMR1 ch1 | 22 |
//! | J4   | 8    | FlexPWM1 sm3 A                          | 33  | 14      | TMR3 ch2 | 23 |
//! | J5   | 4    | FlexPWM2 sm0 A                          | 35  | 15      | TMR3 ch3 | 24 |
//! | J6   | 7    | FlexPWM2 sm3 A via `PWM_OUT_TRIG0` -> XBARA1 -> `XBAR1_INOUT15` | 34  | 19      | TMR3 ch0 | 25 |
//!
//! The C++ wiring put J4 on pin 8 (FlexPWM1 sm3 A) and J6 on pin 7, whose
//! own FlexPWM function is FlexPWM1 sm3 **B**: one submodule, one counter,
//! so J4 and J6 could never step at different rates. Pin 7 (GPIO_B1_01) has
//! another route (twin defect 8, twin/README.md): its ALT1 is `XBAR1_INOUT15`, and a
//! free submodule's trigger output can reach it through XBARA1. J6 uses
//! FlexPWM2 submodule 3 (free in this map) with `TCTRL[PWAOT0] = 1` (its
//! PWM_A waveform drives `PWM_OUT_TRIG0`), XBARA1 input 47
//! (`FLEXPWM2_PWM4_OUT_TRIG0_1`, NXP SDK `fsl_xbara` input table for the
//! RT1062) selected for output 15 (`SEL7[SEL15]`), `IOMUXC_GPR6` bit 27
//! (`IOMUXC_XBAR_DIR_SEL_15` = output) and the XBAR1 clock gate (CCGR2
//! CG11). The period math is that of pin 36 (the same submodule). So **no rewiring** is needed. The cargo feature `j6-pin36` of the
//! firmware selects [`J6_PIN36_PIN_MAP`] instead (J6 STEP moved to pin 36,
//! GPIO_B1_02, FlexPWM2 sm3 A on the pad directly, ALT6), the wiring of
//! earlier firmware.
//!
//! Every pin of the map is checked by [`check`] in a `const` context
//! ([`DEFAULT_PIN_MAP`] is built with [`PinMap::validated`]), so a map that
//! shares a FlexPWM submodule or a QuadTimer channel, or uses a pin twice
//! (including the Serial1 pins 0/1), does not compile. Pin 7 (XBAR route)
//! and pin 36 are both FlexPWM2 sm3:
//!
//! ```compile_fail
//! use hal_imxrt::pure::pins::{PinMap, DEFAULT_PIN_MAP};
//! const BAD: PinMap = PinMap { step: [2, 5, 6, 8, 36, 7], ..DEFAULT_PIN_MAP }.validated();
//! ```
//!
//! The original wiring compiles (control for the test above):
//!
//! ```
//! use hal_imxrt::pure::pins::{PinMap, DEFAULT_PIN_MAP};
//! const CPP: PinMap = PinMap { step: [2, 5, 6, 8, 4, 7], ..DEFAULT_PIN_MAP }.validated();
//! assert_eq!(CPP, DEFAULT_PIN_MAP);
//! ```
//!
//! The encoder map without pin 19 (the C++ omission) cannot be expressed (the
//! array has six entries); putting two encoders on one channel fails:
//!
//! ```compile_fail
//! use hal_imxrt::pure::pins::{PinMap, DEFAULT_PIN_MAP};
//! const BAD: PinMap = PinMap { encoder: [10, 11, 12, 14, 15, 10], ..DEFAULT_PIN_MAP }.validated();
//! ```
//!
//! # Sources and confidence
//!
//! Pad, GPIO bit, FlexPWM/QuadTimer function and ALT values come from the
//! Teensy 4.1 core (`pwm.c` / FreqMeasureMulti tables: "FlexPWM2_3_A 36
//! B1_02 ALT6", ...), teensy4-rs `teensy4-pins` (pin -> pad) and imxrt-iomuxc
//! (ALT values of FlexPWM pads, LPUART6 daisy), checked with the
//! QuadTimer3 select inputs against the reference material. The XBAR
//! route: `GPIO_B1_01` ALT1 = `XBAR1_INOUT15` and the GPR6 bit from the NXP
//! SDK pin/GPR headers; the input number from its XBARA1 input table.

/// i.MXRT1062 pads reachable from Teensy 4.1 pins 0..=41.
#[allow(non_camel_case_types, missing_docs)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pad {
    GPIO_AD_B0_02,
    GPIO_AD_B0_03,
    GPIO_AD_B0_12,
    GPIO_AD_B0_13,
    GPIO_AD_B1_00,
    GPIO_AD_B1_01,
    GPIO_AD_B1_02,
    GPIO_AD_B1_03,
    GPIO_AD_B1_04,
    GPIO_AD_B1_05,
    GPIO_AD_B1_06,
    GPIO_AD_B1_07,
    GPIO_AD_B1_08,
    GPIO_AD_B1_09,
    GPIO_AD_B1_10,
    GPIO_AD_B1_11,
    GPIO_AD_B1_12,
    GPIO_AD_B1_13,
    GPIO_AD_B1_14,
    GPIO_AD_B1_15,
    GPIO_B0_00,
    GPIO_B0_01,
    GPIO_B0_02,
    GPIO_B0_03,
    GPIO_B0_10,
    GPIO_B0_11,
    GPIO_B0_12,
    GPIO_B1_00,
    GPIO_B1_01,
    GPIO_B1_02,
    GPIO_B1_03,
    GPIO_B1_12,
    GPIO_B1_13,
    GPIO_EMC_04,
    GPIO_EMC_05,
    GPIO_EMC_06,
    GPIO_EMC_07,
    GPIO_EMC_08,
    GPIO_EMC_31,
    GPIO_EMC_32,
    GPIO_EMC_36,
    GPIO_EMC_37,
}

/// ALT mode selecting GPIO on every pad above.
pub const GPIO_ALT: u8 = 5;

/// Standard (slow) GPIO port 1..=4 and bit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpioBit {
    /// GPIO1..GPIO4.
    pub port: u8,
    /// Bit 0..=31.
    pub bit: u8,
}

/// FlexPWM output of a submodule.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PwmOutput {
    /// PWM_A (VAL2/VAL3).
    A,
    /// PWM_B (VAL4/VAL5).
    B,
}

/// How a FlexPWM output reaches its pad.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PwmRoute {
    /// The pad's ALT is the PWM output itself (`MASK`/`OUTEN` act on it).
    Pad,
    /// The submodule's PWM_A drives `PWM_OUT_TRIG0` (`TCTRL[PWAOT0]`),
    /// XBARA1 routes input `input` to output `inout` = `XBAR1_INOUT<inout>`,
    /// the pad's ALT selects that XBAR pin (`IOMUXC_GPR6` direction bit =
    /// output). `MASK`/`OUTEN` may not act on the trigger path: the output
    /// is stopped by selecting XBARA1 input 0 (`LOGIC_LOW`) instead.
    Xbar {
        /// XBARA1 output = IOMUX XBAR_INOUT number (4..=19).
        inout: u8,
        /// XBARA1 input of the submodule's `PWM_OUT_TRIG0_1`.
        input: u8,
    },
}

/// XBARA1 input 0: `LOGIC_LOW`.
pub const XBAR_LOGIC_LOW: u8 = 0;

/// A FlexPWM function of a pad.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FlexPwmFn {
    /// FlexPWM1..=4.
    pub module: u8,
    /// Submodule 0..=3 (one counter / period each).
    pub submodule: u8,
    /// Output.
    pub output: PwmOutput,
    /// IOMUXC ALT.
    pub alt: u8,
    /// How the output reaches the pad.
    pub route: PwmRoute,
}

/// A QuadTimer input function of a pad.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct QtimerFn {
    /// TMR1..=4.
    pub module: u8,
    /// Channel 0..=3 (its input pin index, used as SCS).
    pub channel: u8,
    /// IOMUXC ALT.
    pub alt: u8,
    /// `IOMUXC_QTIMERn_TIMERm_SELECT_INPUT` value, if that register exists
    /// (TMR2, TMR3); TMR1 and TMR4 have none.
    pub daisy: Option<u8>,
}

/// Everything known about one Teensy 4.1 pin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TeensyPin {
    /// Teensy pin number.
    pub pin: u8,
    /// Processor pad.
    pub pad: Pad,
    /// GPIO (ALT5).
    pub gpio: GpioBit,
    /// FlexPWM A/B output, if any (X outputs are not supported).
    pub pwm: Option<FlexPwmFn>,
    /// QuadTimer input, if any.
    pub qtimer: Option<QtimerFn>,
}

const fn g(port: u8, bit: u8) -> GpioBit {
    GpioBit { port, bit }
}
const fn pwm(module: u8, submodule: u8, output: PwmOutput, alt: u8) -> Option<FlexPwmFn> {
    Some(FlexPwmFn { module, submodule, output, alt, route: PwmRoute::Pad })
}

/// XBARA1 input of FlexPWM`module` submodule `submodule`'s
/// `PWM_OUT_TRIG0_1` (FlexPWM1..3: inputs 40..=51, four per module; NXP SDK
/// `fsl_xbara` input table of the RT1062; FlexPWM4 not listed here).
// Cannot overflow: module is 1..=3 and submodule 0..=3 (checked first), so
// the result is at most 51.
#[allow(clippy::arithmetic_side_effects)]
pub const fn xbar_trig_input(module: u8, submodule: u8) -> Option<u8> {
    if module >= 1 && module <= 3 && submodule <= 3 {
        Some(40 + 4 * (module - 1) + submodule)
    } else {
        None
    }
}

/// Pin 7's STEP route: FlexPWM2 sm3 A via `PWM_OUT_TRIG0`, XBARA1 input 47
/// -> output 15 = `XBAR1_INOUT15` = GPIO_B1_01 ALT1.
pub const PIN7_XBAR_STEP: FlexPwmFn = FlexPwmFn {
    module: 2,
    submodule: 3,
    output: PwmOutput::A,
    alt: 1,
    route: PwmRoute::Xbar {
        inout: 15,
        input: match xbar_trig_input(2, 3) {
            Some(i) => i,
            None => 0,
        },
    },
};
const fn qt(module: u8, channel: u8, daisy: Option<u8>) -> Option<QtimerFn> {
    Some(QtimerFn { module, channel, alt: 1, daisy })
}

/// Teensy 4.1 pin database (pins 0..=41).
pub const fn teensy41_pin(pin: u8) -> Option<TeensyPin> {
    use Pad::*;
    use PwmOutput::{A, B};
    let (pad, gpio, pwm, qtimer) = match pin {
        0 => (GPIO_AD_B0_03, g(1, 3), None, None),
        1 => (GPIO_AD_B0_02, g(1, 2), None, None),
        2 => (GPIO_EMC_04, g(4, 4), pwm(4, 2, A, 1), None),
        3 => (GPIO_EMC_05, g(4, 5), pwm(4, 2, B, 1), None),
        4 => (GPIO_EMC_06, g(4, 6), pwm(2, 0, A, 1), None),
        5 => (GPIO_EMC_08, g(4, 8), pwm(2, 1, A, 1), None),
        6 => (GPIO_B0_10, g(2, 10), pwm(2, 2, A, 2), qt(4, 1, None)),
        7 => (GPIO_B1_01, g(2, 17), pwm(1, 3, B, 6), None),
        8 => (GPIO_B1_00, g(2, 16), pwm(1, 3, A, 6), None),
        9 => (GPIO_B0_11, g(2, 11), pwm(2, 2, B, 2), qt(4, 2, None)),
        10 => (GPIO_B0_00, g(2, 0), None, qt(1, 0, None)),
        11 => (GPIO_B0_02, g(2, 2), None, qt(1, 2, None)),
        12 => (GPIO_B0_01, g(2, 1), None, qt(1, 1, None)),
        13 => (GPIO_B0_03, g(2, 3), None, qt(2, 0, Some(1))),
        14 => (GPIO_AD_B1_02, g(1, 18), None, qt(3, 2, Some(1))),
        15 => (GPIO_AD_B1_03, g(1, 19), None, qt(3, 3, Some(1))),
        16 => (GPIO_AD_B1_07, g(1, 23), None, None),
        17 => (GPIO_AD_B1_06, g(1, 22), None, None),
        18 => (GPIO_AD_B1_01, g(1, 17), None, qt(3, 1, Some(0))),
        19 => (GPIO_AD_B1_00, g(1, 16), None, qt(3, 0, Some(1))),
        20 => (GPIO_AD_B1_10, g(1, 26), None, None),
        21 => (GPIO_AD_B1_11, g(1, 27), None, None),
        22 => (GPIO_AD_B1_08, g(1, 24), pwm(4, 0, A, 1), None),
        23 => (GPIO_AD_B1_09, g(1, 25), pwm(4, 1, A, 1), None),
        24 => (GPIO_AD_B0_12, g(1, 12), None, None),
        25 => (GPIO_AD_B0_13, g(1, 13), None, None),
        26 => (GPIO_AD_B1_14, g(1, 30), None, None),
        27 => (GPIO_AD_B1_15, g(1, 31), None, None),
        28 => (GPIO_EMC_32, g(3, 18), pwm(3, 1, B, 1), None),
        29 => (GPIO_EMC_31, g(4, 31), pwm(3, 1, A, 1), None),
        30 => (GPIO_EMC_37, g(3, 23), None, None),
        31 => (GPIO_EMC_36, g(3, 22), None, None),
        32 => (GPIO_B0_12, g(2, 12), None, None),
        33 => (GPIO_EMC_07, g(4, 7), pwm(2, 0, B, 1), None),
        34 => (GPIO_B1_13, g(2, 29), None, None),
        35 => (GPIO_B1_12, g(2, 28), None, None),
        36 => (GPIO_B1_02, g(2, 18), pwm(2, 3, A, 6), None),
        37 => (GPIO_B1_03, g(2, 19), pwm(2, 3, B, 6), None),
        38 => (GPIO_AD_B1_12, g(1, 28), None, None),
        39 => (GPIO_AD_B1_13, g(1, 29), None, None),
        40 => (GPIO_AD_B1_04, g(1, 20), None, None),
        41 => (GPIO_AD_B1_05, g(1, 21), None, None),
        _ => return None,
    };
    Some(TeensyPin { pin, pad, gpio, pwm, qtimer })
}

/// Serial1 = LPUART6: pin 0 RX (GPIO_AD_B0_03), pin 1 TX (GPIO_AD_B0_02),
/// ALT2, select-input (daisy) value 1 for both.
pub const SERIAL_PINS: [u8; 2] = [0, 1];
/// LPUART6 ALT on pins 0/1.
pub const SERIAL_ALT: u8 = 2;
/// LPUART6 RX/TX select-input value for pads AD_B0_03 / AD_B0_02.
pub const SERIAL_DAISY: u8 = 1;

/// The pins of the six axes J1..J6.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PinMap {
    /// STEP outputs (FlexPWM A/B), each on its own submodule.
    pub step: [u8; 6],
    /// DIR outputs (GPIO).
    pub dir: [u8; 6],
    /// Encoder PWM inputs (QuadTimer), each on its own channel.
    pub encoder: [u8; 6],
    /// Limit switch inputs (GPIO, pull-up, active low).
    pub limit: [u8; 6],
}

/// Why a pin map is invalid. The payload is the offending Teensy pin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PinMapError {
    /// Not a Teensy 4.1 pin of the database.
    UnknownPin(u8),
    /// STEP pin without a FlexPWM A/B function.
    NotStepCapable(u8),
    /// Two STEP pins on one FlexPWM submodule (second pin reported).
    StepSubmoduleShared(u8),
    /// Encoder pin without a QuadTimer input.
    NotEncoderCapable(u8),
    /// Two encoder pins on one QuadTimer channel (second pin reported).
    EncoderChannelShared(u8),
    /// A pin used twice across STEP/DIR/encoder/limit/serial (second use).
    PinUsedTwice(u8),
    /// The driver-enable output on a pin the map, the LED or the TMC5160
    /// SPI link already uses.
    EnablePinTaken(u8),
}

impl PinMapError {
    /// Static message (usable in `const` panics).
    pub const fn message(self) -> &'static str {
        match self {
            PinMapError::UnknownPin(_) => "pin map: unknown Teensy 4.1 pin",
            PinMapError::NotStepCapable(_) => "pin map: STEP pin has no FlexPWM A/B output",
            PinMapError::StepSubmoduleShared(_) => {
                "pin map: two STEP pins share one FlexPWM submodule (cannot run at different rates)"
            }
            PinMapError::NotEncoderCapable(_) => "pin map: encoder pin has no QuadTimer input",
            PinMapError::EncoderChannelShared(_) => "pin map: two encoder pins share one QuadTimer channel",
            PinMapError::PinUsedTwice(_) => "pin map: a pin is used twice (STEP/DIR/encoder/limit/serial 0,1)",
            PinMapError::EnablePinTaken(_) => {
                "pin map: the driver-enable pin is already used (axis map, Serial1, LED 13 or the TMC5160 link)"
            }
        }
    }
}

/// Check a pin map (see module docs).
pub const fn check(map: &PinMap) -> Result<(), PinMapError> {
    // every pin known
    let all = map.all_pins();
    let mut rest: &[u8] = &all;
    while let Some((&p, tail)) = rest.split_first() {
        if teensy41_pin(p).is_none() {
            return Err(PinMapError::UnknownPin(p));
        }
        // no pin twice
        let mut later: &[u8] = tail;
        while let Some((&q, t2)) = later.split_first() {
            if p == q {
                return Err(PinMapError::PinUsedTwice(q));
            }
            later = t2;
        }
        rest = tail;
    }
    // STEP: FlexPWM, distinct submodules
    let mut rest: &[u8] = &map.step;
    while let Some((&p, tail)) = rest.split_first() {
        let Some(a) = step_fn(p) else {
            return Err(PinMapError::NotStepCapable(p));
        };
        let mut later: &[u8] = tail;
        while let Some((&q, t2)) = later.split_first() {
            if let Some(b) = step_fn(q) {
                if a.module == b.module && a.submodule == b.submodule {
                    return Err(PinMapError::StepSubmoduleShared(q));
                }
            }
            later = t2;
        }
        rest = tail;
    }
    // encoders: QuadTimer, distinct channels
    let mut rest: &[u8] = &map.encoder;
    while let Some((&p, tail)) = rest.split_first() {
        let Some(a) = encoder_fn(p) else {
            return Err(PinMapError::NotEncoderCapable(p));
        };
        let mut later: &[u8] = tail;
        while let Some((&q, t2)) = later.split_first() {
            if let Some(b) = encoder_fn(q) {
                if a.module == b.module && a.channel == b.channel {
                    return Err(PinMapError::EncoderChannelShared(q));
                }
            }
            later = t2;
        }
        rest = tail;
    }
    Ok(())
}

/// STEP function of a pin, if any: the pad's own FlexPWM output, except
/// pin 7, which uses the XBAR route [`PIN7_XBAR_STEP`] (its own function,
/// FlexPWM1 sm3 B, shares the submodule of pin 8).
pub const fn step_fn(pin: u8) -> Option<FlexPwmFn> {
    if pin == 7 {
        return Some(PIN7_XBAR_STEP);
    }
    match teensy41_pin(pin) {
        Some(p) => p.pwm,
        None => None,
    }
}

/// QuadTimer input of a pin, if any.
pub const fn encoder_fn(pin: u8) -> Option<QtimerFn> {
    match teensy41_pin(pin) {
        Some(p) => p.qtimer,
        None => None,
    }
}

impl PinMap {
    /// All 26 pins: STEP, DIR, encoder, limit, serial.
    pub const fn all_pins(&self) -> [u8; 26] {
        let [s0, s1, s2, s3, s4, s5] = self.step;
        let [d0, d1, d2, d3, d4, d5] = self.dir;
        let [e0, e1, e2, e3, e4, e5] = self.encoder;
        let [l0, l1, l2, l3, l4, l5] = self.limit;
        let [r0, r1] = SERIAL_PINS;
        [s0, s1, s2, s3, s4, s5, d0, d1, d2, d3, d4, d5, e0, e1, e2, e3, e4, e5, l0, l1, l2, l3, l4, l5, r0, r1]
    }

    /// Return `self` if [`check`] passes; otherwise panic, which in a `const`
    /// context is a compile error.
    pub const fn validated(self) -> Self {
        match check(&self) {
            Ok(()) => self,
            Err(e) => panic!("{}", e.message()),
        }
    }
}

/// The PAROL6 pin map of this firmware: the original wiring (J6 STEP on
/// pin 7 through XBARA1, see module docs).
pub const DEFAULT_PIN_MAP: PinMap = PinMap {
    step: [2, 5, 6, 8, 4, 7],
    dir: [30, 31, 32, 33, 35, 34],
    encoder: [10, 11, 12, 14, 15, 19],
    limit: [20, 21, 22, 23, 24, 25],
}
.validated();

/// The map with J6 STEP rewired to pin 36 (firmware feature `j6-pin36`).
pub const J6_PIN36_PIN_MAP: PinMap = PinMap { step: [2, 5, 6, 8, 4, 36], ..DEFAULT_PIN_MAP }.validated();

const _: () = assert!(check(&DEFAULT_PIN_MAP).is_ok());

/// An LPSPI signal on a pad: the pad's ALT and the value of the signal's
/// select-input (daisy) register that picks this pad.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SpiPad {
    /// Teensy pin.
    pub pin: u8,
    /// Processor pad.
    pub pad: Pad,
    /// IOMUXC ALT of the LPSPI3 signal.
    pub alt: u8,
    /// `IOMUXC_LPSPI3_<signal>_SELECT_INPUT` value for this pad.
    pub daisy: u8,
}

/// The TMC5160 drivers' SPI link (firmware feature `tmc5160-spi`): LPSPI3
/// on its Teensy 4.1 "SPI1" pads, mode 3, and one chip select per driver as
/// a plain GPIO output (active low, driven high at boot before the pad is
/// switched to GPIO).
///
/// | signal | Teensy pin | pad | function |
/// |---|---:|---|---|
/// | SCK  | 27 | GPIO_AD_B1_15 | LPSPI3_SCK, ALT2, SCK select input 1 |
/// | SDO (MOSI, to every driver's SDI) | 26 | GPIO_AD_B1_14 | LPSPI3_SDO, ALT2, SDO select input 1 |
/// | SDI (MISO, from every driver's SDO) | 39 | GPIO_AD_B1_13 | LPSPI3_SDI, ALT2, SDI select input 1 |
/// | CS J1..J6 | 38, 40, 41, 17, 16, 28 | AD_B1_12, AD_B1_04, AD_B1_05, AD_B1_06, AD_B1_07, EMC_32 | GPIO |
///
/// The ALT and select-input values are those of `imxrt-iomuxc`'s i.MXRT1060
/// LPSPI table (LPSPI3 SCK/SDO/SDI on GPIO_AD_B1_15/14/13, ALT2, daisy 1);
/// the pins from `teensy4-pins` (pin 39 = GPIO_AD_B1_13, 40/41 =
/// GPIO_AD_B1_04/05, 38 = GPIO_AD_B1_12). None of these pins is in the
/// axis map, Serial1 or the LED (checked by [`check_tmc`] at compile time).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TmcWiring {
    /// LPSPI3 SCK.
    pub sck: SpiPad,
    /// LPSPI3 SDO (controller out).
    pub sdo: SpiPad,
    /// LPSPI3 SDI (controller in).
    pub sdi: SpiPad,
    /// Chip select of the driver of J1..J6 (GPIO, active low).
    pub cs: [u8; 6],
}

/// The Teensy LED (pin 13), which the image drives on a fatal fault.
pub const LED_PIN: u8 = 13;

/// The TMC5160 wiring of this firmware (see [`TmcWiring`]).
pub const TMC_WIRING: TmcWiring = TmcWiring {
    sck: SpiPad { pin: 27, pad: Pad::GPIO_AD_B1_15, alt: 2, daisy: 1 },
    sdo: SpiPad { pin: 26, pad: Pad::GPIO_AD_B1_14, alt: 2, daisy: 1 },
    sdi: SpiPad { pin: 39, pad: Pad::GPIO_AD_B1_13, alt: 2, daisy: 1 },
    cs: [38, 40, 41, 17, 16, 28],
};

/// Check the TMC5160 wiring against an axis map: every pin known, each SPI
/// pin on the pad its record names, no pin used twice (within the wiring,
/// by the map, Serial1 or the LED).
pub const fn check_tmc(map: &PinMap, w: &TmcWiring) -> Result<(), PinMapError> {
    let spi = [w.sck, w.sdo, w.sdi];
    let mut rest: &[SpiPad] = &spi;
    while let Some((s, tail)) = rest.split_first() {
        match teensy41_pin(s.pin) {
            Some(tp) if pad_eq(tp.pad, s.pad) => {}
            _ => return Err(PinMapError::UnknownPin(s.pin)),
        }
        rest = tail;
    }
    let [c0, c1, c2, c3, c4, c5] = w.cs;
    let own = [w.sck.pin, w.sdo.pin, w.sdi.pin, c0, c1, c2, c3, c4, c5];
    let taken = map.all_pins();
    let mut rest: &[u8] = &own;
    while let Some((&p, tail)) = rest.split_first() {
        if teensy41_pin(p).is_none() {
            return Err(PinMapError::UnknownPin(p));
        }
        if p == LED_PIN {
            return Err(PinMapError::PinUsedTwice(p));
        }
        let mut later: &[u8] = tail;
        while let Some((&q, t2)) = later.split_first() {
            if p == q {
                return Err(PinMapError::PinUsedTwice(q));
            }
            later = t2;
        }
        let mut other: &[u8] = &taken;
        while let Some((&q, t2)) = other.split_first() {
            if p == q {
                return Err(PinMapError::PinUsedTwice(p));
            }
            other = t2;
        }
        rest = tail;
    }
    Ok(())
}

const fn pad_eq(a: Pad, b: Pad) -> bool {
    a as u8 == b as u8
}

const _: () = assert!(check_tmc(&DEFAULT_PIN_MAP, &TMC_WIRING).is_ok());
const _: () = assert!(check_tmc(&J6_PIN36_PIN_MAP, &TMC_WIRING).is_ok());

/// The stepper drivers' shared enable output: one GPIO driving every
/// TMC5160's `DRV_ENN` (the power stage is off while `DRV_ENN` is high).
/// Optional (firmware feature `driver-enable`): a board that wires it lets
/// the image remove torque; the default image never touches the pin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EnablePin {
    /// Teensy pin.
    pub pin: u8,
    /// Level that enables the drivers: `false` for `DRV_ENN` wired
    /// directly (active low).
    pub active_high: bool,
}

/// Check an enable pin against a map: a known pin, used by nothing else
/// (the map's 26 pins, the LED, the TMC5160 link's SPI pins and chip
/// selects, [`TMC_WIRING`]).
pub const fn check_enable_pin(e: EnablePin, map: &PinMap) -> Result<(), PinMapError> {
    if teensy41_pin(e.pin).is_none() {
        return Err(PinMapError::UnknownPin(e.pin));
    }
    let all = map.all_pins();
    let mut rest: &[u8] = &all;
    while let Some((&p, tail)) = rest.split_first() {
        if p == e.pin {
            return Err(PinMapError::EnablePinTaken(e.pin));
        }
        rest = tail;
    }
    let w = TMC_WIRING;
    let [c0, c1, c2, c3, c4, c5] = w.cs;
    let tmc = [w.sck.pin, w.sdo.pin, w.sdi.pin, c0, c1, c2, c3, c4, c5];
    let mut rest: &[u8] = &tmc;
    while let Some((&p, tail)) = rest.split_first() {
        if p == e.pin {
            return Err(PinMapError::EnablePinTaken(e.pin));
        }
        rest = tail;
    }
    if e.pin == LED_PIN {
        return Err(PinMapError::EnablePinTaken(e.pin));
    }
    Ok(())
}

impl EnablePin {
    /// Return `self` if [`check_enable_pin`] passes against both maps of
    /// this firmware; otherwise panic (a compile error in a `const`).
    pub const fn validated(self) -> Self {
        if let Err(e) = check_enable_pin(self, &DEFAULT_PIN_MAP) {
            panic!("{}", e.message());
        }
        if let Err(e) = check_enable_pin(self, &J6_PIN36_PIN_MAP) {
            panic!("{}", e.message());
        }
        self
    }
}

/// The drivers' enable line: pin 3 (GPIO_EMC_05, GPIO4 bit 5), active low,
/// wired to every TMC5160's `DRV_ENN`, with a 10 kOhm pull-up to the
/// drivers' 3.3 V logic supply at the drivers. After any reset the pad is
/// an input (no drive), so the pull-up holds `DRV_ENN` high: the drivers
/// are off until the image drives the line low in a state that may move.
/// Pin 3 is a plain output here (its FlexPWM4 sm2 B function is unused:
/// J1 uses sm2 A on pin 2 through its own pad).
pub const DRIVER_ENABLE: EnablePin = EnablePin { pin: 3, active_high: false }.validated();

// Test code is built with overflow checks on: an overflow fails the test.
#[cfg(test)]
#[allow(clippy::arithmetic_side_effects)]
mod tests {
    use super::*;

    #[test]
    fn default_step_pins() {
        let want = [(2, 4, 2), (5, 2, 1), (6, 2, 2), (8, 1, 3), (4, 2, 0), (7, 2, 3)];
        for (i, (pin, module, sm)) in want.into_iter().enumerate() {
            assert_eq!(DEFAULT_PIN_MAP.step[i], pin);
            let f = step_fn(pin).unwrap();
            assert_eq!((f.module, f.submodule, f.output), (module, sm, PwmOutput::A), "pin {pin}");
        }
        // ALT values (Teensy core tables)
        assert_eq!(step_fn(2).unwrap().alt, 1);
        assert_eq!(step_fn(6).unwrap().alt, 2);
        assert_eq!(step_fn(8).unwrap().alt, 6);
        assert_eq!(step_fn(36).unwrap().alt, 6);
        assert_eq!(teensy41_pin(36).unwrap().pad, Pad::GPIO_B1_02);
        assert_eq!(step_fn(36).unwrap().route, PwmRoute::Pad);
    }

    #[test]
    fn pin7_xbar_route() {
        let f = step_fn(7).unwrap();
        assert_eq!(teensy41_pin(7).unwrap().pad, Pad::GPIO_B1_01);
        assert_eq!((f.module, f.submodule, f.output, f.alt), (2, 3, PwmOutput::A, 1));
        assert_eq!(f.route, PwmRoute::Xbar { inout: 15, input: 47 });
        assert_eq!(xbar_trig_input(1, 0), Some(40));
        assert_eq!(xbar_trig_input(3, 3), Some(51));
        assert_eq!(xbar_trig_input(4, 0), None);
        // the pin-36 map keeps the direct pad route on the same submodule
        assert_eq!(J6_PIN36_PIN_MAP.step[5], 36);
        let g = step_fn(36).unwrap();
        assert_eq!((g.module, g.submodule), (f.module, f.submodule));
    }

    #[test]
    fn default_encoder_pins() {
        let want = [(10, 1, 0), (11, 1, 2), (12, 1, 1), (14, 3, 2), (15, 3, 3), (19, 3, 0)];
        for (i, (pin, module, ch)) in want.into_iter().enumerate() {
            assert_eq!(DEFAULT_PIN_MAP.encoder[i], pin);
            let f = encoder_fn(pin).unwrap();
            assert_eq!((f.module, f.channel, f.alt), (module, ch, 1), "pin {pin}");
            assert_eq!(f.daisy.is_some(), module == 3);
        }
        // J6 on pin 19 = TMR3 ch0, the channel the C++ map forgot
        assert_eq!(encoder_fn(19).unwrap().daisy, Some(1));
    }

    #[test]
    fn default_dir_and_limit_pins() {
        let dir = [(30, 3, 23), (31, 3, 22), (32, 2, 12), (33, 4, 7), (35, 2, 28), (34, 2, 29)];
        for (i, (pin, port, bit)) in dir.into_iter().enumerate() {
            assert_eq!(DEFAULT_PIN_MAP.dir[i], pin);
            assert_eq!(teensy41_pin(pin).unwrap().gpio, GpioBit { port, bit });
        }
        let lim = [(20, 1, 26), (21, 1, 27), (22, 1, 24), (23, 1, 25), (24, 1, 12), (25, 1, 13)];
        for (i, (pin, port, bit)) in lim.into_iter().enumerate() {
            assert_eq!(DEFAULT_PIN_MAP.limit[i], pin);
            assert_eq!(teensy41_pin(pin).unwrap().gpio, GpioBit { port, bit });
        }
    }

    #[test]
    fn cpp_step_map_accepted_via_xbar_and_pin36_conflicts_with_it() {
        let cpp = PinMap { step: [2, 5, 6, 8, 4, 7], ..DEFAULT_PIN_MAP };
        assert_eq!(check(&cpp), Ok(()));
        let both = PinMap { step: [2, 5, 6, 8, 36, 7], ..DEFAULT_PIN_MAP };
        assert_eq!(check(&both), Err(PinMapError::StepSubmoduleShared(7)));
    }

    #[test]
    fn other_rejections() {
        let m = PinMap { dir: [30, 31, 32, 33, 35, 0], ..DEFAULT_PIN_MAP };
        assert_eq!(check(&m), Err(PinMapError::PinUsedTwice(0)));
        let m = PinMap { limit: [20, 21, 22, 23, 24, 2], ..DEFAULT_PIN_MAP };
        assert_eq!(check(&m), Err(PinMapError::PinUsedTwice(2)));
        let m = PinMap { step: [2, 5, 6, 8, 4, 30], dir: [29, 31, 32, 33, 35, 34], ..DEFAULT_PIN_MAP };
        assert_eq!(check(&m), Err(PinMapError::NotStepCapable(30)));
        let m = PinMap { encoder: [10, 11, 12, 14, 15, 16], ..DEFAULT_PIN_MAP };
        assert_eq!(check(&m), Err(PinMapError::NotEncoderCapable(16)));
        let m = PinMap { encoder: [10, 11, 12, 14, 15, 99], ..DEFAULT_PIN_MAP };
        assert_eq!(check(&m), Err(PinMapError::UnknownPin(99)));
        // A and B of one submodule conflict too
        let m = PinMap { step: [2, 3, 6, 8, 4, 7], ..DEFAULT_PIN_MAP };
        assert_eq!(check(&m), Err(PinMapError::StepSubmoduleShared(3)));
        // alternative fix with pin 29 is valid
        let m = PinMap { step: [2, 5, 6, 8, 4, 29], ..DEFAULT_PIN_MAP };
        assert_eq!(check(&m), Ok(()));
    }

    #[test]
    fn driver_enable_pin_is_free_and_checked() {
        assert_eq!(check_enable_pin(DRIVER_ENABLE, &DEFAULT_PIN_MAP), Ok(()));
        assert_eq!(check_enable_pin(DRIVER_ENABLE, &J6_PIN36_PIN_MAP), Ok(()));
        assert_eq!(teensy41_pin(DRIVER_ENABLE.pin).unwrap().gpio, GpioBit { port: 4, bit: 5 });
        assert_eq!(DRIVER_ENABLE, EnablePin { pin: 3, active_high: false });
        for taken in [2, 30, 10, 20, 0, 13, 26, 27, 39, 38, 17, 28] {
            let e = EnablePin { pin: taken, active_high: false };
            assert_eq!(check_enable_pin(e, &DEFAULT_PIN_MAP), Err(PinMapError::EnablePinTaken(taken)), "{taken}");
        }
        let j6 = EnablePin { pin: 36, active_high: false };
        assert_eq!(check_enable_pin(j6, &DEFAULT_PIN_MAP), Ok(()));
        assert_eq!(check_enable_pin(j6, &J6_PIN36_PIN_MAP), Err(PinMapError::EnablePinTaken(36)));
        let unknown = EnablePin { pin: 99, active_high: false };
        assert_eq!(check_enable_pin(unknown, &DEFAULT_PIN_MAP), Err(PinMapError::UnknownPin(99)));
    }

    #[test]
    fn database_is_self_consistent() {
        for pin in 0..=41u8 {
            let p = teensy41_pin(pin).unwrap();
            assert_eq!(p.pin, pin);
            assert!((1..=4).contains(&p.gpio.port) && p.gpio.bit < 32);
            // pads unique
            for other in 0..pin {
                assert_ne!(teensy41_pin(other).unwrap().pad, p.pad, "{pin} {other}");
            }
        }
        assert!(teensy41_pin(42).is_none());
    }

    #[test]
    fn tmc_wiring_pads_and_conflicts() {
        assert_eq!(check_tmc(&DEFAULT_PIN_MAP, &TMC_WIRING), Ok(()));
        assert_eq!(teensy41_pin(27).unwrap().pad, Pad::GPIO_AD_B1_15);
        assert_eq!(teensy41_pin(26).unwrap().pad, Pad::GPIO_AD_B1_14);
        assert_eq!(teensy41_pin(39).unwrap().pad, Pad::GPIO_AD_B1_13);
        let cs_bits = TMC_WIRING.cs.map(|p| teensy41_pin(p).unwrap().gpio);
        assert_eq!(cs_bits, [g(1, 28), g(1, 20), g(1, 21), g(1, 22), g(1, 23), g(3, 18)]);
        // a chip select on a limit input, on the LED, twice, or on an SPI pin
        let w = TmcWiring { cs: [20, 40, 41, 17, 16, 28], ..TMC_WIRING };
        assert_eq!(check_tmc(&DEFAULT_PIN_MAP, &w), Err(PinMapError::PinUsedTwice(20)));
        let w = TmcWiring { cs: [13, 40, 41, 17, 16, 28], ..TMC_WIRING };
        assert_eq!(check_tmc(&DEFAULT_PIN_MAP, &w), Err(PinMapError::PinUsedTwice(13)));
        let w = TmcWiring { cs: [38, 38, 41, 17, 16, 28], ..TMC_WIRING };
        assert_eq!(check_tmc(&DEFAULT_PIN_MAP, &w), Err(PinMapError::PinUsedTwice(38)));
        let w = TmcWiring { cs: [27, 40, 41, 17, 16, 28], ..TMC_WIRING };
        assert_eq!(check_tmc(&DEFAULT_PIN_MAP, &w), Err(PinMapError::PinUsedTwice(27)));
        // an SPI record whose pad is not its pin's
        let w = TmcWiring { sdi: SpiPad { pin: 38, ..TMC_WIRING.sdi }, ..TMC_WIRING };
        assert_eq!(check_tmc(&DEFAULT_PIN_MAP, &w), Err(PinMapError::UnknownPin(38)));
    }
}
