//! STEP generation on FlexPWM submodules (one submodule per axis, enforced by
//! the pin map) and DIR on GPIO with a settle time before the next STEP edge.
//!
//! Submodule setup: IPG clock, independent outputs, `INIT = 0`,
//! `VAL1 = period - 1` (full-cycle reload), the pulse at the **end** of the
//! period: output high at `VAL2/VAL4 = period - 1 - pulse`, low at
//! `VAL3/VAL5 = period - 1` ([`compares`]). Changes follow [`plan_update`]:
//!
//! * `Retime`: `CLDOK` (cancel a load still pending from an earlier update:
//!   while `LDOK` is set the hardware ignores writes to the buffered
//!   registers), write `PRSC`/`VAL1`/`VAL2|4`/`VAL3|5`, set `LDOK`: the new
//!   values load at the next period boundary, so pulses are never truncated,
//!   and the newest timing replaces one not yet loaded.
//! * `Halt`: set the output's `MASK` bit with `UPDATE_MASK` (immediate; output
//!   forced low).
//! * `Restart`: mask, write DIR (if changed), busy-wait the DIR settle time
//!   (one wait per call, shared by all axes), stop the counter, `CLDOK`,
//!   write the timing, **load it at once** (`CTRL[LDMOD] = 1`, then `LDOK`:
//!   "buffered registers are loaded and take effect immediately upon LDOK
//!   being set"; `LDMOD` back to 0 for the retimes), software `FORCE` (with
//!   `FRCEN`) to re-initialise the counter to `INIT`, unmask, run. The first
//!   period therefore runs at the new rate (twin defect 3, twin/README.md:
//!   with `LDMOD = 0` the values wait for the next `VAL1` match, i.e. one whole
//!   period at the old rate, 50 ms after a stop at 20 steps/s), and its
//!   rising edge comes at the end of that period (defect 4: never at the
//!   restart itself).
//!
//! `SMCTRL2[DBGEN] = 0`: the counters stop while a debugger halts the core
//! (twin defect 5), as the PIT and the watchdog do.
//!
//! An axis on an XBAR route ([`PwmRoute::Xbar`], J6 on pin 7 in the original
//! wiring, twin defect 8): `TCTRL[PWAOT0] = 1` makes PWM_A drive the
//! submodule's `PWM_OUT_TRIG0`, which XBARA1 routes to the pad. The
//! reference material does not say whether `MASK`/`OUTEN` act on the
//! trigger path, so masking such an axis **selects XBARA1 input 0
//! (`LOGIC_LOW`)** for its output (and sets `MASK` as well, harmless if it
//! acts and needed nowhere else); unmasking selects the trigger input again.
//! Both are combinational selections between a low input and the trigger:
//! a stop can truncate a pulse in flight (as `MASK` does) but never makes an
//! extra edge, and a restart unmasks right after `FORCE`, when the trigger is
//! low (counter at `INIT`, the pulse sits at the end of the period).
//!
//! *Bench* (scope on STEP/DIR): that `UPDATE_MASK` masks immediately, the
//! first period after a restart, and the DIR-to-STEP delay. Worst case ISR
//! cost of a reversal: 900 cycles (1.5 us) once per call plus register
//! writes.
//!
//! Buffered registers (`CTRL[PRSC]`, `INIT`, `VAL0..VAL5`) ignore writes
//! while the submodule's `LDOK` is set (twin defect 2, twin/README.md), so every write of them is preceded by `CLDOK` for that submodule
//! and followed by `LDOK`. `MCTRL` read-modify-writes write the `LDOK` field
//! as 0 (writing 0 has no effect; writing back a 1 read a moment earlier
//! would re-arm another submodule's load that its reload has just cleared)
//! and set only the `CLDOK`/`LDOK` bits they mean.

use super::cycles::CycleCounter;
use super::gpio::Gpios;
use crate::pure::clock::{dir_settle_cycles, CPU_HZ, DIR_SETTLE_NS};
use crate::pure::pins::{
    step_fn, teensy41_pin, FlexPwmFn, GpioBit, PinMap, PinMapError, PwmOutput, PwmRoute, XBAR_LOGIC_LOW,
};
use crate::pure::step::{
    compares, plan_update, AxisOutput, Direction, StepCommand, StepConfig, StepTiming, UpdatePlan,
};
use imxrt_ral as ral;
use ral::{pwm, xbara1};

