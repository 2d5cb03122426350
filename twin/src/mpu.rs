//! The Cortex-M7 MPU (ARMv7-M PMSAv7) as far as the image's stack guard
//! needs it: the registers the image writes (`MPU_CTRL`, `MPU_RNR`,
//! `MPU_RBAR`, `MPU_RASR` and their aliases at 0xE000_ED90..), and the
//! regions that deny every access to privileged code (`AP = 0b000`), which
//! the harness maps as protected memory in Unicorn ([`crate::Twin`]): an
//! access there stops the CPU and is taken as the MemManage fault the
//! image leaves escalating to HardFault.
//!
//! Modelled: enable, `HFNMIENA` (the MPU is off while the HardFault
//! handler runs when it is clear), region size, subregion disable bits,
//! `XN` with no access. Not modelled: access permissions other than "none"
//! (the image runs privileged, and every other `AP` lets it read and
//! write), memory attributes, and a higher-numbered region that grants
//! access over a no-access one (the image programs one region).

/// `MPU_TYPE`: 16 data regions, unified.
pub const MPU_TYPE: u32 = 16 << 8;

/// The MPU's registers.
#[derive(Clone, Debug, Default)]
pub struct Mpu {
    /// `MPU_CTRL`.
    pub ctrl: u32,
    /// `MPU_RNR`.
    pub rnr: u32,
    /// `MPU_RBAR` of each region (address bits).
    pub rbar: [u32; 16],
    /// `MPU_RASR` of each region.
    pub rasr: [u32; 16],
    /// A register changed since the harness last applied the regions.
    pub dirty: bool,
}

impl Mpu {
    /// The MPU is on.
    pub fn enabled(&self) -> bool {
        self.ctrl & 1 != 0
    }

    /// `HFNMIENA`: the MPU stays on in the HardFault and NMI handlers.
    pub fn on_in_hardfault(&self) -> bool {
        self.ctrl & 2 != 0
    }

    /// Register read at `a` (0xE000_ED90..=0xE000_EDB8), if it is one.
    pub fn read(&self, a: u32) -> Option<u32> {
        let r = (self.rnr & 15) as usize;
        Some(match a {
            0xE000_ED90 => MPU_TYPE,
            0xE000_ED94 => self.ctrl,
            0xE000_ED98 => self.rnr,
            0xE000_ED9C | 0xE000_EDA4 | 0xE000_EDAC | 0xE000_EDB4 => self.rbar[r] | self.rnr & 15,
            0xE000_EDA0 | 0xE000_EDA8 | 0xE000_EDB0 | 0xE000_EDB8 => self.rasr[r],
            _ => return None,
        })
    }

    /// Register write at `a`; `false` if it is not an MPU register.
    pub fn write(&mut self, a: u32, v: u32) -> bool {
        match a {
            0xE000_ED94 => self.ctrl = v & 7,
            0xE000_ED98 => self.rnr = v & 0xFF,
            0xE000_ED9C | 0xE000_EDA4 | 0xE000_EDAC | 0xE000_EDB4 => {
                if v & (1 << 4) != 0 {
                    self.rnr = v & 15;
                }
                self.rbar[(self.rnr & 15) as usize] = v & !0x1F;
            }
            0xE000_EDA0 | 0xE000_EDA8 | 0xE000_EDB0 | 0xE000_EDB8 => self.rasr[(self.rnr & 15) as usize] = v,
            _ => return false,
        }
        self.dirty = true;
        true
    }

    /// The address ranges `[start, end)` no access may touch while the MPU
    /// is on: enabled regions with `AP = 0b000`, less their disabled
    /// subregions. Empty when the MPU is off.
    pub fn no_access(&self) -> Vec<(u64, u64)> {
        let mut out = Vec::new();
        if !self.enabled() {
            return out;
        }
        for (&rbar, &rasr) in self.rbar.iter().zip(self.rasr.iter()) {
            let ap = (rasr >> 24) & 7;
            if rasr & 1 == 0 || ap != 0 {
                continue;
            }
            let size_log2 = ((rasr >> 1) & 0x1F) + 1;
            if size_log2 < 5 {
                continue; // reserved sizes: the region is ignored
            }
            let size = 1u64 << size_log2;
            let base = u64::from(rbar) & !(size - 1);
            let srd = (rasr >> 8) & 0xFF;
            if srd == 0 || size_log2 < 8 {
                out.push((base, base + size));
                continue;
            }
            let sub = size / 8;
            for k in 0..8 {
                if srd & (1 << k) == 0 {
                    out.push((base + k * sub, base + (k + 1) * sub));
                }
            }
        }
        out
    }
}

/// An access the MPU refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MpuFault {
    /// The address accessed.
    pub addr: u32,
    /// A write (else a read or a fetch).
    pub write: bool,
    /// Time (cycles).
    pub at: u64,
    /// The stack pointer at the access.
    pub sp: u32,
}
