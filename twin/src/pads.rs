//! The twin's own pad database (Teensy 4.1 schematic + i.MXRT1062 IOMUXC
//! chapter, written independently of `hal_imxrt::pure::pins`): which pad a
//! Teensy pin is, where its `SW_MUX_CTL`/`SW_PAD_CTL` registers are, which
//! GPIO bit it is, and what its ALT functions mean for the pins the twin
//! wires to the plant; and the board's view of its pads: GPIO ports,
//! pad functions and levels, XBARA1 routing.

use crate::board::{reset_value, Board, CCM, IOMUXC, IOMUXC_GPR};
use crate::pwm::PadRoute;

/// Pad group.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Group {
    /// GPIO_EMC_00..41
    Emc,
    /// GPIO_AD_B0_00..15
    AdB0,
    /// GPIO_AD_B1_00..15
    AdB1,
    /// GPIO_B0_00..15
    B0,
    /// GPIO_B1_00..15
    B1,
}

/// A pad.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pad {
    /// Group.
    pub group: Group,
    /// Index in the group.
    pub index: u8,
}

impl Pad {
    /// `SW_MUX_CTL_PAD_*` offset in IOMUXC.
    pub const fn mux_offset(self) -> u32 {
        let base = match self.group {
            Group::Emc => 0x014,
            Group::AdB0 => 0x0BC,
            Group::AdB1 => 0x0FC,
            Group::B0 => 0x13C,
            Group::B1 => 0x17C,
        };
        base + 4 * self.index as u32
    }
    /// `SW_PAD_CTL_PAD_*` offset in IOMUXC.
    pub const fn pad_offset(self) -> u32 {
        let base = match self.group {
            Group::Emc => 0x204,
            Group::AdB0 => 0x2AC,
            Group::AdB1 => 0x2EC,
            Group::B0 => 0x32C,
            Group::B1 => 0x36C,
        };
        base + 4 * self.index as u32
    }
    /// Standard GPIO (port 1..4, bit) of the pad (ALT5).
    pub const fn gpio(self) -> (usize, u32) {
        let i = self.index as u32;
        match self.group {
            Group::Emc if i < 32 => (4, i),
            Group::Emc => (3, i - 32 + 18),
            Group::AdB0 => (1, i),
            Group::AdB1 => (1, i + 16),
            Group::B0 => (2, i),
            Group::B1 => (2, i + 16),
        }
    }
}

const fn pad(group: Group, index: u8) -> Pad {
    Pad { group, index }
}

/// Teensy 4.1 pin -> pad (the pins the twin uses).
pub const fn teensy_pad(pin: u8) -> Option<Pad> {
    use Group::*;
    Some(match pin {
        0 => pad(AdB0, 3),
        1 => pad(AdB0, 2),
        2 => pad(Emc, 4),
        3 => pad(Emc, 5),
        4 => pad(Emc, 6),
        5 => pad(Emc, 8),
        6 => pad(B0, 10),
        7 => pad(B1, 1),
        8 => pad(B1, 0),
        9 => pad(B0, 11),
        10 => pad(B0, 0),
        11 => pad(B0, 2),
        12 => pad(B0, 1),
        13 => pad(B0, 3),
        14 => pad(AdB1, 2),
        15 => pad(AdB1, 3),
        16 => pad(AdB1, 7),
        17 => pad(AdB1, 6),
        18 => pad(AdB1, 1),
        19 => pad(AdB1, 0),
        20 => pad(AdB1, 10),
        21 => pad(AdB1, 11),
        22 => pad(AdB1, 8),
        23 => pad(AdB1, 9),
        24 => pad(AdB0, 12),
        25 => pad(AdB0, 13),
        26 => pad(AdB1, 14),
        27 => pad(AdB1, 15),
        28 => pad(Emc, 32),
        29 => pad(Emc, 31),
        30 => pad(Emc, 37),
        31 => pad(Emc, 36),
        32 => pad(B0, 12),
        33 => pad(Emc, 7),
        34 => pad(B1, 13),
        35 => pad(B1, 12),
        36 => pad(B1, 2),
        37 => pad(B1, 3),
        38 => pad(AdB1, 12),
        39 => pad(AdB1, 13),
        40 => pad(AdB1, 4),
        41 => pad(AdB1, 5),
        _ => return None,
    })
}