const SETTLE_CYCLES: u32 = dir_settle_cycles(DIR_SETTLE_NS, CPU_HZ);

/// `MCTRL[LDOK]` (write 1 to set, 0 no effect).
const MCTRL_LDOK: u16 = pwm::MCTRL::LDOK::mask;

/// Clear the pending load of the submodules in `bits` (`MCTRL[CLDOK]`,
/// write 1 to clear `LDOK`; reads 0). `LDOK` is written as 0.
fn clear_ldok(rb: &pwm::RegisterBlock, bits: u16) {
    ral::modify_reg!(ral::pwm, rb, MCTRL, |v| (v & !MCTRL_LDOK) | ((bits & 0xF) << 4));
}

/// Set `LDOK` for the submodules in `bits` only (the others' `LDOK` written
/// as 0, `CLDOK` reads 0 so is written as 0).
fn set_ldok(rb: &pwm::RegisterBlock, bits: u16) {
    ral::modify_reg!(ral::pwm, rb, MCTRL, |v| (v & !MCTRL_LDOK) | (bits & 0xF));
}

#[derive(Clone, Copy, Debug)]
struct Axis {
    pwm: FlexPwmFn,
    dir: GpioBit,
    out: AxisOutput,
}

/// The six step generators.
pub struct StepOutputs {
    pwm1: pwm::PWM1,
    pwm2: pwm::PWM2,
    pwm3: pwm::PWM3,
    pwm4: pwm::PWM4,
    xbar: xbara1::XBARA1,
    axes: [Axis; 6],
}

impl core::fmt::Debug for StepOutputs {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("StepOutputs").field("axes", &self.axes).finish_non_exhaustive()
    }
}

impl StepOutputs {
    /// Configure the submodules of `map.step` (outputs masked, counters
    /// stopped) and the DIR pins as outputs, low.
    pub fn new(
        pwm1: pwm::PWM1,
        pwm2: pwm::PWM2,
        pwm3: pwm::PWM3,
        pwm4: pwm::PWM4,
        xbar: xbara1::XBARA1,
        gpios: &Gpios,
        map: &PinMap,
    ) -> Result<Self, PinMapError> {
        let mut axes = [Axis {
            pwm: FlexPwmFn { module: 1, submodule: 0, output: PwmOutput::A, alt: 0, route: PwmRoute::Pad },
            dir: GpioBit { port: 1, bit: 0 },
            out: AxisOutput::INIT,
        }; 6];
        for ((a, &sp), &dp) in axes.iter_mut().zip(map.step.iter()).zip(map.dir.iter()) {
            let Some(f) = step_fn(sp) else {
                return Err(PinMapError::NotStepCapable(sp));
            };
            let Some(d) = teensy41_pin(dp) else {
                return Err(PinMapError::UnknownPin(dp));
            };
            if let PwmRoute::Xbar { inout, .. } = f.route {
                if !(4..=19).contains(&inout) || f.output != PwmOutput::A {
                    return Err(PinMapError::NotStepCapable(sp));
                }
            }
            a.pwm = f;
            a.dir = d.gpio;
        }
        let this = Self { pwm1, pwm2, pwm3, pwm4, xbar, axes };
        for a in axes {
            gpios.write(a.dir, false);
            gpios.make_output(a.dir);
            this.init_submodule(a.pwm);
        }
        Ok(this)
    }

    fn block(&self, module: u8) -> &pwm::RegisterBlock {
        match module {
            1 => &self.pwm1,
            2 => &self.pwm2,
            3 => &self.pwm3,
            _ => &self.pwm4,
        }
    }

