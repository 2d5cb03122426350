//! The i.MXRT1062 peripheral models behind the MMIO hooks, and their wiring
//! to the plant. Time is `now`, in CPU cycles = executed instructions (the
//! twin counts 1 instruction as 1 cycle at 600 MHz).

use rustc_hash::FxHashMap;

use crate::gpt::Gpt;
use crate::lpspi::{Frame, Lpspi};
use crate::lpuart::Uart;
use crate::lpuart::IRQ_LPUART6;
use crate::pads::{self, wiring, Gpio};
use crate::pit::{Pit, IRQ_PIT};
use crate::plant::Plant;
use crate::pwm::FlexPwm;
use crate::qtimer::{InputWave, QTimer};
use crate::tmc5160::Tmc5160;
use crate::usb::{Usb, IRQ_USB_OTG1};
use crate::wdog::Wdog;

/// CPU cycles per second. The twin keeps its own figures for the chip and
/// the sensors (here, `qtimer.rs`, `plant.rs`) on purpose rather than
/// importing the HAL's: it is an independent model the image is checked
/// against, so a wrong figure in the HAL shows as a disagreement.
pub const CPU_HZ: u64 = 600_000_000;

// Base addresses (imxrt-ral `imxrt1062.rs`).
pub(crate) const CCM: u32 = 0x400F_C000;
const CCM_ANALOG: u32 = 0x400D_8000;
const DCDC: u32 = 0x4008_0000;
const SRC: u32 = 0x400F_8000;
pub(crate) const IOMUXC: u32 = 0x401F_8000;
pub(crate) const IOMUXC_GPR: u32 = 0x400A_C000;
const GPIO: [u32; 4] = [0x401B_8000, 0x401B_C000, 0x401C_0000, 0x401C_4000];
const PIT: u32 = 0x4008_4000;
const GPT: [u32; 2] = [0x401E_C000, 0x401F_0000];
const RTWDOG: u32 = 0x400B_C000;
const LPUART6: u32 = 0x4019_8000;
const LPSPI3: u32 = 0x4039_C000;
const TMR: [u32; 4] = [0x401D_C000, 0x401E_0000, 0x401E_4000, 0x401E_8000];
const PWM: [u32; 4] = [0x403D_C000, 0x403E_0000, 0x403E_4000, 0x403E_8000];
const XBARA1: u32 = 0x403B_C000;
const USB1: u32 = crate::usb::USB1;
const USBPHY1: u32 = 0x400D_9000;

/// XBARA1 outputs feeding FlexPWM1..4 FAULT0..3.
const FAULT_XBAR: [[usize; 4]; 4] = [[35, 36, 37, 38], [49, 50, 37, 38], [56, 57, 37, 38], [63, 64, 37, 38]];

/// What happened that the machine must act on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reset {
    /// RTWDOG timeout, or a refresh inside its closed window.
    Watchdog,
}

