//! The i.MXRT1062 peripheral models behind the MMIO hooks, and their wiring
//! to the plant. Time is `now`, in CPU cycles = executed instructions (the
//! twin counts 1 instruction as 1 cycle at 600 MHz).

use std::collections::{HashMap, VecDeque};

use crate::pads::{self, wiring, Pad};
use crate::plant::Plant;
use crate::pwm::{FlexPwm, PadRoute};
use crate::qtimer::{InputWave, QTimer};

/// CPU cycles per second. The twin keeps its own figures for the chip and
/// the sensors (here, `qtimer.rs`, `plant.rs`) on purpose rather than
/// importing the HAL's: it is an independent model the image is checked
/// against, so a wrong figure in the HAL shows as a disagreement.
pub const CPU_HZ: u64 = 600_000_000;
/// PIT interrupt number (i.MXRT1062).
pub const IRQ_PIT: u32 = 122;
/// LPO clock of the RTWDOG (32 kHz nominal), cycles per LPO tick.
pub const LPO_CYCLES: f64 = CPU_HZ as f64 / 32_000.0;

// Base addresses (imxrt-ral `imxrt1062.rs`).
const CCM: u32 = 0x400F_C000;
const CCM_ANALOG: u32 = 0x400D_8000;
const DCDC: u32 = 0x4008_0000;
const SRC: u32 = 0x400F_8000;
const IOMUXC: u32 = 0x401F_8000;
const IOMUXC_GPR: u32 = 0x400A_C000;
const GPIO: [u32; 4] = [0x401B_8000, 0x401B_C000, 0x401C_0000, 0x401C_4000];
const PIT: u32 = 0x4008_4000;
const RTWDOG: u32 = 0x400B_C000;
const LPUART6: u32 = 0x4019_8000;
const TMR: [u32; 4] = [0x401D_C000, 0x401E_0000, 0x401E_4000, 0x401E_8000];
const PWM: [u32; 4] = [0x403D_C000, 0x403E_0000, 0x403E_4000, 0x403E_8000];
const XBARA1: u32 = 0x403B_C000;
const USB1: u32 = 0x402E_0000;
const USBPHY1: u32 = 0x400D_9000;

/// XBARA1 outputs feeding FlexPWM1..4 FAULT0..3.
const FAULT_XBAR: [[usize; 4]; 4] = [[35, 36, 37, 38], [49, 50, 37, 38], [56, 57, 37, 38], [63, 64, 37, 38]];

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

/// PIT channel.
#[derive(Clone, Debug, Default)]
pub struct PitCh {
    /// LDVAL.
    pub ldval: u32,
    /// TCTRL.
    pub tctrl: u32,
    /// TIF.
    pub tif: bool,
    /// Time the counter was (re)loaded.
    pub start: u64,
    /// Expiries counted so far since `start`.
    pub expiries: u64,
}

/// RTWDOG state.
#[derive(Clone, Debug, Default)]
pub struct Wdog {
    /// CS.
    pub cs: u32,
    /// TOVAL.
    pub toval: u32,
    /// WIN.
    pub win: u32,
    /// Time of the last refresh/configuration.
    pub since: u64,
    /// Unlocked (ULK) until this time.
    pub unlocked_until: u64,
    /// Refreshes seen.
    pub refreshes: u64,
}

/// LPUART6.
#[derive(Clone, Debug, Default)]
pub struct Uart {
    /// Registers by offset/4.
    pub r: [u32; 12],
    /// TX FIFO.
    pub tx_fifo: VecDeque<u8>,
    /// Shifter busy until.
    pub tx_busy_until: u64,
    /// Bytes sent on the wire (with their completion time).
    pub tx_out: Vec<(u64, u8)>,
    /// RX FIFO.
    pub rx_fifo: VecDeque<u8>,
    /// Host bytes not yet on the wire.
    pub rx_pending: VecDeque<u8>,
    /// Next time a host byte can arrive.
    pub rx_next: u64,
    /// Overrun flag.
    pub or: bool,
}

/// What happened that the machine must act on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reset {
    /// RTWDOG timeout.
    Watchdog,
}