    fn init_submodule(&self, f: FlexPwmFn) {
        let rb = self.block(f.module);
        let bit = 1u16 << (f.submodule & 3);
        let sm = &rb.SM[(f.submodule & 3) as usize];
        // stop, masked
        ral::modify_reg!(ral::pwm, rb, MCTRL, |v| v & !MCTRL_LDOK & !(bit << 8));
        self.mask(f, true);
        // Fault inputs (twin defect 1, twin/README.md): at reset
        // FLVL = 0 makes a logic 0 a fault, the inputs come from XBARA1
        // outputs whose reset selection is LOGIC_LOW, and SMDISMAP0 maps
        // every fault to A and B, so every output would stay disabled.
        // Make logic 1 the fault level (nothing routes one) and clear the
        // latched flags (w1c), as imxrt-hal and the Teensy core do.
        ral::write_reg!(ral::pwm, rb, FCTRL0, FLVL: 0xF);
        ral::write_reg!(ral::pwm, rb, FSTS0, FFLAG: 0xF);
        // IPG clock, local reload, local software FORCE re-initialises counter,
        // independent A/B outputs.
        ral::write_reg!(
            ral::pwm::sm,
            sm,
            SMCTRL2,
            CLK_SEL: 0,
            RELOAD_SEL: 0,
            FORCE_SEL: 0,
            FRCEN: 1,
            INIT_SEL: 0,
            INDEP: 1,
            DBGEN: 0
        );
        // A load left pending (by a warm reset that kept the peripheral's
        // state) would make the buffered writes below be ignored.
        clear_ldok(rb, bit);
        ral::write_reg!(ral::pwm::sm, sm, SMCTRL, FULL: 1, PRSC: 0, LDMOD: 0);
        ral::write_reg!(ral::pwm::sm, sm, SMINIT, 0);
        ral::write_reg!(ral::pwm::sm, sm, SMVAL0, 0);
        ral::write_reg!(ral::pwm::sm, sm, SMVAL1, 0xFFFF);
        ral::write_reg!(ral::pwm::sm, sm, SMVAL2, 0);
        ral::write_reg!(ral::pwm::sm, sm, SMVAL3, 0);
        ral::write_reg!(ral::pwm::sm, sm, SMVAL4, 0);
        ral::write_reg!(ral::pwm::sm, sm, SMVAL5, 0);
        set_ldok(rb, bit); // loads at the first reload (a restart loads its own)
        if let PwmRoute::Xbar { .. } = f.route {
            // PWM_A drives PWM_OUT_TRIG0 (towards XBARA1)
            ral::write_reg!(ral::pwm::sm, sm, SMTCTRL, PWAOT0: 1);
        }
        // output enable for our output only
        match f.output {
            PwmOutput::A => ral::modify_reg!(ral::pwm, rb, OUTEN, |v| v | (bit << 8)),
            PwmOutput::B => ral::modify_reg!(ral::pwm, rb, OUTEN, |v| v | (bit << 4)),
        }
    }

    /// Select XBARA1 `input` for output `out` (4..=19; `SELn` holds outputs
    /// 2n and 2n + 1 in its low and high byte).
    fn xbar_select(&self, out: u8, input: u8) {
        let shift = if out & 1 == 0 { 0 } else { 8 };
        let m = 0x7Fu16 << shift;
        let v = u16::from(input & 0x7F) << shift;
        let x = &self.xbar;
        match out / 2 {
            2 => ral::modify_reg!(ral::xbara1, x, SEL2, |r| (r & !m) | v),
            3 => ral::modify_reg!(ral::xbara1, x, SEL3, |r| (r & !m) | v),
            4 => ral::modify_reg!(ral::xbara1, x, SEL4, |r| (r & !m) | v),
            5 => ral::modify_reg!(ral::xbara1, x, SEL5, |r| (r & !m) | v),
            6 => ral::modify_reg!(ral::xbara1, x, SEL6, |r| (r & !m) | v),
            7 => ral::modify_reg!(ral::xbara1, x, SEL7, |r| (r & !m) | v),
            8 => ral::modify_reg!(ral::xbara1, x, SEL8, |r| (r & !m) | v),
            9 => ral::modify_reg!(ral::xbara1, x, SEL9, |r| (r & !m) | v),
            _ => {} // refused by `new`
        }
    }

    /// Mask (force low) or unmask the axis output immediately.
    fn mask(&self, f: FlexPwmFn, masked: bool) {
        if let PwmRoute::Xbar { inout, input } = f.route {
            self.xbar_select(inout, if masked { XBAR_LOGIC_LOW } else { input });
        }
        let rb = self.block(f.module);
        let bit = 1u16 << (f.submodule & 3);
        let m = match f.output {
            PwmOutput::A => bit << 8,
            PwmOutput::B => bit << 4,
        };
        let update = bit << 12;
        if masked {
            ral::modify_reg!(ral::pwm, rb, MASK, |v| v | m | update);
        } else {
            ral::modify_reg!(ral::pwm, rb, MASK, |v| (v & !m) | update);
        }
    }