/// All peripheral state.
pub struct Board {
    /// Simulated time in CPU cycles.
    pub now: u64,
    /// Generic register file for unmodelled registers (address -> value).
    pub regs: FxHashMap<u32, u32>,
    /// GPIO1..4.
    pub gpio: [Gpio; 4],
    /// PIT.
    pub pit: Pit,
    /// RTWDOG.
    pub wdog: Wdog,
    /// GPT1, GPT2.
    pub gpt: [Gpt; 2],
    /// The core clock's actual frequency (Hz): CPU cycles per second of
    /// emulated real time, [`CPU_HZ`] unless a test detunes the PLL
    /// ([`Board::set_cpu_hz`]). Only the 32.768 kHz reference (GPT on
    /// `ipg_clk_32k`) counts in real time.
    pub cpu_hz: f64,
    /// LPUART6.
    pub uart: Uart,
    /// LPSPI3 (the TMC5160 link).
    pub spi3: Lpspi,
    /// The six TMC5160 drivers on LPSPI3, J1..J6 (separate chips: a reset
    /// of the processor leaves them as they are).
    pub tmc: [Tmc5160; 6],
    /// Each driver's chip-select level as last seen (high = deselected).
    tmc_cs_high: [bool; 6],
    /// USB OTG1 (device mode, endpoint 0) and the host on its bus.
    pub usb: Usb,
    /// TMR1..4.
    pub tmr: [QTimer; 4],
    /// PWM1..4.
    pub pwm: [FlexPwm; 4],
    /// XBARA1 select per output.
    pub xbar: [u8; 132],
    /// The last FlexPWM trigger selected per XBARA1 output (bookkeeping: the
    /// output's pulse log while `LOGIC_LOW` is selected).
    pub xbar_last_trigger: FxHashMap<usize, (usize, usize)>,
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
    pub unmodelled: FxHashMap<u32, u64>,
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
    /// The interrupt `irq_wait_unmask` waits for (IRQ number).
    pub irq_wait: u32,
    /// The core executed WFI and sleeps until an enabled interrupt is
    /// pending (whatever PRIMASK says).
    pub sleeping: bool,
    /// WFI sleeps (the default); `TWIN_WFI_NOP=1` makes it a NOP, as on a
    /// core that does not implement sleep.
    pub wfi_sleeps: bool,
    /// The core executed `BKPT #imm` at this time and halted in debug
    /// state (no debugger: nothing resumes it).
    pub bkpt_halt: Option<(u8, u64)>,
    /// WFI instructions executed (each a sleep).
    pub wfi_count: u64,
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
    pub pit_blocks: FxHashMap<u32, u64>,
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
    /// Changes of the drivers' enable line (pin 3, `DRV_ENN`): (time,
    /// drivers energised), from power-on (off: the pull-up) on.
    pub driver_enable_log: Vec<(u64, bool)>,
    /// The Cortex-M7 MPU's registers (the stack guard).
    pub mpu: crate::mpu::Mpu,
    /// An access the MPU refused, for the harness to take as a fault.
    pub mpu_fault: Option<crate::mpu::MpuFault>,
}

impl Board {
    /// Power-on state.
    pub fn new(plant: Plant) -> Self {
        let mut b = Board {
            now: 0,
            regs: FxHashMap::default(),
            gpio: Default::default(),
            pit: Pit::default(),
            wdog: Wdog::default(),
            gpt: Default::default(),
            cpu_hz: CPU_HZ as f64,
            uart: Uart::default(),
            spi3: Lpspi::default(),
            tmc: Default::default(),
            tmc_cs_high: [true; 6],
            usb: Usb::default(),
            tmr: Default::default(),
            pwm: Default::default(),
            xbar: [0; 132],
            xbar_last_trigger: FxHashMap::default(),
            plant,
            srsr: 1, // IPP_RESET_B: power-on
            vtor: 0,
            nvic_en: [0; 8],
            nvic_ipr: [0; 240],
            cyccnt_off: 0,
            dwt_ctrl: 0x4000_0000,
            demcr: 0,
            reset: None,
            unmodelled: FxHashMap::default(),
            stop_at: 0,
            hints_patched: 0,
            it_deferred: 0,
            irq_wait_unmask: false,
            irq_wait: IRQ_PIT,
            sleeping: false,
            wfi_sleeps: std::env::var_os("TWIN_WFI_NOP").is_none(),
            wfi_count: 0,
            bkpt_halt: None,
            irq_unmask_entries: 0,
            stopped_at: None,
            trace: [0; 16],
            trace_i: 0,
            in_pit: false,
            pit_blocks: FxHashMap::default(),
            main_addr: u32::MAX,
            main_at: Vec::new(),
            faults_forced_inactive: false,
            idle_skip: std::env::var_os("TWIN_NO_IDLE_SKIP").is_none(),
            idle_skip_allowed: false,
            last_write_at: 0,
            idle_stop: false,
            driver_enable_log: Vec::new(),
            mpu: Default::default(),
            mpu_fault: None,
        };
        b.reset_peripherals();
        b
    }