/// All peripheral state.
pub struct Board {
    /// Simulated time in CPU cycles.
    pub now: u64,
    /// Generic register file for unmodelled registers (address -> value).
    pub regs: HashMap<u32, u32>,
    /// GPIO1..4.
    pub gpio: [Gpio; 4],
    /// PIT channels and MCR.
    pub pit: [PitCh; 4],
    /// PIT MCR.
    pub pit_mcr: u32,
    /// RTWDOG.
    pub wdog: Wdog,
    /// LPUART6.
    pub uart: Uart,
    /// TMR1..4.
    pub tmr: [QTimer; 4],
    /// PWM1..4.
    pub pwm: [FlexPwm; 4],
    /// XBARA1 select per output.
    pub xbar: [u8; 132],
    /// The last FlexPWM trigger selected per XBARA1 output (bookkeeping: the
    /// output's pulse log while `LOGIC_LOW` is selected).
    pub xbar_last_trigger: HashMap<usize, (usize, usize)>,
    /// The arm.
    pub plant: Plant,
    /// SRC SRSR.
    pub srsr: u32,
    /// SCB VTOR.
    pub vtor: u32,
    /// NVIC ISER bits.
    pub nvic_en: [u32; 8],
    /// NVIC IPR: one priority byte per interrupt (the i.MXRT1062 implements
    /// the upper 4 bits; the lower read 0).
    pub nvic_ipr: [u8; 240],
    /// DWT CYCCNT offset (CYCCNT = now + offset when enabled).
    pub cyccnt_off: u32,
    /// DWT CTRL.
    pub dwt_ctrl: u32,
    /// DEMCR.
    pub demcr: u32,
    /// Pending reset.
    pub reset: Option<Reset>,
    /// Log of accesses to unmodelled registers (address, write?) for diagnostics.
    pub unmodelled: HashMap<u32, u64>,
    /// The CPU stops at the next block boundary at or after this time.
    pub stop_at: u64,
    /// Hint instructions (YIELD/WFE/WFI/SEV) patched to NOP.
    pub hints_patched: u64,
    /// Block at which the last stop was requested.
    pub stopped_at: Option<u32>,
    /// Stops deferred because the CPU was inside an IT block.
    pub it_deferred: u64,
    /// Set by the harness: the PIT interrupt is pending and enabled but
    /// masked (PRIMASK, FAULTMASK or BASEPRI) in thread code, so the block
    /// hook stops the CPU at the first block that runs unmasked (the
    /// instruction after the one that lifted the mask: QEMU ends a
    /// translated block after `MSR PRIMASK`/`BASEPRI`/`FAULTMASK` and
    /// `CPSIE`), where the harness takes the interrupt.
    pub irq_wait_unmask: bool,
    /// PIT entries that waited for the mask to be lifted.
    pub irq_unmask_entries: u64,
    /// Last translated-block addresses (diagnostics).
    pub trace: [u32; 16],
    /// Next slot of `trace`.
    pub trace_i: usize,
    /// The PIT handler is running (set by the harness around each call).
    pub in_pit: bool,
    /// Instructions executed inside the PIT handler, per translated-block
    /// address (the per-function profile of the tick interrupt).
    pub pit_blocks: HashMap<u32, u64>,
    /// Address of `main` (the image's entry after the runtime's reset code).
    pub main_addr: u32,
    /// Times (cycles) at which `main` was entered, one per boot.
    pub main_at: Vec<u64>,
    /// Test control, not hardware: drive every FlexPWM fault input to its
    /// inactive level regardless of XBAR/FLVL (shows what the image would
    /// do with the faults disarmed).
    pub faults_forced_inactive: bool,
    /// Skip idle main-loop time (see `Twin` docs): enabled.
    pub idle_skip: bool,
    /// Set by the harness: the CPU runs thread code (no handler) after the
    /// PIT interrupt was enabled, so idle time may be skipped.
    pub idle_skip_allowed: bool,
    /// Time of the last MMIO write (peripherals or core peripherals).
    pub last_write_at: u64,
    /// The block hook stopped the CPU because it was idle.
    pub idle_stop: bool,
}

impl Board {
    /// Power-on state.
    pub fn new(plant: Plant) -> Self {
        let mut b = Board {
            now: 0,
            regs: HashMap::new(),
            gpio: Default::default(),
            pit: Default::default(),
            pit_mcr: 0x2, // MDIS = 1 at reset
            wdog: Wdog::default(),
            uart: Uart::default(),
            tmr: Default::default(),
            pwm: Default::default(),
            xbar: [0; 132],
            xbar_last_trigger: HashMap::new(),
            plant,
            srsr: 1, // IPP_RESET_B: power-on
            vtor: 0,
            nvic_en: [0; 8],
            nvic_ipr: [0; 240],
            cyccnt_off: 0,
            dwt_ctrl: 0x4000_0000,
            demcr: 0,
            reset: None,
            unmodelled: HashMap::new(),
            stop_at: 0,
            hints_patched: 0,
            it_deferred: 0,
            irq_wait_unmask: false,
            irq_unmask_entries: 0,
            stopped_at: None,
            trace: [0; 16],
            trace_i: 0,
            in_pit: false,
            pit_blocks: HashMap::new(),
            main_addr: u32::MAX,
            main_at: Vec::new(),
            faults_forced_inactive: false,
            idle_skip: std::env::var_os("TWIN_NO_IDLE_SKIP").is_none(),
            idle_skip_allowed: false,
            last_write_at: 0,
            idle_stop: false,
        };
        b.reset_peripherals();
        b
    }