/// FlexPWM output reachable on a pad: (module 1..4, submodule, is_b, ALT).
pub const fn pwm_function(p: Pad) -> Option<(usize, usize, bool, u32)> {
    use Group::*;
    match (p.group, p.index) {
        (Emc, 4) => Some((4, 2, false, 1)),
        (Emc, 5) => Some((4, 2, true, 1)),
        (Emc, 6) => Some((2, 0, false, 1)),
        (Emc, 7) => Some((2, 0, true, 1)),
        (Emc, 8) => Some((2, 1, false, 1)),
        (Emc, 31) => Some((3, 1, false, 1)),
        (B0, 10) => Some((2, 2, false, 2)),
        (B0, 11) => Some((2, 2, true, 2)),
        (B1, 0) => Some((1, 3, false, 6)),
        (B1, 1) => Some((1, 3, true, 6)),
        (B1, 2) => Some((2, 3, false, 6)),
        (B1, 3) => Some((2, 3, true, 6)),
        _ => None,
    }
}

/// A QuadTimer input on a pad: (module 1..4, channel, ALT, daisy register
/// offset and the value selecting this pad, if the input has a daisy).
pub type QtimerInput = (usize, usize, u32, Option<(u32, u32)>);

/// QuadTimer input on a pad.
pub const fn qtimer_function(p: Pad) -> Option<QtimerInput> {
    use Group::*;
    match (p.group, p.index) {
        (B0, 0) => Some((1, 0, 1, None)),
        (B0, 1) => Some((1, 1, 1, None)),
        (B0, 2) => Some((1, 2, 1, None)),
        (B0, 3) => Some((2, 0, 1, Some((0x56C, 1)))),
        // QTIMER3_TIMERn_SELECT_INPUT: EMC_15/16/17/18 ALT4 = 0 (TIMER1:
        // AD_B1_01 = 0, EMC_16 = 1), AD_B1_0n ALT1 = 1, B0_06.. = 2.
        (AdB1, 0) => Some((3, 0, 1, Some((0x57C, 1)))),
        (AdB1, 1) => Some((3, 1, 1, Some((0x580, 0)))),
        (AdB1, 2) => Some((3, 2, 1, Some((0x584, 1)))),
        (AdB1, 3) => Some((3, 3, 1, Some((0x588, 1)))),
        _ => None,
    }
}

/// IOMUX XBAR pin function of a pad: (ALT, XBAR1_INOUT number). Only the
/// pad the firmware uses is listed: GPIO_B1_01 (pin 7) ALT1 =
/// `XBAR1_INOUT15` (NXP SDK pin header).
pub const fn xbar_inout_function(p: Pad) -> Option<(u32, usize)> {
    match (p.group, p.index) {
        (Group::B1, 1) => Some((1, 15)),
        _ => None,
    }
}

/// The default wiring the twin connects (J1..J6): docs/spec/robot.md section 2, the
/// original wiring (J6 STEP on pin 7), the firmware's default map.
#[derive(Clone, Copy, Debug)]
pub struct Wiring {
    /// STEP pins.
    pub step: [u8; 6],
    /// DIR pins.
    pub dir: [u8; 6],
    /// Encoder PWM pins.
    pub encoder: [u8; 6],
    /// Limit switch pins.
    pub limit: [u8; 6],
}

/// Board wiring used by the twin.
pub const WIRING: Wiring = Wiring {
    step: [2, 5, 6, 8, 4, 7],
    dir: [30, 31, 32, 33, 35, 34],
    encoder: [10, 11, 12, 14, 15, 19],
    limit: [20, 21, 22, 23, 24, 25],
};

/// The wiring the twin connects: [`WIRING`], or with `TWIN_J6_PIN=36` in
/// the environment J6 STEP on pin 36 (for images built with the firmware's
/// `j6-pin36` feature or without the fix of defect 8, e.g. to reproduce a
/// test's figures on the image of an older commit).
pub fn wiring() -> &'static Wiring {
    static W: std::sync::OnceLock<Wiring> = std::sync::OnceLock::new();
    W.get_or_init(|| {
        let mut w = WIRING;
        if std::env::var("TWIN_J6_PIN").is_ok_and(|v| v.trim() == "36") {
            w.step[5] = 36;
        }
        w
    })
}

/// The drivers' enable line: Teensy pin 3 wired to every TMC5160's
/// `DRV_ENN` (active low), pulled up at the drivers (10 kOhm to 3.3 V): the
/// line is high (drivers off) unless a GPIO output drives it.
pub const DRIVER_ENABLE_PIN: u8 = 3;
/// The TMC5160 link (firmware feature `tmc5160-spi`): LPSPI3 SCK, SDO, SDI
/// (Teensy "SPI1": pins 27, 26, 39) and the chip selects of J1..J6.
pub const TMC_SCK: u8 = 27;
/// LPSPI3 SDO (to the drivers' SDI).
pub const TMC_SDO: u8 = 26;
/// LPSPI3 SDI (from the drivers' SDO).
pub const TMC_SDI: u8 = 39;
/// Chip select of each driver, J1..J6 (GPIO, active low).
pub const TMC_CS: [u8; 6] = [38, 40, 41, 17, 16, 28];