    /// Chip reset (watchdog): every peripheral back to reset, plant and
    /// time kept, SRSR records the cause.
    pub fn reset_peripherals(&mut self) {
        self.regs.clear();
        self.gpio = Default::default();
        self.pit = Pit::default();
        self.wdog = Wdog::after_boot_rom();
        self.gpt = Default::default();
        self.uart.reset(self.now);
        self.spi3.reset();
        self.tmc_cs_update();
        self.usb.reset();
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
        // the MPU is off after a reset; the harness lifts its protection
        self.mpu = crate::mpu::Mpu { dirty: true, ..Default::default() };
        self.mpu_fault = None;
        for t in self.tmr.iter_mut() {
            for c in t.ch.iter_mut() {
                c.t = self.now;
            }
        }
        for p in self.pwm.iter_mut() {
            p.settle_time(self.now);
        }
        self.note_driver_enable();
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
        // The outputs behind the STEP pins, found once: advancing the PWMs
        // changes no pad routing.
        let sources: [Option<(usize, usize, usize)>; 6] = core::array::from_fn(|i| self.step_source(i));
        let pulses =
            |b: &Board| -> [u64; 6] { sources.map(|src| src.map_or(0, |(m, s, l)| b.pwm[m - 1].sm[s].log[l].pulses)) };
        let before = pulses(self);
        for (m, p) in self.pwm.iter_mut().enumerate() {
            p.advance(now, &routes[m]);
        }
        let after = pulses(self);
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
        let byte = self.uart_byte_cycles();
        self.uart.sync(self.now, byte);
    }

    /// After a debug halt of `cycles`: the blocks that stop in debug mode
    /// resume where they stopped (PIT if `MCR[FRZ]`, RTWDOG unless
    /// `CS[DBG]`, CYCCNT always).
    pub fn debug_halt_time_bases(&mut self, cycles: u64) {
        self.pit.debug_halt(cycles);
        if self.wdog.cs & (1 << 2) == 0 {
            self.wdog.since += cycles;
        }
        self.cyccnt_off = self.cyccnt_off.wrapping_sub(cycles as u32);
        for g in self.gpt.iter_mut() {
            g.debug_halt(cycles);
        }
    }

    /// Run the core clock at `hz` from now on (a PLL locked at a wrong
    /// frequency): the 32.768 kHz reference then advances one count per
    /// `hz / 32768` CPU cycles.
    pub fn set_cpu_hz(&mut self, hz: f64) {
        for g in self.gpt.iter_mut() {
            g.rebase(self.now, self.cpu_hz);
        }
        self.cpu_hz = hz;
    }

    /// Record every FlexPWM output's rising-edge times from now on.
    pub fn record_edges(&mut self) {
        self.sync();
        for p in self.pwm.iter_mut() {
            p.record = true;
        }
    }

    // ------------------------------------------------------------ PIT

    /// CPU cycles per PIT clock: `CSCMR1` `PERCLK_CLK_SEL` (bit 6) 1 = OSC
    /// 24 MHz, 0 = IPG 150 MHz; `PERCLK_PODF` bits 5:0.
    fn pit_clock_cycles(&self) -> u64 {
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
        self.pit.update(self.now, clk);
    }

    /// The next PIT expiry (cycles), if a channel runs.
    pub fn next_pit(&self) -> Option<u64> {
        self.pit.next_expiry(self.pit_clock_cycles())
    }

    /// Next time anything needs the CPU's attention (PIT expiry, watchdog).
    pub fn next_event(&self) -> u64 {
        let t = self.next_pit().unwrap_or(u64::MAX).min(self.usb.next_event().unwrap_or(u64::MAX));
        self.wdog.deadline().map_or(t, |w| t.min(w))
    }

    /// When the pending PIT interrupt was raised: the latest expiry of a
    /// channel whose `TIF` and `TIE` are set (the earliest such channel if
    /// several), or `None` if none is pending.
    pub fn pit_raised_at(&self) -> Option<u64> {
        self.pit.raised_at(self.pit_clock_cycles())
    }

    /// The PIT interrupt is pending and enabled in the NVIC.
    pub fn pit_irq(&mut self) -> bool {
        self.pit_update();
        self.pit.requesting() && self.nvic_enabled(IRQ_PIT)
    }

    /// Interrupt `irq` is enabled in the NVIC.
    pub fn nvic_enabled(&self, irq: u32) -> bool {
        self.nvic_en[(irq / 32) as usize] & (1 << (irq % 32)) != 0
    }

    /// The LPUART6 interrupt is requested (a received byte with `RIE`, an
    /// empty transmit FIFO with `TIE`) and enabled in the NVIC.
    pub fn uart_irq(&mut self) -> bool {
        self.sync();
        self.uart.requesting() && self.nvic_enabled(IRQ_LPUART6)
    }