    /// Chip reset (watchdog): every peripheral back to reset, plant and
    /// time kept, SRSR records the cause.
    pub fn reset_peripherals(&mut self) {
        self.regs.clear();
        self.gpio = Default::default();
        self.pit = Default::default();
        self.pit_mcr = 0x2;
        // After the boot ROM the RTWDOG is disabled (the twin's assumption).
        self.wdog = Wdog { cs: 0x2120, toval: 0x0400, ..Wdog::default() };
        // the wire's history (what a terminal saw) survives the reset
        let out = std::mem::take(&mut self.uart.tx_out);
        self.uart = Uart { tx_out: out, ..Uart::default() };
        self.uart.r[1] = 0x0202; // PARAM: 4-entry FIFOs
        self.tmr = Default::default();
        for p in self.pwm.iter_mut() {
            let rec = p.record;
            *p = FlexPwm::new();
            p.record = rec;
        }
        self.xbar = [0; 132];
        self.xbar_last_trigger.clear();
        self.vtor = 0;
        self.nvic_en = [0; 8];
        self.nvic_ipr = [0; 240];
        self.dwt_ctrl = 0x4000_0000;
        self.demcr = 0;
        for p in self.plant.joints.iter_mut() {
            let _ = p;
        }
        for t in self.tmr.iter_mut() {
            for c in t.ch.iter_mut() {
                c.t = self.now;
            }
        }
        for p in self.pwm.iter_mut() {
            p.settle_time(self.now);
        }
        self.uart.rx_next = self.now;
    }

    // ---------------------------------------------------------------- pins

    fn iomux(&self, off: u32) -> u32 {
        self.regs.get(&(IOMUXC + off)).copied().unwrap_or(0)
    }

    /// ALT selected on a pad (SW_MUX_CTL bits 2:0) and SION.
    pub fn pad_mux(&self, p: Pad) -> (u32, bool) {
        let v = self.iomux(p.mux_offset());
        (v & 7, v & 0x10 != 0)
    }

    /// The pad is driven by GPIO1..4 (ALT5 and the GPR26..29 bit clear).
    fn pad_is_std_gpio(&self, p: Pad) -> bool {
        let (port, bit) = p.gpio();
        let gpr = self.regs.get(&(IOMUXC_GPR + 0x68 + 4 * (port as u32 - 1))).copied().unwrap_or(0);
        self.pad_mux(p).0 == 5 && gpr & (1 << bit) == 0
    }

    /// Level driven onto a pad by GPIO (if it is a GPIO output).
    pub fn gpio_out(&self, pin: u8) -> Option<bool> {
        let p = pads::teensy_pad(pin)?;
        let (port, bit) = p.gpio();
        let g = &self.gpio[port - 1];
        if self.pad_is_std_gpio(p) && g.gdir & (1 << bit) != 0 {
            Some(g.dr & (1 << bit) != 0)
        } else {
            None
        }
    }

    /// DIR line of axis `i`: the GPIO level if driven, else low (driver
    /// input pulled low).
    pub fn dir_level(&self, i: usize) -> bool {
        self.gpio_out(wiring().dir[i]).unwrap_or(false)
    }