/// IOMUXC offsets of the LPUART6 pads and daisy registers.
pub const LPUART6_RX_SELECT: u32 = 0x550;

// ------------------------------------------------------------ the board's pads

/// GPIO port.
#[derive(Clone, Debug, Default)]
pub struct Gpio {
    /// DR.
    pub dr: u32,
    /// GDIR.
    pub gdir: u32,
    /// Other registers (ICR1/2, IMR, ISR, EDGE_SEL) by offset/4.
    pub other: [u32; 8],
}

impl Gpio {
    /// Register write at offset `off` (`PSR` is read-only; `DR_SET`,
    /// `DR_CLEAR`, `DR_TOGGLE` change `DR`).
    pub fn write(&mut self, off: u32, v: u32) {
        match off {
            0x0 => self.dr = v,
            0x4 => self.gdir = v,
            0x8 => {}
            0x84 => self.dr |= v,
            0x88 => self.dr &= !v,
            0x8C => self.dr ^= v,
            o => self.other[((o / 4) as usize).min(7)] = v,
        }
    }
}

/// The pins as the board sees them: IOMUXC pad functions, GPIO levels,
/// XBARA1 routing of the FlexPWM outputs.
impl Board {
    /// GPIO port `p` (0-based) register read at offset `off`: `PSR` is
    /// the pads' levels.
    pub(crate) fn gpio_read(&self, p: usize, off: u32) -> u32 {
        let g = &self.gpio[p];
        match off {
            0x0 => g.dr,
            0x4 => g.gdir,
            0x8 => self.gpio_psr(p),
            0x84..=0x8C => 0,
            o => g.other[((o / 4) as usize).min(7)],
        }
    }

    /// XBARA1 select registers (one byte per output, two per halfword) read
    /// at offset `off`.
    pub(crate) fn xbar_read(&self, off: u32, size: usize) -> u32 {
        let i = (off & !1) as usize;
        let byte = |k: usize| u32::from(*self.xbar.get(k).unwrap_or(&0));
        let v16 = byte(i) | (byte(i + 1) << 8);
        if size == 4 {
            v16 | (byte(i + 2) << 16) | (byte(i + 3) << 24)
        } else {
            v16
        }
    }

    /// XBARA1 select registers written at offset `off`; remembers each
    /// output's last FlexPWM trigger.
    pub(crate) fn xbar_write(&mut self, off: u32, size: usize, value: u32) {
        let bytes = value.to_le_bytes();
        for (k, &b) in bytes.iter().enumerate().take(size) {
            let i = off as usize + k;
            if i < 132 {
                self.xbar[i] = b & 0x7F;
                if let Some(src) = self.xbar_trigger_source(i) {
                    self.xbar_last_trigger.insert(i, src);
                }
            }
        }
    }

    pub(crate) fn iomux(&self, off: u32) -> u32 {
        self.regs.get(&(IOMUXC + off)).copied().unwrap_or(0)
    }

    /// ALT selected on a pad (SW_MUX_CTL bits 2:0) and SION.
    pub fn pad_mux(&self, p: Pad) -> (u32, bool) {
        let v = self.iomux(p.mux_offset());
        (v & 7, v & 0x10 != 0)
    }

    /// The pad is driven by GPIO1..4 (ALT5 and the GPR26..29 bit clear).
    pub(crate) fn pad_is_std_gpio(&self, p: Pad) -> bool {
        let (port, bit) = p.gpio();
        let gpr = self.regs.get(&(IOMUXC_GPR + 0x68 + 4 * (port as u32 - 1))).copied().unwrap_or(0);
        self.pad_mux(p).0 == 5 && gpr & (1 << bit) == 0
    }

    /// Level driven onto a pad by GPIO (if it is a GPIO output).
    pub fn gpio_out(&self, pin: u8) -> Option<bool> {
        let p = teensy_pad(pin)?;
        let (port, bit) = p.gpio();
        let g = &self.gpio[port - 1];
        if self.pad_is_std_gpio(p) && g.gdir & (1 << bit) != 0 {
            Some(g.dr & (1 << bit) != 0)
        } else {
            None
        }
    }

    /// The drivers' enable line (`DRV_ENN`): the GPIO level if pin 3 is
    /// driven, else high (the external pull-up).
    pub fn driver_enable_line(&self) -> bool {
        self.gpio_out(DRIVER_ENABLE_PIN).unwrap_or(true)
    }

