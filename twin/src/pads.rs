//! The twin's own pad database (Teensy 4.1 schematic + i.MXRT1062 IOMUXC
//! chapter, written independently of `hal_imxrt::pure::pins`): which pad a
//! Teensy pin is, where its `SW_MUX_CTL`/`SW_PAD_CTL` registers are, which
//! GPIO bit it is, and what its ALT functions mean for the pins the twin
//! wires to the plant.

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
        18 => pad(AdB1, 1),
        19 => pad(AdB1, 0),
        20 => pad(AdB1, 10),
        21 => pad(AdB1, 11),
        22 => pad(AdB1, 8),
        23 => pad(AdB1, 9),
        24 => pad(AdB0, 12),
        25 => pad(AdB0, 13),
        29 => pad(Emc, 31),
        30 => pad(Emc, 37),
        31 => pad(Emc, 36),
        32 => pad(B0, 12),
        33 => pad(Emc, 7),
        34 => pad(B1, 13),
        35 => pad(B1, 12),
        36 => pad(B1, 2),
        37 => pad(B1, 3),
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

/// The default wiring the twin connects (J1..J6): ROBOT.md section 2, the
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
/// `j6-pin36` feature or before issue 11 defect 8, e.g. to reproduce a
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

/// IOMUXC offsets of the LPUART6 pads and daisy registers.
pub const LPUART6_RX_SELECT: u32 = 0x550;