    /// External level on a pad (what the outside world drives or pulls).
    fn external_level(&self, p: Pad) -> bool {
        for (i, &pin) in wiring().limit.iter().enumerate() {
            if pads::teensy_pad(pin) == Some(p) {
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

    fn gpio_psr(&self, port: usize) -> u32 {
        let g = &self.gpio[port];
        let mut v = 0u32;
        for pin in 0..=41u8 {
            let Some(p) = pads::teensy_pad(pin) else { continue };
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
        let Some(p) = pads::teensy_pad(pin) else { return "unknown".into() };
        let (alt, sion) = self.pad_mux(p);
        if alt == 5 {
            let (port, bit) = p.gpio();
            return format!("GPIO{port}.{bit}{}", if self.pad_is_std_gpio(p) { "" } else { " (fast GPIO)" });
        }
        if let Some((m, s, b, a)) = pads::pwm_function(p) {
            if a == alt {
                return format!("FLEXPWM{m}_PWM{}{s}", if b { 'B' } else { 'A' });
            }
        }
        if let Some((a, inout)) = pads::xbar_inout_function(p) {
            if a == alt {
                let dir = if self.pad_xbar_output(p).is_some() { "output" } else { "input" };
                return format!("XBAR1_INOUT{inout} ({dir})");
            }
        }
        if let Some((m, c, a, daisy)) = pads::qtimer_function(p) {
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
    fn reg(&self, a: u32) -> u32 {
        self.regs.get(&a).copied().unwrap_or_else(|| reset_value(a))
    }

    /// XBARA1 output `out` (0..132) as a FlexPWM trigger: (module,
    /// submodule) whose `PWM_OUT_TRIG0_1` is selected (inputs 40..=51 =
    /// FlexPWM1..3 submodules 0..3, NXP SDK XBARA1 input table), if the
    /// XBAR1 clock gate (CCGR2 CG11) is open.
    fn xbar_trigger_source(&self, out: usize) -> Option<(usize, usize)> {
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
    fn pad_xbar_output(&self, p: Pad) -> Option<usize> {
        let (alt, inout) = pads::xbar_inout_function(p)?;
        let gpr6 = self.reg(IOMUXC_GPR + 0x18);
        (self.pad_mux(p).0 == alt && gpr6 & (1 << (12 + inout)) != 0).then_some(inout)
    }

    /// Where a pad's level comes from, if a FlexPWM drives it: (module,
    /// submodule, log index 0 = A / 1 = B on the pad, 2 = `PWM_OUT_TRIG0`
    /// through XBARA1).
    pub fn pad_pwm_source(&self, p: Pad) -> Option<(usize, usize, usize)> {
        if let Some((m, s, b, a)) = pads::pwm_function(p) {
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
    fn pwm_routes(&self) -> [PadRoute; 4] {
        let mut r = [PadRoute::default(); 4];
        for pin in wiring().step {
            let Some(p) = pads::teensy_pad(pin) else { continue };
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

    // ------------------------------------------------------------ time

    /// Bring the analogue world up to `now`: PWM pulses -> plant, encoder
    /// waveforms -> QuadTimers, UART shifting, XBAR fault levels.
    pub fn sync(&mut self) {
        let now = self.now;
        // fault inputs from XBARA1 (input 0 = LOGIC_LOW, 1 = LOGIC_HIGH)
        for (m, outs) in FAULT_XBAR.iter().enumerate() {
            for (f, &o) in outs.iter().enumerate() {
                let level = self.xbar[o] == 1;
                let flvl = self.pwm[m].fctrl & (1 << (12 + f)) != 0;
                self.pwm[m].fault_in[f] = if self.faults_forced_inactive { !flvl } else { level };
            }
        }
        let routes = self.pwm_routes();
        let before = self.step_pulses();
        for (m, p) in self.pwm.iter_mut().enumerate() {
            p.advance(now, &routes[m]);
        }
        let after = self.step_pulses();
        for i in 0..6 {
            let d = after[i] - before[i];
            if d > 0 {
                let dir = if self.dir_level(i) { 1 } else { -1 };
                self.plant.joints[i].steps += dir * d as i64;
            }
        }
        // encoders -> TMR1/TMR3 channels whose pads are selected
        for (i, &pin) in wiring().encoder.iter().enumerate() {
            let Some(p) = pads::teensy_pad(pin) else { continue };
            let Some((m, c, alt, daisy)) = pads::qtimer_function(p) else { continue };
            let (pad_alt, _) = self.pad_mux(p);
            let selected = pad_alt == alt && daisy.is_none_or(|(off, val)| self.iomux(off) & 3 == val);
            let mut wave = JointWave { plant: &mut self.plant, axis: i, connected: selected };
            self.tmr[m - 1].advance(c, now, &mut wave);
        }
        self.uart_sync();
    }

    /// After a debug halt of `cycles`: the blocks that stop in debug mode
    /// resume where they stopped (PIT if `MCR[FRZ]`, RTWDOG unless
    /// `CS[DBG]`, CYCCNT always).
    pub fn debug_halt_time_bases(&mut self, cycles: u64) {
        if self.pit_mcr & 1 != 0 {
            for ch in self.pit.iter_mut() {
                ch.start += cycles;
            }
        }
        if self.wdog.cs & (1 << 2) == 0 {
            self.wdog.since += cycles;
        }
        self.cyccnt_off = self.cyccnt_off.wrapping_sub(cycles as u32);
    }

    /// Record every FlexPWM output's rising-edge times from now on.
    pub fn record_edges(&mut self) {
        self.sync();
        for p in self.pwm.iter_mut() {
            p.record = true;
        }
    }

    /// The FlexPWM submodule log behind axis `i`'s STEP pin: (module,
    /// submodule, log index) for a pad muxed to a PWM output, or for pin 7
    /// routed through XBARA1 the trigger log.
    pub fn step_source(&self, i: usize) -> Option<(usize, usize, usize)> {
        self.pad_pwm_source(pads::teensy_pad(wiring().step[i])?)
    }

    /// Rising-edge times (cycles) recorded on axis `i`'s STEP pin.
    pub fn step_rises(&self, i: usize) -> Vec<u64> {
        match self.step_source(i) {
            Some((m, s, b)) => self.pwm[m - 1].sm[s].log[b].rises.clone(),
            None => Vec::new(),
        }
    }

    // ------------------------------------------------------------ PIT

    fn pit_clock_cycles(&self) -> u64 {
        // CSCMR1: PERCLK_CLK_SEL (bit 6): 1 = OSC 24 MHz, 0 = IPG 150 MHz; PODF 5:0
        let cscmr1 = self.regs.get(&(CCM + 0x1C)).copied().unwrap_or(0x0400_0000);
        let podf = u64::from(cscmr1 & 0x3F) + 1;
        if cscmr1 & (1 << 6) != 0 {
            25 * podf
        } else {
            4 * podf
        }
    }

    fn pit_update(&mut self) {
        let clk = self.pit_clock_cycles();
        let mdis = self.pit_mcr & 2 != 0;
        for ch in self.pit.iter_mut() {
            if mdis || ch.tctrl & 1 == 0 {
                continue;
            }
            let period = (u64::from(ch.ldval) + 1) * clk;
            let n = (self.now.saturating_sub(ch.start)) / period;
            if n > ch.expiries {
                ch.tif = true;
                ch.expiries = n;
            }
        }
    }

    /// Nothing for the image to read on LPUART6 now (RX FIFO empty; bytes
    /// still on the wire arrive at [`Board::uart_rx_next_event`]).
    pub fn uart_rx_quiet(&self) -> bool {
        self.uart.rx_fifo.is_empty()
    }

    /// When the next host byte lands in the RX FIFO, if one is on its way.
    pub fn uart_rx_next_event(&self) -> Option<u64> {
        (!self.uart.rx_pending.is_empty()).then_some(self.uart.rx_next.max(self.now + 1))
    }

    /// When the LPUART6 transmitter next changes state (the shifter takes
    /// the next FIFO byte or finishes), if it is busy.
    pub fn uart_tx_next_event(&self) -> Option<u64> {
        (self.uart.tx_busy_until > self.now || !self.uart.tx_fifo.is_empty())
            .then_some(self.uart.tx_busy_until.max(self.now + 1))
    }

    /// The next PIT expiry (cycles), if a channel runs.
    pub fn next_pit(&self) -> Option<u64> {
        let clk = self.pit_clock_cycles();
        if self.pit_mcr & 2 != 0 {
            return None;
        }
        self.pit
            .iter()
            .filter(|ch| ch.tctrl & 1 != 0)
            .map(|ch| ch.start + (ch.expiries + 1) * (u64::from(ch.ldval) + 1) * clk)
            .min()
    }

    /// Next time anything needs the CPU's attention (PIT expiry, watchdog).
    pub fn next_event(&self) -> u64 {
        let mut t = u64::MAX;
        let clk = self.pit_clock_cycles();
        if self.pit_mcr & 2 == 0 {
            for ch in &self.pit {
                if ch.tctrl & 1 != 0 {
                    let period = (u64::from(ch.ldval) + 1) * clk;
                    t = t.min(ch.start + (ch.expiries + 1) * period);
                }
            }
        }
        if let Some(w) = self.wdog_deadline() {
            t = t.min(w);
        }
        t
    }

    /// When the pending PIT interrupt was raised: the latest expiry of a
    /// channel whose `TIF` and `TIE` are set (the earliest such channel if
    /// several), or `None` if none is pending.
    pub fn pit_raised_at(&self) -> Option<u64> {
        let clk = self.pit_clock_cycles();
        self.pit
            .iter()
            .filter(|c| c.tif && c.tctrl & 2 != 0 && c.expiries > 0)
            .map(|c| c.start + c.expiries * (u64::from(c.ldval) + 1) * clk)
            .min()
    }

    /// The PIT interrupt is pending and enabled in the NVIC.
    pub fn pit_irq(&mut self) -> bool {
        self.pit_update();
        let pending = self.pit.iter().any(|c| c.tif && c.tctrl & 2 != 0);
        pending && self.nvic_en[(IRQ_PIT / 32) as usize] & (1 << (IRQ_PIT % 32)) != 0
    }

    // ------------------------------------------------------------ RTWDOG

    fn wdog_deadline(&self) -> Option<u64> {
        let w = &self.wdog;
        if w.cs & (1 << 7) == 0 {
            return None;
        }
        let pres = if w.cs & (1 << 12) != 0 { 256.0 } else { 1.0 };
        let lpo = (w.cs >> 8) & 3 == 1;
        let tick = if lpo { LPO_CYCLES } else { 4.0 };
        Some(w.since + (f64::from(w.toval) * pres * tick) as u64)
    }

    /// Check the watchdog; sets `reset` on timeout.
    pub fn wdog_check(&mut self) {
        if let Some(d) = self.wdog_deadline() {
            if self.now >= d {
                self.reset = Some(Reset::Watchdog);
            }
        }
    }

    fn wdog_read(&self, off: u32) -> u32 {
        match off {
            0x0 => {
                let mut cs = self.wdog.cs;
                if self.now < self.wdog.unlocked_until {
                    cs |= 1 << 11;
                }
                cs | (1 << 10) // RCS: reconfiguration done at once
            }
            0x4 => {
                let w = &self.wdog;
                let tick = if (w.cs >> 8) & 3 == 1 { LPO_CYCLES } else { 4.0 };
                ((self.now - w.since) as f64 / tick) as u32 & 0xFFFF
            }
            0x8 => self.wdog.toval,
            _ => self.wdog.win,
        }
    }

    fn wdog_write(&mut self, off: u32, v: u32) {
        let unlocked = self.now < self.wdog.unlocked_until;
        match off {
            0x4 => {
                if v == 0xD928_C520 {
                    // unlock window: 255 bus clocks (IPG = 4 cycles)
                    self.wdog.unlocked_until = self.now + 255 * 4;
                } else if v == 0xB480_A602 {
                    self.wdog.since = self.now;
                    self.wdog.refreshes += 1;
                }
            }
            0x0 if unlocked => {
                self.wdog.cs = v & !(1 << 14);
                self.wdog.since = self.now;
                self.wdog.unlocked_until = 0;
            }
            0x8 if unlocked => self.wdog.toval = v & 0xFFFF,
            0xC if unlocked => self.wdog.win = v & 0xFFFF,
            _ => {}
        }
    }

    // ------------------------------------------------------------ LPUART6

    fn uart_byte_cycles(&self) -> u64 {
        let baud = self.uart.r[4];
        let sbr = u64::from(baud & 0x1FFF).max(1);
        let osr = u64::from((baud >> 24) & 0x1F) + 1;
        let osr = if osr < 4 { 16 } else { osr };
        // UART_CLK_ROOT: CSCDR1 UART_CLK_SEL (bit 6) 1 = OSC 24 MHz, PODF 5:0
        let cscdr1 = self.regs.get(&(CCM + 0x24)).copied().unwrap_or(0);
        let src = if cscdr1 & (1 << 6) != 0 { 24_000_000u64 } else { 80_000_000 };
        let clk = src / (u64::from(cscdr1 & 0x3F) + 1);
        10 * sbr * osr * CPU_HZ / clk
    }

    fn uart_sync(&mut self) {
        let byte = self.uart_byte_cycles();
        let te = self.uart.r[6] & (1 << 19) != 0;
        let re = self.uart.r[6] & (1 << 18) != 0;
        while te && !self.uart.tx_fifo.is_empty() && self.uart.tx_busy_until <= self.now {
            if let Some(b) = self.uart.tx_fifo.pop_front() {
                let done = self.uart.tx_busy_until + byte;
                self.uart.tx_out.push((done, b));
                self.uart.tx_busy_until = done;
            }
        }
        while re && !self.uart.rx_pending.is_empty() && self.uart.rx_next <= self.now {
            if let Some(b) = self.uart.rx_pending.pop_front() {
                if self.uart.rx_fifo.len() >= 4 {
                    self.uart.or = true;
                } else {
                    self.uart.rx_fifo.push_back(b);
                }
                self.uart.rx_next += byte;
            }
        }
        if self.uart.rx_pending.is_empty() && self.uart.rx_next < self.now {
            self.uart.rx_next = self.now;
        }
    }

    /// Bytes the image has transmitted on Serial1 so far.
    pub fn serial_text(&self) -> String {
        let v: Vec<u8> = self.uart.tx_out.iter().map(|&(_, b)| b).collect();
        String::from_utf8_lossy(&v).into_owned()
    }

    /// Queue host bytes onto Serial1's RX line.
    pub fn serial_send(&mut self, bytes: &[u8]) {
        self.uart.rx_pending.extend(bytes.iter().copied());
    }

    fn uart_read(&mut self, off: u32) -> u32 {
        match off {
            0x14 => {
                let mut s = self.uart.r[5] & 0x3F00_0000;
                let fifo_room = self.uart.tx_fifo.is_empty();
                if fifo_room {
                    s |= 1 << 23; // TDRE (TXWATER = 0)
                }
                if self.uart.tx_fifo.is_empty() && self.uart.tx_busy_until <= self.now {
                    s |= 1 << 22; // TC
                }
                if !self.uart.rx_fifo.is_empty() {
                    s |= 1 << 21; // RDRF
                }
                if self.uart.or {
                    s |= 1 << 19;
                }
                s
            }
            0x1C => match self.uart.rx_fifo.pop_front() {
                Some(b) => u32::from(b),
                None => 1 << 12, // RXEMPT
            },
            0x28 => {
                let mut f = self.uart.r[10] & !0x00C0_0000;
                if self.uart.tx_fifo.is_empty() {
                    f |= 1 << 23; // TXEMPT
                }
                if self.uart.rx_fifo.is_empty() {
                    f |= 1 << 22; // RXEMPT
                }
                f | 0x11 // TXFIFOSIZE / RXFIFOSIZE = 4
            }
            o => self.uart.r.get((o / 4) as usize).copied().unwrap_or(0),
        }
    }

    fn uart_write(&mut self, off: u32, v: u32) {
        match off {
            0x8 => {
                if v & 2 != 0 {
                    let param = self.uart.r[1];
                    let out = std::mem::take(&mut self.uart.tx_out);
                    let pend = std::mem::take(&mut self.uart.rx_pending);
                    self.uart = Uart { tx_out: out, rx_pending: pend, rx_next: self.now, ..Uart::default() };
                    self.uart.r[1] = param;
                }
                self.uart.r[2] = v;
            }
            0x14 if v & (1 << 19) != 0 => self.uart.or = false,
            0x14 => {}
            0x1C if self.uart.r[6] & (1 << 19) != 0 => {
                if self.uart.tx_fifo.is_empty() && self.uart.tx_busy_until <= self.now {
                    let done = self.now + self.uart_byte_cycles();
                    self.uart.tx_out.push((done, v as u8));
                    self.uart.tx_busy_until = done;
                } else if self.uart.tx_fifo.len() < 4 {
                    self.uart.tx_fifo.push_back(v as u8);
                }
            }
            0x1C => {}
            o if (o / 4) < 12 => self.uart.r[(o / 4) as usize] = v,
            _ => {}
        }
    }

    // ------------------------------------------------------------ MMIO

    /// Peripheral read (address in 0x4000_0000..0x4040_0000 or GPIO6..9).
    pub fn read(&mut self, addr: u32, size: usize) -> u32 {
        self.sync();
        let (base, off) = (addr & !0x3FFF, addr & 0x3FFF);
        if let Some(m) = PWM.iter().position(|&b| b == base) {
            return self.read16(addr, size, |s, o| s.pwm[m].read(o), off);
        }
        if let Some(m) = TMR.iter().position(|&b| b == base) {
            return self.read16(addr, size, |s, o| s.tmr[m].read(o), off);
        }
        if base == XBARA1 {
            let i = (off & !1) as usize;
            let lo = u32::from(*self.xbar.get(i).unwrap_or(&0));
            let hi = u32::from(*self.xbar.get(i + 1).unwrap_or(&0));
            let v16 = lo | (hi << 8);
            return if size == 4 {
                v16 | (u32::from(*self.xbar.get(i + 2).unwrap_or(&0)) << 16)
                    | (u32::from(*self.xbar.get(i + 3).unwrap_or(&0)) << 24)
            } else {
                v16
            };
        }
        let v = self.read32(addr & !3);
        let shift = (addr & 3) * 8;
        match size {
            1 => (v >> shift) & 0xFF,
            2 => (v >> shift) & 0xFFFF,
            _ => v,
        }
    }

    fn read16(&mut self, _addr: u32, size: usize, f: impl Fn(&Self, u32) -> u16, off: u32) -> u32 {
        let lo = u32::from(f(self, off & !1));
        if size == 4 {
            lo | (u32::from(f(self, (off & !1) + 2)) << 16)
        } else {
            lo
        }
    }

    fn read32(&mut self, a: u32) -> u32 {
        let base = a & !0x3FFF;
        let off = a & 0x3FFF;
        if let Some(p) = GPIO.iter().position(|&b| b == base) {
            let g = &self.gpio[p];
            return match off {
                0x0 => g.dr,
                0x4 => g.gdir,
                0x8 => self.gpio_psr(p),
                0x84..=0x8C => 0,
                o => g.other[((o / 4) as usize).min(7)],
            };
        }
        match base {
            PIT => {
                self.pit_update();
                if off == 0 {
                    return self.pit_mcr;
                }
                if (0x100..0x140).contains(&off) {
                    let n = ((off - 0x100) / 0x10) as usize;
                    let clk = self.pit_clock_cycles();
                    let ch = &self.pit[n];
                    return match off & 0xF {
                        0x0 => ch.ldval,
                        0x4 => {
                            if ch.tctrl & 1 == 0 || self.pit_mcr & 2 != 0 {
                                ch.ldval
                            } else {
                                let period = (u64::from(ch.ldval) + 1) * clk;
                                let in_p = (self.now - ch.start) % period;
                                ch.ldval - (in_p / clk) as u32
                            }
                        }
                        0x8 => ch.tctrl,
                        _ => u32::from(ch.tif),
                    };
                }
                return 0;
            }
            RTWDOG => return self.wdog_read(off),
            LPUART6 => return self.uart_read(off),
            SRC if off == 0x8 => return self.srsr,
            _ => {}
        }
        let stored = match self.regs.get(&a) {
            Some(&v) => v,
            None => {
                *self.unmodelled.entry(a).or_default() += 1;
                reset_value(a)
            }
        };
        // status bits that the boot code polls
        if (CCM_ANALOG..CCM_ANALOG + 0x100).contains(&a) && (a & 0xF) == 0 && a < CCM_ANALOG + 0xF0 {
            return stored | (1 << 31); // PLL LOCK
        }
        if (CCM_ANALOG + 0x110..CCM_ANALOG + 0x140).contains(&a) && (a & 0xF) == 0 {
            return stored | (1 << 17); // PMU REG_xPx OK_VDDxPx
        }
        if a == DCDC {
            return stored | (1 << 31); // STS_DC_OK
        }
        if a == CCM + 0x48 {
            return 0; // CDHIPR: no handshake busy
        }
        if a == CCM + 0x08 {
            return stored | (1 << 5); // CSR: COSC_READY
        }
        stored
    }

    /// Peripheral write.
    pub fn write(&mut self, addr: u32, size: usize, value: u32) {
        self.last_write_at = self.now;
        self.write_inner(addr, size, value);
        let next = self.next_event().max(self.now + 1);
        self.stop_at = self.stop_at.min(next);
    }

    fn write_inner(&mut self, addr: u32, size: usize, value: u32) {
        self.sync();
        let (base, off) = (addr & !0x3FFF, addr & 0x3FFF);
        if let Some(m) = PWM.iter().position(|&b| b == base) {
            self.pwm[m].write(off & !1, value as u16);
            if size == 4 {
                self.pwm[m].write((off & !1) + 2, (value >> 16) as u16);
            }
            self.pwm[m].settle_time(self.now);
            return;
        }
        if let Some(m) = TMR.iter().position(|&b| b == base) {
            self.tmr[m].write(off & !1, value as u16);
            if size == 4 {
                self.tmr[m].write((off & !1) + 2, (value >> 16) as u16);
            }
            return;
        }
        if base == XBARA1 {
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
            return;
        }
        let a = addr & !3;
        let shift = (addr & 3) * 8;
        let value = match size {
            1 | 2 => {
                let mask = if size == 1 { 0xFFu32 } else { 0xFFFF } << shift;
                let old = self.regs.get(&a).copied().unwrap_or_else(|| reset_value(a));
                (old & !mask) | ((value << shift) & mask)
            }
            _ => value,
        };
        self.write32(a, value);
    }

    fn write32(&mut self, a: u32, v: u32) {
        let base = a & !0x3FFF;
        let off = a & 0x3FFF;
        if let Some(p) = GPIO.iter().position(|&b| b == base) {
            let g = &mut self.gpio[p];
            match off {
                0x0 => g.dr = v,
                0x4 => g.gdir = v,
                0x8 => {}
                0x84 => g.dr |= v,
                0x88 => g.dr &= !v,
                0x8C => g.dr ^= v,
                o => g.other[((o / 4) as usize).min(7)] = v,
            }
            return;
        }
        match base {
            PIT => {
                self.pit_update();
                if off == 0 {
                    self.pit_mcr = v;
                    for ch in self.pit.iter_mut() {
                        ch.start = self.now;
                        ch.expiries = 0;
                    }
                } else if (0x100..0x140).contains(&off) {
                    let n = ((off - 0x100) / 0x10) as usize;
                    let now = self.now;
                    let ch = &mut self.pit[n];
                    match off & 0xF {
                        0x0 => ch.ldval = v,
                        0x8 => {
                            if v & 1 != 0 && ch.tctrl & 1 == 0 {
                                ch.start = now;
                                ch.expiries = 0;
                            }
                            ch.tctrl = v & 7;
                        }
                        0xC if v & 1 != 0 => ch.tif = false,
                        _ => {}
                    }
                }
                return;
            }
            RTWDOG => return self.wdog_write(off, v),
            LPUART6 => return self.uart_write(off, v),
            SRC if off == 0x8 => {
                self.srsr &= !v;
                return;
            }
            _ => {}
        }
        // SET/CLR/TOG aliases of CCM_ANALOG/PMU and USBPHY registers
        if (CCM_ANALOG..CCM_ANALOG + 0x180).contains(&a) || (USBPHY1..USBPHY1 + 0x100).contains(&a) {
            let reg = a & !0xF;
            let old = self.regs.get(&reg).copied().unwrap_or_else(|| reset_value(reg));
            let new = match a & 0xF {
                0x4 => old | v,
                0x8 => old & !v,
                0xC => old ^ v,
                _ => v,
            };
            let new = if reg == USBPHY1 + 0x30 { new & !(1 << 31) } else { new }; // CTRL SFTRST
            self.regs.insert(reg, new);
            return;
        }
        // USB1 USBCMD: RST (bit 1) self-clears
        let v = if a == USB1 + 0x140 { v & !2 } else { v };
        self.regs.insert(a, v);
    }
}

/// Reset values of registers the boot code reads before writing.
fn reset_value(a: u32) -> u32 {
    match a {
        // CCM_ANALOG PLL_ARM/USB1/SYS: powered down, bypassed at reset
        0x400D_8000 => 0x0001_3063,
        0x400D_8010 | 0x400D_8020 => 0x0001_2000,
        0x400D_8030 => 0x0001_3001,
        // CCM CBCDR, CBCMR, CSCMR1, CSCDR1, CCSR
        0x400F_C014 => 0x000A_8300,
        0x400F_C018 => 0x2DAE_8324,
        0x400F_C01C => 0x0449_0B00,
        0x400F_C024 => 0x0649_0B06,
        0x400F_C00C => 0x0000_0100,
        // CCM CCGR0..6: gates on
        0x400F_C068..=0x400F_C080 => 0xFFFF_FFFF,
        // DCDC REG3
        0x4008_000C => 0x0000_0010,
        _ => 0,
    }
}

struct JointWave<'a> {
    plant: &'a mut Plant,
    axis: usize,
    connected: bool,
}

impl InputWave for JointWave<'_> {
    fn level_and_next(&mut self, _ch: usize, t: u64) -> (bool, u64) {
        if !self.connected {
            return (false, u64::MAX);
        }
        self.plant.joints[self.axis].wave(t)
    }
}