    /// The USB OTG1 interrupt is requested and enabled in the NVIC.
    pub fn usb_irq(&self) -> bool {
        self.usb.requesting() && self.nvic_enabled(IRQ_USB_OTG1)
    }

    /// When the next interrupt can become pending while the core sleeps:
    /// the next PIT expiry, the watchdog's deadline, and LPUART6's next
    /// byte in (with `RIE`) or transmitter step (with `TIE`).
    pub fn next_wake_event(&self) -> u64 {
        let mut t = self.next_event();
        if self.uart.r[6] & (1 << 21) != 0 {
            t = t.min(self.uart.rx_next_event(self.now).unwrap_or(u64::MAX));
        }
        if self.uart.r[6] & (1 << 23) != 0 {
            t = t.min(self.uart.tx_next_event(self.now).unwrap_or(u64::MAX));
        }
        t
    }

    // ------------------------------------------------------------ RTWDOG

    /// Check the watchdog; sets `reset` on timeout.
    pub fn wdog_check(&mut self) {
        if self.wdog.deadline().is_some_and(|d| self.now >= d) {
            self.reset = Some(Reset::Watchdog);
        }
    }

    // ------------------------------------------------------------ LPUART6

    /// LPUART6's cycles per byte at the clock root the image programmed.
    fn uart_byte_cycles(&self) -> u64 {
        self.uart.byte_cycles(self.regs.get(&(CCM + 0x24)).copied().unwrap_or(0))
    }

    /// Bytes the image has transmitted on Serial1 so far.
    pub fn serial_text(&self) -> String {
        self.uart.text()
    }

    /// Queue host bytes onto Serial1's RX line.
    pub fn serial_send(&mut self, bytes: &[u8]) {
        self.uart.send(bytes);
    }

    /// Nothing for the image to read on LPUART6 now (RX FIFO empty; bytes
    /// still on the wire arrive at [`Board::uart_rx_next_event`]).
    pub fn uart_rx_quiet(&self) -> bool {
        self.uart.rx_quiet()
    }

    /// When the next host byte lands in the RX FIFO, if one is on its way.
    pub fn uart_rx_next_event(&self) -> Option<u64> {
        self.uart.rx_next_event(self.now)
    }

    /// When the LPUART6 transmitter next changes state (the shifter takes
    /// the next FIFO byte or finishes), if it is busy.
    pub fn uart_tx_next_event(&self) -> Option<u64> {
        self.uart.tx_next_event(self.now)
    }

    // ------------------------------------------------------------ LPSPI3, TMC5160

    /// LPSPI3's functional clock: `CBCMR[LPSPI_CLK_SEL]` (bits 5:4) = 2
    /// (PLL2, 528 MHz) divided by `LPSPI_PODF` (bits 28:26) + 1, with the
    /// clock gate (`CCGR1` CG2) open; other sources are not modelled (no
    /// frame then completes).
    fn lpspi_clk_hz(&self) -> Option<f64> {
        let cbcmr = self.regs.get(&(CCM + 0x18)).copied().unwrap_or_else(|| reset_value(CCM + 0x18));
        let ccgr1 = self.regs.get(&(CCM + 0x6C)).copied().unwrap_or_else(|| reset_value(CCM + 0x6C));
        if (cbcmr >> 4) & 3 != 2 || (ccgr1 >> 4) & 3 == 0 {
            return None;
        }
        Some(528e6 / f64::from(((cbcmr >> 26) & 7) + 1))
    }

    /// The level of driver `i`'s chip select: the GPIO's if the pad drives
    /// it, else high (the pull-up the wiring specifies).
    fn tmc_cs_level(&self, i: usize) -> bool {
        self.gpio_out(pads::TMC_CS[i]).unwrap_or(true)
    }

    /// Chip-select edges: a rising one makes the driver act on its datagram.
    fn tmc_cs_update(&mut self) {
        for i in 0..6 {
            let high = self.tmc_cs_level(i);
            if high && !self.tmc_cs_high[i] {
                self.tmc[i].deselect();
            }
            self.tmc_cs_high[i] = high;
        }
    }