    /// The drivers are energised (`DRV_ENN` low).
    pub fn drivers_energised(&self) -> bool {
        !self.driver_enable_line()
    }

    /// Records a change of the drivers' enable line (time, energised).
    pub(crate) fn note_driver_enable(&mut self) {
        let on = self.drivers_energised();
        if self.driver_enable_log.last().is_some_and(|&(_, last)| last) != on {
            self.driver_enable_log.push((self.now, on));
        }
    }

    /// DIR line of axis `i`: the GPIO level if driven, else low (driver
    /// input pulled low).
    pub fn dir_level(&self, i: usize) -> bool {
        self.gpio_out(wiring().dir[i]).unwrap_or(false)
    }

    /// External level on a pad (what the outside world drives or pulls).
    pub(crate) fn external_level(&self, p: Pad) -> bool {
        for (i, &pin) in wiring().limit.iter().enumerate() {
            if teensy_pad(pin) == Some(p) {
                if self.plant.joints[i].switch_closed() {
                    return false; // switch to ground
                }
                // open: only the pad's pull decides
                let ctl = self.iomux(p.pad_offset());
                let pke = ctl & (1 << 12) != 0;
                let pue = ctl & (1 << 13) != 0;
                let pus = (ctl >> 14) & 3;
                return pke && pue && pus != 0;
            }
        }
        false
    }

    pub(crate) fn gpio_psr(&self, port: usize) -> u32 {
        let g = &self.gpio[port];
        let mut v = 0u32;
        for pin in 0..=41u8 {
            let Some(p) = teensy_pad(pin) else { continue };
            let (pt, bit) = p.gpio();
            if pt != port + 1 {
                continue;
            }
            let (alt, sion) = self.pad_mux(p);
            let gpr = self.regs.get(&(IOMUXC_GPR + 0x68 + 4 * port as u32)).copied().unwrap_or(0);
            if gpr & (1 << bit) != 0 || (alt != 5 && !sion) {
                continue;
            }
            let level =
                if alt == 5 && g.gdir & (1 << bit) != 0 { g.dr & (1 << bit) != 0 } else { self.external_level(p) };
            if level {
                v |= 1 << bit;
            }
        }
        v
    }

    /// Effective function of a Teensy pin, as a string (tests, diagnostics).
    pub fn pin_function(&self, pin: u8) -> String {
        let Some(p) = teensy_pad(pin) else { return "unknown".into() };
        let (alt, sion) = self.pad_mux(p);
        if alt == 5 {
            let (port, bit) = p.gpio();
            return format!("GPIO{port}.{bit}{}", if self.pad_is_std_gpio(p) { "" } else { " (fast GPIO)" });
        }
        if let Some((m, s, b, a)) = pwm_function(p) {
            if a == alt {
                return format!("FLEXPWM{m}_PWM{}{s}", if b { 'B' } else { 'A' });
            }
        }
        if let Some((a, inout)) = xbar_inout_function(p) {
            if a == alt {
                let dir = if self.pad_xbar_output(p).is_some() { "output" } else { "input" };
                return format!("XBAR1_INOUT{inout} ({dir})");
            }
        }
        if let Some((m, c, a, daisy)) = qtimer_function(p) {
            if a == alt {
                let selected = daisy.is_none_or(|(off, val)| self.iomux(off) & 3 == val);
                return format!(
                    "QTIMER{m}_TIMER{c}{}{}",
                    if sion { " SION" } else { "" },
                    if selected { "" } else { " (daisy selects another pad)" }
                );
            }
        }
        format!("ALT{alt}")
    }

    /// A register's value (stored, or its reset value).
    pub(crate) fn reg(&self, a: u32) -> u32 {
        self.regs.get(&a).copied().unwrap_or_else(|| reset_value(a))
    }

    /// XBARA1 output `out` (0..132) as a FlexPWM trigger: (module,
    /// submodule) whose `PWM_OUT_TRIG0_1` is selected (inputs 40..=51 =
    /// FlexPWM1..3 submodules 0..3, NXP SDK XBARA1 input table), if the
    /// XBAR1 clock gate (CCGR2 CG11) is open.
    pub(crate) fn xbar_trigger_source(&self, out: usize) -> Option<(usize, usize)> {
        let gate = (self.reg(CCM + 0x70) >> 22) & 3 != 0;
        let sel = usize::from(*self.xbar.get(out)?);
        if gate && (40..=51).contains(&sel) {
            Some(((sel - 40) / 4 + 1, (sel - 40) % 4))
        } else {
            None
        }
    }

