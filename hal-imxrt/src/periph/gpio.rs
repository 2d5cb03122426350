//! GPIO1..4 (standard GPIO) for DIR outputs and limit-switch inputs.

use crate::pure::pins::{teensy41_pin, GpioBit, PinMap, PinMapError};
use imxrt_ral as ral;
use ral::gpio;

/// Owner of GPIO1..GPIO4. DIR writes use the atomic `DR_SET`/`DR_CLEAR`
/// registers and inputs read `PSR`, so sharing one owner between the step
/// driver and the limit inputs needs no read-modify-write of `DR` at run time.
pub struct Gpios {
    g1: gpio::GPIO1,
    g2: gpio::GPIO2,
    g3: gpio::GPIO3,
    g4: gpio::GPIO4,
}

impl core::fmt::Debug for Gpios {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Gpios").finish_non_exhaustive()
    }
}

impl Gpios {
    /// Take ownership of GPIO1..4.
    pub fn new(g1: gpio::GPIO1, g2: gpio::GPIO2, g3: gpio::GPIO3, g4: gpio::GPIO4) -> Self {
        Self { g1, g2, g3, g4 }
    }

    fn block(&self, port: u8) -> &gpio::RegisterBlock {
        match port {
            1 => &self.g1,
            2 => &self.g2,
            3 => &self.g3,
            _ => &self.g4,
        }
    }

    /// Make a bit an output (init-time read-modify-write of `GDIR`).
    pub fn make_output(&self, b: GpioBit) {
        let m = 1u32 << (b.bit & 31);
        let r = self.block(b.port);
        ral::modify_reg!(ral::gpio, r, GDIR, |v| v | m);
    }

    /// Make a bit an input.
    pub fn make_input(&self, b: GpioBit) {
        let m = 1u32 << (b.bit & 31);
        let r = self.block(b.port);
        ral::modify_reg!(ral::gpio, r, GDIR, |v| v & !m);
    }

    /// Drive an output high or low (atomic set/clear registers).
    #[inline]
    pub fn write(&self, b: GpioBit, high: bool) {
        let m = 1u32 << (b.bit & 31);
        let r = self.block(b.port);
        if high {
            ral::write_reg!(ral::gpio, r, DR_SET, m);
        } else {
            ral::write_reg!(ral::gpio, r, DR_CLEAR, m);
        }
    }

    /// Read the pad level.
    #[inline]
    pub fn read(&self, b: GpioBit) -> bool {
        let r = self.block(b.port);
        ral::read_reg!(ral::gpio, r, PSR) & (1u32 << (b.bit & 31)) != 0
    }
}

/// Six limit-switch inputs (pull-up, active low), read once per tick; the
/// composition root debounces them (`hal_imxrt::pure::debounce`).
#[derive(Debug)]
pub struct Limits {
    pins: [GpioBit; 6],
}

impl Limits {
    /// Configure the limit pins of `map` as inputs (pads are set up by
    /// [`super::iomux::configure_pins`]).
    pub fn new(gpios: &Gpios, map: &PinMap) -> Result<Self, PinMapError> {
        let mut pins = [GpioBit { port: 1, bit: 0 }; 6];
        for (slot, &p) in pins.iter_mut().zip(map.limit.iter()) {
            let Some(tp) = teensy41_pin(p) else {
                return Err(PinMapError::UnknownPin(p));
            };
            gpios.make_input(tp.gpio);
            *slot = tp.gpio;
        }
        Ok(Self { pins })
    }

    /// The six raw input levels, bit `i` = J(i+1) pin high (switch open).
    pub fn levels(&self, gpios: &Gpios) -> u8 {
        let mut out = 0u8;
        for (i, b) in self.pins.iter().enumerate() {
            if gpios.read(*b) {
                out |= 1u8 << (i & 7);
            }
        }
        out
    }
}