    /// `CLDOK`, then the buffered timing registers (`PRSC`, `VAL1`, the
    /// output's two compares); `LDOK` is left to the caller.
    fn write_buffers(&self, f: FlexPwmFn, t: StepTiming) {
        let rb = self.block(f.module);
        let bit = 1u16 << (f.submodule & 3);
        let sm = &rb.SM[(f.submodule & 3) as usize];
        let c = compares(&t);
        // A load still pending (period longer than the update interval)
        // is replaced by this one: the buffers are writable only once its
        // LDOK is cleared. Between the CLDOK and the LDOK a period
        // boundary loads nothing, so PRSC/VAL1/compares load together.
        clear_ldok(rb, bit);
        ral::modify_reg!(ral::pwm::sm, sm, SMCTRL, PRSC: t.prescaler_log2 as u16 & 7);
        ral::write_reg!(ral::pwm::sm, sm, SMVAL1, c.val1);
        match f.output {
            PwmOutput::A => {
                ral::write_reg!(ral::pwm::sm, sm, SMVAL2, c.on);
                ral::write_reg!(ral::pwm::sm, sm, SMVAL3, c.off);
            }
            PwmOutput::B => {
                ral::write_reg!(ral::pwm::sm, sm, SMVAL4, c.on);
                ral::write_reg!(ral::pwm::sm, sm, SMVAL5, c.off);
            }
        }
    }

    /// Retime a running output: buffers, `LDOK` (loads at the next reload).
    fn write_timing(&self, f: FlexPwmFn, t: StepTiming) {
        self.write_buffers(f, t);
        set_ldok(self.block(f.module), 1u16 << (f.submodule & 3));
    }

    fn restart(&self, f: FlexPwmFn, t: StepTiming) {
        let rb = self.block(f.module);
        let bit = 1u16 << (f.submodule & 3);
        let sm = &rb.SM[(f.submodule & 3) as usize];
        ral::modify_reg!(ral::pwm, rb, MCTRL, |v| v & !MCTRL_LDOK & !(bit << 8)); // RUN = 0
        self.write_buffers(f, t); // CLDOK, values
                                  // Load now (LDMOD = 1: on LDOK), not at the next VAL1 match.
        ral::modify_reg!(ral::pwm::sm, sm, SMCTRL, LDMOD: 1);
        set_ldok(rb, bit);
        ral::modify_reg!(ral::pwm::sm, sm, SMCTRL, LDMOD: 0);
        clear_ldok(rb, bit); // nothing pending (the load has cleared it)
        ral::modify_reg!(ral::pwm::sm, sm, SMCTRL2, FORCE: 1); // counter := INIT
        self.mask(f, false);
        ral::modify_reg!(ral::pwm, rb, MCTRL, |v| (v & !MCTRL_LDOK) | (bit << 8));
        // RUN = 1
    }

    /// Apply one tick's commands (J1..J6). All DIR writes happen first, then
    /// a single settle wait, then the restarts.
    pub fn apply(&mut self, gpios: &Gpios, cycles: &CycleCounter, cmds: &[StepCommand; 6]) {
        let mut plans = [UpdatePlan::Idle; 6];
        let mut dir_written_at: Option<u32> = None;
        for ((a, p), &c) in self.axes.iter_mut().zip(plans.iter_mut()).zip(cmds.iter()) {
            let (plan, next) = plan_update(a.out, c, &StepConfig::DEFAULT);
            *p = plan;
            a.out = next;
        }
        for (a, p) in self.axes.iter().zip(plans.iter()) {
            match *p {
                UpdatePlan::Idle => {}
                UpdatePlan::Halt => self.mask(a.pwm, true),
                UpdatePlan::Retime(t) => self.write_timing(a.pwm, t),
                UpdatePlan::Restart { timing, dir_change } => {
                    self.mask(a.pwm, true);
                    if dir_change {
                        gpios.write(a.dir, timing.dir == Direction::Positive);
                        dir_written_at = Some(cycles.now());
                    }
                }
            }
        }
        if let Some(t0) = dir_written_at {
            cycles.wait_since(t0, SETTLE_CYCLES);
        }
        for (a, p) in self.axes.iter().zip(plans.iter()) {
            if let UpdatePlan::Restart { timing, .. } = *p {
                self.restart(a.pwm, timing);
            }
        }
    }

    /// Mask every output now (E-stop path; DIR untouched).
    pub fn halt_all(&mut self) {
        for a in self.axes.iter_mut() {
            a.out.running = false;
        }
        for a in self.axes {
            self.mask(a.pwm, true);
        }
    }
}