    /// The pad carries LPSPI3's signal: ALT2 and the signal's select input
    /// (IOMUXC offset `daisy`) set to 1 (the Teensy pad).
    fn lpspi3_pad(&self, pin: u8, daisy: u32) -> bool {
        pads::teensy_pad(pin).is_some_and(|p| self.pad_mux(p).0 == 2) && self.iomux(daisy) & 1 == 1
    }

    /// Shift `frame` through the selected drivers; the bits LPSPI3's SDI
    /// receives. SCK or SDO not routed to their pads: no driver sees the
    /// frame. SDI not routed: zeros. No driver driving SDO (none selected,
    /// none fitted): the pad's pull-up (ones) or zeros without one. Two
    /// drivers selected at once: their outputs wired-AND.
    fn spi_shift(&mut self, frame: Frame) -> u64 {
        let ones = if frame.bits >= 64 { u64::MAX } else { (1u64 << frame.bits) - 1 };
        let to_drivers = self.lpspi3_pad(pads::TMC_SCK, 0x510) && self.lpspi3_pad(pads::TMC_SDO, 0x518);
        let mut out: Option<u64> = None;
        if to_drivers && frame.bits == 40 {
            for i in 0..6 {
                if !self.tmc_cs_level(i) && self.tmc[i].present {
                    let o = self.tmc[i].shift(frame.data, self.now);
                    out = Some(out.map_or(o, |a| a & o));
                }
            }
        }
        if !self.lpspi3_pad(pads::TMC_SDI, 0x514) {
            return 0;
        }
        out.unwrap_or_else(|| {
            let p = pads::teensy_pad(pads::TMC_SDI).map(|p| self.iomux(p.pad_offset())).unwrap_or(0);
            let pull_up = p & (1 << 12) != 0 && p & (1 << 13) != 0 && (p >> 14) & 3 != 0;
            if pull_up {
                ones
            } else {
                0
            }
        })
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
            return self.xbar_read(off, size);
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
            return self.gpio_read(p, off);
        }
        match base {
            PIT => {
                self.pit_update();
                return self.pit.read(off, self.now, self.pit_clock_cycles());
            }
            RTWDOG => return self.wdog.read(off, self.now),
            b if GPT.contains(&b) => return self.gpt[usize::from(b == GPT[1])].read(off, self.now, self.cpu_hz),
            LPUART6 => return self.uart.read(off, self.now),
            LPSPI3 => return self.spi3.read(off, self.now),
            USB1 if off < 0x200 => return self.usb.read(off),
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
        if GPIO.contains(&(addr & !0x3FFF)) || (addr & !0x3FFF) == IOMUXC || (addr & !0x3FFF) == IOMUXC_GPR {
            self.note_driver_enable();
        }
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
            self.xbar_write(off, size, value);
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
            self.gpio[p].write(off, v);
            self.tmc_cs_update();
            return;
        }
        match base {
            PIT => {
                self.pit_update();
                self.pit.write(off, v, self.now);
                return;
            }
            RTWDOG => {
                self.wdog.write(off, v, self.now);
                if std::mem::take(&mut self.wdog.reset_request) {
                    // a refresh inside the window: reset at once (the CPU
                    // stops at the next block)
                    self.reset = Some(Reset::Watchdog);
                    self.stop_at = self.now;
                }
                return;
            }
            b if GPT.contains(&b) => {
                let (now, hz) = (self.now, self.cpu_hz);
                return self.gpt[usize::from(b == GPT[1])].write(off, v, now, hz);
            }
            LPUART6 => {
                let byte = self.uart_byte_cycles();
                return self.uart.write(off, v, self.now, byte);
            }
            LPSPI3 => {
                if let Some(frame) = self.spi3.write(off, v, self.now) {
                    let answer = self.spi_shift(frame);
                    let cycles = self.lpspi_clk_hz().map_or(u64::MAX / 2, |hz| self.spi3.frame_cycles(hz));
                    self.spi3.complete(frame, answer, self.now, cycles);
                }
                return;
            }
            SRC if off == 0x8 => {
                self.srsr &= !v;
                return;
            }
            USB1 if off < 0x200 => {
                self.usb.write(off, v, self.now);
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
        self.regs.insert(a, v);
    }
}

/// Reset values of registers the boot code reads before writing.
pub(crate) fn reset_value(a: u32) -> u32 {
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