    /// The pad is an XBAR1_INOUT output (its ALT selected, `IOMUXC_GPR6`
    /// direction bit `12 + n` set): the XBARA1 output number.
    pub(crate) fn pad_xbar_output(&self, p: Pad) -> Option<usize> {
        let (alt, inout) = xbar_inout_function(p)?;
        let gpr6 = self.reg(IOMUXC_GPR + 0x18);
        (self.pad_mux(p).0 == alt && gpr6 & (1 << (12 + inout)) != 0).then_some(inout)
    }

    /// Where a pad's level comes from, if a FlexPWM drives it: (module,
    /// submodule, log index 0 = A / 1 = B on the pad, 2 = `PWM_OUT_TRIG0`
    /// through XBARA1).
    pub fn pad_pwm_source(&self, p: Pad) -> Option<(usize, usize, usize)> {
        if let Some((m, s, b, a)) = pwm_function(p) {
            if self.pad_mux(p).0 == a {
                return Some((m, s, usize::from(b)));
            }
        }
        let out = self.pad_xbar_output(p)?;
        let (m, s) = self.xbar_trigger_source(out).or_else(|| self.xbar_last_trigger.get(&out).copied())?;
        Some((m, s, 2))
    }

    /// Pad routing of each PWM output (the pad is muxed to it, directly or
    /// through XBARA1).
    pub(crate) fn pwm_routes(&self) -> [PadRoute; 4] {
        let mut r = [PadRoute::default(); 4];
        for pin in wiring().step {
            let Some(p) = teensy_pad(pin) else { continue };
            match self.pad_pwm_source(p) {
                // only while the trigger (not LOGIC_LOW) is selected
                Some((m, s, 2)) if self.pad_xbar_output(p).and_then(|o| self.xbar_trigger_source(o)).is_some() => {
                    r[m - 1].trig0[s] = true
                }
                Some((_, _, 2)) => {}
                Some((m, s, b)) => r[m - 1].routed[s][b] = true,
                None => {}
            }
        }
        r
    }

    /// One line per axis: the FlexPWM state of its STEP output.
    pub fn step_report(&self) -> Vec<String> {
        (0..6)
            .map(|i| {
                let pin = wiring().step[i];
                let Some((m, s, b)) = self.step_source(i) else {
                    return format!("J{} pin {pin} {}: no PWM reaches the pad", i + 1, self.pin_function(pin));
                };
                let pw = &self.pwm[m - 1];
                let sm = &pw.sm[s];
                let bit = if b == 1 { 4 + s } else { 8 + s };
                format!(
                    "J{} pin {pin} {} <- FLEXPWM{m} sm{s} {}: RUN={} OUTEN={} MASK={} fault-disabled={} (FCTRL0={:#06x} FSTS0={:#06x} DISMAP0={:#06x}) PRSC={} VAL1={} VAL2={} VAL3={} LDOK={} dropped-writes={} pulses={}",
                    i + 1,
                    self.pin_function(pin),
                    ["A", "B", "OUT_TRIG0 via XBARA1"][b],
                    u8::from(pw.mctrl & (1 << (8 + s)) != 0),
                    u8::from(pw.outen & (1 << bit) != 0),
                    u8::from(pw.mask & (1 << bit) != 0),
                    pw.fault_disabled(s, b.min(1)),
                    pw.fctrl,
                    pw.read(0x18E),
                    sm.dismap0(),
                    sm.prsc,
                    sm.val[1],
                    sm.val[2],
                    sm.val[3],
                    u8::from(pw.mctrl & (1 << s) != 0),
                    sm.dropped_writes,
                    sm.log[b].pulses
                )
            })
            .collect()
    }

    /// STEP pulses seen on each axis's STEP pin since power-on (the output
    /// that drives the pad now).
    pub fn step_pulses(&self) -> [u64; 6] {
        core::array::from_fn(|i| match self.step_source(i) {
            Some((m, s, b)) => self.pwm[m - 1].sm[s].log[b].pulses,
            None => 0,
        })
    }

    /// The FlexPWM submodule log behind axis `i`'s STEP pin: (module,
    /// submodule, log index) for a pad muxed to a PWM output, or for pin 7
    /// routed through XBARA1 the trigger log.
    pub fn step_source(&self, i: usize) -> Option<(usize, usize, usize)> {
        self.pad_pwm_source(teensy_pad(wiring().step[i])?)
    }

    /// Rising-edge times (cycles) recorded on axis `i`'s STEP pin.
    pub fn step_rises(&self, i: usize) -> Vec<u64> {
        match self.step_source(i) {
            Some((m, s, b)) => self.pwm[m - 1].sm[s].log[b].rises.clone(),
            None => Vec::new(),
        }
    }
}
