//! The CPU: Unicorn (Cortex-M7, Thumb, M-class) with the memory map of the
//! Teensy 4.1, MMIO hooks into [`Board`], the Cortex-M core peripherals the
//! image touches (SCB, NVIC, DWT), and exception entry/return done by the
//! harness (Unicorn has no NVIC): the PIT and LPUART6 handlers are called
//! as functions with a sentinel return address, the interrupted context
//! saved and restored whole. WFI stops the core until an enabled interrupt
//! is pending; the harness skips the time in between.

use std::collections::HashMap;

use rustc_hash::FxHashMap;

use unicorn_engine::{Arch, ArmCpuModel, Context, HookType, MemType, Mode, Prot, RegisterARM, Unicorn};

use crate::board::{Board, Reset};
use crate::elf::Image;
use crate::lpuart::IRQ_LPUART6;
use crate::mpu::MpuFault;
use crate::pit::IRQ_PIT;
use crate::plant::Plant;
use crate::usb::IRQ_USB_OTG1;

const ITCM: u64 = 0x0000_0000;
const DTCM: u64 = 0x2000_0000;
const OCRAM: u64 = 0x2020_0000;
const FLASH: u64 = 0x6000_0000;
const PERIPH: u64 = 0x4000_0000;
const FAST_GPIO: u64 = 0x4200_0000;
const PPB: u64 = 0xE000_0000;
/// Return address given to handlers; a `b .` lives there.
const SENTINEL: u64 = 0x7000_0000;
/// Thread code that ran this many cycles without an MMIO write, with no
/// received byte waiting in the LPUART6 FIFO, is idle (see
/// [`Twin::run_until`]).
pub const IDLE_CYCLES: u64 = 5_000;

/// Why a run stopped with an error.
#[derive(Debug)]
pub struct Fault {
    /// Message.
    pub what: String,
    /// PC.
    pub pc: u32,
    /// PC as a symbol.
    pub at: String,
}

impl std::fmt::Display for Fault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} at {:#010x} ({})", self.what, self.pc, self.at)
    }
}

/// Counters of what the harness did.
#[derive(Clone, Debug, Default)]
pub struct Stats {
    /// PIT handler invocations.
    pub pit_calls: u64,
    /// Time (cycles) of each PIT handler entry (bounded).
    pub pit_entries: Vec<u64>,
    /// Per entry (bounded like `pit_entries`): cycles from the PIT expiry
    /// that raised the pending interrupt to the handler's entry.
    pub pit_latency: Vec<u64>,
    /// Per entry (bounded): the thread PC the interrupt was taken at (the
    /// return address of its exception frame).
    pub pit_from: Vec<u32>,
    /// Instructions executed by each PIT handler call, entry to return
    /// (bounded): the whole interrupt (sense mapping, kernel tick, step
    /// commands, telemetry push, watchdog).
    pub pit_instructions: Vec<u64>,
    /// Stops where the CPU did not halt at the block that requested the
    /// stop (would mean a miscounted block; expected 0).
    pub stop_mismatch: u64,
    /// Chip resets by the watchdog.
    pub watchdog_resets: u64,
    /// Time (cycles) of each watchdog reset.
    pub watchdog_reset_at: Vec<u64>,
    /// Idle main-loop stretches skipped, and the cycles skipped.
    pub idle_skips: u64,
    /// Cycles skipped as idle.
    pub idle_cycles: u64,
    /// Cycles the core slept.
    pub sleep_cycles: u64,
    /// LPUART6 handler invocations.
    pub uart_calls: u64,
    /// Accesses the MPU refused (each taken as a HardFault).
    pub mpu_faults: Vec<MpuFault>,
    /// USB OTG1 handler invocations.
    pub usb_calls: u64,
}

/// The twin: CPU + board.
pub struct Twin {
    /// Unicorn with the board as its data.
    pub uc: Unicorn<'static, Board>,
    /// The image (symbols).
    pub image: Image,
    boot_sp: u32,
    boot_pc: u32,
    reset_ctx: Context,
    in_handler: Option<Context>,
    /// The interrupt whose handler runs (meaningful with `in_handler`).
    in_irq: u32,
    next_pc: Option<u64>,
    /// The ranges protected in Unicorn for the MPU's no-access regions.
    mpu_protected: Vec<(u64, u64)>,
    /// The HardFault handler runs with `HFNMIENA = 0`: the MPU is off
    /// until the next reset (the image's handler never returns).
    mpu_suspended: bool,
    /// Harness statistics.
    pub stats: Stats,
}

fn count_thumb(code: &[u8]) -> u64 {
    let mut i = 0;
    let mut n = 0;
    while i + 1 < code.len() {
        let hw = u16::from_le_bytes([code[i], code[i + 1]]);
        i += if hw >> 11 >= 0b11101 { 4 } else { 2 };
        n += 1;
    }
    n.max(1)
}

impl Twin {
    /// Load an ELF and set the chip to power-on.
    pub fn new(elf: &[u8], plant: Plant) -> Result<Self, String> {
        let image = Image::parse(elf)?;
        let e = |x: unicorn_engine::uc_error| format!("unicorn: {x:?}");
        let mut uc = Unicorn::new_with_data(Arch::ARM, Mode::THUMB | Mode::MCLASS, Board::new(plant)).map_err(e)?;
        uc.ctl_set_cpu_model(ArmCpuModel::CORTEX_M7 as i32).map_err(e)?;
        uc.mem_map(ITCM, 512 * 1024, Prot::ALL).map_err(e)?;
        uc.mem_map(DTCM, 512 * 1024, Prot::ALL).map_err(e)?;
        uc.mem_map(OCRAM, 1024 * 1024, Prot::ALL).map_err(e)?;
        uc.mem_map(FLASH, 8 * 1024 * 1024, Prot::ALL).map_err(e)?;
        uc.mem_map(FAST_GPIO, 0x1_0000, Prot::READ | Prot::WRITE).map_err(e)?;
        uc.mem_map(SENTINEL, 0x1000, Prot::ALL).map_err(e)?;
        uc.mem_write(SENTINEL, &[0xFE, 0xE7]).map_err(e)?; // b .
                                                           // erased NOR flash reads 0xFF: the bytes between the image's
                                                           // sections, as the Teensy loader leaves them (the image's CRC at
                                                           // boot covers them)
        uc.mem_write(FLASH, &vec![0xFF; 8 * 1024 * 1024]).map_err(e)?;
        for s in &image.segments {
            uc.mem_write(u64::from(s.paddr), &s.data).map_err(e)?;
        }
        uc.mmio_map(
            PERIPH,
            0x40_0000,
            Some(|uc: &mut Unicorn<'_, Board>, off: u64, size: usize| {
                u64::from(uc.get_data_mut().read(PERIPH as u32 + off as u32, size))
            }),
            Some(|uc: &mut Unicorn<'_, Board>, off: u64, size: usize, v: u64| {
                uc.get_data_mut().write(PERIPH as u32 + off as u32, size, v as u32)
            }),
        )
        .map_err(e)?;
        uc.mmio_map(
            PPB,
            0x10_0000,
            Some(|uc: &mut Unicorn<'_, Board>, off: u64, size: usize| {
                u64::from(ppb_read(uc.get_data_mut(), PPB as u32 + off as u32, size))
            }),
            Some(|uc: &mut Unicorn<'_, Board>, off: u64, size: usize, v: u64| {
                ppb_write(uc.get_data_mut(), PPB as u32 + off as u32, size, v as u32)
            }),
        )
        .map_err(e)?;
        // time: one instruction = one cycle, counted per translated block
        // (FxHash: this map is read once per executed block.)
        let mut cache: FxHashMap<u64, u64> = FxHashMap::default();
        uc.add_block_hook(1, 0, move |uc: &mut Unicorn<'_, Board>, addr: u64, size: u32| {
            let n = *cache.entry(addr).or_insert_with(|| {
                let code = uc.mem_read_as_vec(addr, size as usize).unwrap_or_default();
                count_thumb(&code)
            });
            let b = uc.get_data_mut();
            let idle = b.idle_skip
                && b.idle_skip_allowed
                && b.now.saturating_sub(b.last_write_at) > IDLE_CYCLES
                && b.uart_rx_quiet();
            let irq = b.irq_wait;
            let unmasked = b.irq_wait_unmask && !irq_masked(uc, irq);
            let b = uc.get_data_mut();
            if b.now >= b.stop_at || addr == SENTINEL || idle || unmasked {
                // Never stop inside an IT block: restarting writes the PC,
                // which loses ITSTATE (the rest of the block would run
                // unconditionally). Stop at the next block instead.
                let xpsr = uc.reg_read(RegisterARM::XPSR).unwrap_or(0);
                if xpsr & 0x0600_FC00 == 0 {
                    // Unicorn stops before this block's body runs; it is
                    // counted when it runs after the restart.
                    let _ = uc.emu_stop();
                    let b = uc.get_data_mut();
                    b.stopped_at = Some(addr as u32);
                    b.idle_stop = idle && b.now < b.stop_at;
                    return;
                }
                uc.get_data_mut().it_deferred += 1;
            }
            let b = uc.get_data_mut();
            b.now += n;
            if b.in_pit {
                *b.pit_blocks.entry(addr as u32).or_insert(0) += n;
            }
            b.trace[b.trace_i & 15] = addr as u32;
            b.trace_i = b.trace_i.wrapping_add(1);
            if addr as u32 == b.main_addr {
                let now = b.now;
                b.main_at.push(now);
            }
        })
        .map_err(e)?;
        uc.add_intr_hook(|uc: &mut Unicorn<'_, Board>, _intno: u32| {
            // BKPT without a debugger attached: the core halts in debug
            // state (`bkpt #251` is how a Teensy image hands over to its
            // bootloader). Unicorn reports it as an exception; the PC is at
            // the instruction or after it.
            let pc = uc.reg_read(RegisterARM::PC).unwrap_or(0);
            let bkpt = [pc, pc.wrapping_sub(2)].into_iter().find_map(|a| {
                let mut hw = [0u8; 2];
                let h = uc.mem_read(a, &mut hw).is_ok().then(|| u16::from_le_bytes(hw))?;
                (h & 0xFF00 == 0xBE00).then_some(h as u8)
            });
            if let Some(imm) = bkpt {
                let b = uc.get_data_mut();
                let now = b.now;
                b.bkpt_halt = Some((imm, now));
            }
            let _ = uc.emu_stop();
        })
        .map_err(e)?;
        uc.add_insn_invalid_hook(|uc: &mut Unicorn<'_, Board>| {
            // WFI: the core sleeps; the harness resumes it after the WFI
            // once an enabled interrupt is pending (`Twin::run_until`).
            // YIELD, WFE, SEV are architectural hints; NOP is a valid
            // implementation on a single core without low-power modes.
            // Unicorn reports the PC after the hint inside an IT block and
            // at the hint otherwise; patch it to NOP (so it is not trapped
            // again) and continue after it.
            let is_hint = |uc: &Unicorn<'_, Board>, a: u64| {
                let mut hw = [0u8; 2];
                uc.mem_read(a, &mut hw).is_ok() && matches!(u16::from_le_bytes(hw), 0xBF10 | 0xBF20 | 0xBF30 | 0xBF40)
            };
            let pc = uc.reg_read(RegisterARM::PC).unwrap_or(0);
            let (at, resume) = if is_hint(uc, pc) {
                (pc, Some(pc + 2))
            } else if pc >= 2 && is_hint(uc, pc - 2) {
                (pc - 2, None)
            } else {
                return false;
            };
            let mut hw = [0u8; 2];
            let wfi = uc.mem_read(at, &mut hw).is_ok() && u16::from_le_bytes(hw) == 0xBF30;
            if wfi && uc.get_data().wfi_sleeps {
                let _ = uc.reg_write(RegisterARM::PC, at + 2);
                let b = uc.get_data_mut();
                b.sleeping = true;
                b.wfi_count += 1;
                let _ = uc.emu_stop();
                return true;
            }
            let _ = uc.mem_write(at, &[0x00, 0xBF]);
            let _ = uc.ctl_remove_cache(at, at + 2);
            if let Some(r) = resume {
                let _ = uc.reg_write(RegisterARM::PC, r);
            }
            uc.get_data_mut().hints_patched += 1;
            true
        })
        .map_err(e)?;
        // The MPU's no-access regions are protected Unicorn pages: an access
        // there lands here and stops the CPU (nothing runs on).
        uc.add_mem_hook(
            HookType::MEM_PROT,
            1,
            0,
            |uc: &mut Unicorn<'_, Board>, ty: MemType, addr: u64, _size: usize, _v: i64| {
                let sp = uc.reg_read(RegisterARM::SP).unwrap_or(0) as u32;
                let b = uc.get_data_mut();
                let write = matches!(ty, MemType::WRITE_PROT);
                b.mpu_fault = Some(MpuFault { addr: addr as u32, write, at: b.now, sp });
                false
            },
        )
        .map_err(e)?;
        let ivt_entry = read_u32(&uc, 0x6000_1004)?;
        let boot_sp = read_u32(&uc, u64::from(ivt_entry))?;
        let boot_pc = read_u32(&uc, u64::from(ivt_entry) + 4)?;
        let reset_ctx = uc.context_init().map_err(e)?;
        if std::env::var_os("TWIN_DEBUG").is_some() {
            eprintln!("IVT entry {ivt_entry:#x} sp {boot_sp:#x} pc {boot_pc:#x}");
        }
        let main_addr = image.symbols.get("main").copied().unwrap_or(u32::MAX);
        uc.get_data_mut().main_addr = main_addr;
        let mut t = Twin {
            uc,
            image,
            boot_sp,
            boot_pc,
            reset_ctx,
            in_handler: None,
            in_irq: IRQ_PIT,
            next_pc: None,
            mpu_protected: Vec::new(),
            mpu_suspended: false,
            stats: Stats::default(),
        };
        t.cpu_reset()?;
        Ok(t)
    }

    fn cpu_reset(&mut self) -> Result<(), String> {
        let e = |x: unicorn_engine::uc_error| format!("unicorn: {x:?}");
        self.uc.context_restore(&self.reset_ctx).map_err(e)?;
        self.uc.reg_write(RegisterARM::SP, u64::from(self.boot_sp)).map_err(e)?;
        self.next_pc = Some(u64::from(self.boot_pc & !1));
        self.in_handler = None;
        self.board_mut().sleeping = false;
        self.board_mut().bkpt_halt = None;
        Ok(())
    }

    /// The board.
    pub fn board(&self) -> &Board {
        self.uc.get_data()
    }
    /// The board, mutable.
    pub fn board_mut(&mut self) -> &mut Board {
        self.uc.get_data_mut()
    }
    /// Simulated time in cycles.
    pub fn now(&self) -> u64 {
        self.board().now
    }

    fn fault(&self, what: String) -> Fault {
        let pc = self.uc.reg_read(RegisterARM::PC).unwrap_or(0) as u32;
        let b = self.board();
        let trail: Vec<String> =
            (0..16).map(|k| b.trace[(b.trace_i + k) & 15]).map(|a| self.image.symbolize(a)).collect();
        let what = format!("{what}; last blocks: {}", trail.join(" > "));
        Fault { what, pc, at: self.image.symbolize(pc) }
    }

    /// Run until simulated time `t_end` (cycles).
    pub fn run_until(&mut self, t_end: u64) -> Result<(), Fault> {
        while self.now() < t_end {
            if let Some(Reset::Watchdog) = self.board_mut().reset.take() {
                self.stats.watchdog_resets += 1;
                let at = self.now();
                self.stats.watchdog_reset_at.push(at);
                let b = self.board_mut();
                b.reset_peripherals();
                b.srsr = 1 << 7; // WDOG3_RST_B
                self.cpu_reset().map_err(|w| self.fault(w))?;
                self.mpu_suspended = false;
            }
            if self.board().mpu.dirty {
                self.apply_mpu().map_err(|w| self.fault(w))?;
            }
            if self.board().bkpt_halt.is_some() {
                // halted at a breakpoint (no debugger attached: the core
                // stays in debug state): no instruction runs again; the
                // peripherals keep their clocks as in a debug halt, and the
                // USB controller finishes what the host sends
                crate::usb::service(&mut self.uc);
                let next = self.board().usb.next_event().unwrap_or(u64::MAX).min(t_end);
                self.debug_halt(next.saturating_sub(self.now()).max(1));
                continue;
            }
            crate::usb::service(&mut self.uc);
            if self.board().sleeping && self.sleep(t_end) {
                continue;
            }
            let pending = self.board_mut().pit_irq();
            let uart_pending = self.board_mut().uart_irq();
            let usb_pending = self.board().usb_irq();
            if self.in_handler.is_none() && pending && !pit_masked(&self.uc) {
                self.enter_irq(IRQ_PIT)?;
            } else if self.in_handler.is_none() && uart_pending && !irq_masked(&self.uc, IRQ_LPUART6) {
                self.enter_irq(IRQ_LPUART6)?;
            } else if self.in_handler.is_none() && usb_pending && !irq_masked(&self.uc, IRQ_USB_OTG1) {
                self.enter_irq(IRQ_USB_OTG1)?;
            }
            let now = self.now();
            let in_thread = self.in_handler.is_none();
            let b = self.board_mut();
            b.wdog_check();
            if b.reset.is_some() {
                continue;
            }
            let stop = t_end.min(b.next_event());
            // Pending but not taken: in thread code it is masked, and is
            // taken at the first block that runs unmasked (the block hook
            // stops there: the NVIC keeps the interrupt pending, and the
            // core takes it as soon as the mask is lifted); in a handler it
            // waits for the handler's return (same priority: no nesting;
            // the return to the sentinel stops the CPU).
            b.irq_wait_unmask = (pending || uart_pending || usb_pending) && in_thread;
            b.irq_wait = if pending {
                IRQ_PIT
            } else if uart_pending {
                IRQ_LPUART6
            } else {
                IRQ_USB_OTG1
            };
            b.stop_at = stop.max(now + 1);
            // Idle skipping: only thread code (no handler running) after the
            // image enabled the PIT interrupt, i.e. its main loop.
            let pit_enabled = self.board().nvic_en[(IRQ_PIT / 32) as usize] & (1 << (IRQ_PIT % 32)) != 0;
            let allowed = self.in_handler.is_none() && pit_enabled && !pending;
            self.board_mut().idle_skip_allowed = allowed;
            let pc = self.next_pc.take().unwrap_or_else(|| self.uc.reg_read(RegisterARM::PC).unwrap_or(0));
            if std::env::var_os("TWIN_DEBUG").is_some() && now < 100_000 || std::env::var_os("TWIN_DEBUG_ALL").is_some()
            {
                eprintln!("start at {pc:#x} now {now} stop {}", self.board().stop_at);
            }
            let r = self.uc.emu_start(pc | 1, SENTINEL, 0, 0);
            let pc = self.uc.reg_read(RegisterARM::PC).unwrap_or(0);
            let requested = self.board_mut().stopped_at.take();
            if let Some(a) = requested {
                if u64::from(a) != pc && pc != SENTINEL {
                    self.stats.stop_mismatch += 1;
                }
            } else if pc >= 2 && self.board().wfi_sleeps && !self.board().sleeping {
                // Unicorn ends the run itself after a WFI (the core halts),
                // PC after it: the core sleeps from here.
                let mut hw = [0u8; 2];
                if self.uc.mem_read(pc - 2, &mut hw).is_ok() && u16::from_le_bytes(hw) == 0xBF30 {
                    let b = self.board_mut();
                    b.sleeping = true;
                    b.wfi_count += 1;
                }
            }
            if let Err(err) = r {
                match self.board_mut().mpu_fault.take() {
                    Some(f) => {
                        self.mem_manage(f)?;
                        continue;
                    }
                    None => return Err(self.fault(format!("CPU stopped: {err:?}"))),
                }
            }
            if std::mem::take(&mut self.board_mut().idle_stop) {
                // The main loop spins without writing a peripheral: what it
                // polls changes next at the next PIT interrupt (the only
                // interrupt), the next LPUART6 transmitter step or the next
                // received byte, so the
                // spinning is skipped: time jumps there, as if the loop had
                // run (CYCCNT follows `now`).
                let b = self.board_mut();
                let mut target = b.next_pit().unwrap_or(t_end).min(t_end);
                for u in [b.uart_tx_next_event(), b.uart_rx_next_event()].into_iter().flatten() {
                    target = target.min(u);
                }
                if target > b.now {
                    let d = target - b.now;
                    b.now = target;
                    b.last_write_at = target;
                    self.stats.idle_skips += 1;
                    self.stats.idle_cycles += d;
                }
            }
            if pc == SENTINEL {
                let Some(ctx) = self.in_handler.take() else {
                    return Err(self.fault("returned to the sentinel outside a handler".into()));
                };
                self.uc.context_restore(&ctx).map_err(|x| self.fault(format!("{x:?}")))?;
                self.board_mut().in_pit = false;
                if self.in_irq != IRQ_PIT {
                    continue;
                }
                if let Some(&entry) = self.stats.pit_entries.last() {
                    if self.stats.pit_instructions.len() < self.stats.pit_entries.len() {
                        let n = self.now().saturating_sub(entry);
                        self.stats.pit_instructions.push(n);
                    }
                }
            }
        }
        // bring the peripherals and the plant up to the end time (a CPU
        // spinning without MMIO accesses does not sync them)
        self.board_mut().sync();
        Ok(())
    }

    /// The sleeping core (after WFI): wakes it if an enabled interrupt is
    /// pending (PRIMASK does not matter: ARMv7-M WFI wakes on any pending
    /// interrupt that is enabled in the NVIC), else skips time to the next
    /// event that can raise one, at most to `t_end`. Returns whether the
    /// core still sleeps.
    fn sleep(&mut self, t_end: u64) -> bool {
        let b = self.uc.get_data_mut();
        if b.pit_irq() || b.uart_irq() || b.usb_irq() {
            b.sleeping = false;
            return false;
        }
        let target = b.next_wake_event().min(t_end);
        if target > b.now {
            self.stats.sleep_cycles += target - b.now;
            b.now = target;
            b.last_write_at = target;
        }
        b.sync();
        b.wdog_check();
        true
    }

    fn enter_irq(&mut self, irq: u32) -> Result<(), Fault> {
        let e = |x: unicorn_engine::uc_error| format!("{x:?}");
        let vtor = self.board().vtor;
        let handler = read_u32(&self.uc, u64::from(vtor) + 4 * (16 + u64::from(irq))).map_err(|w| self.fault(w))?;
        let from = self.next_pc.unwrap_or_else(|| self.uc.reg_read(RegisterARM::PC).unwrap_or(0)) as u32;
        let mut ctx = self.uc.context_alloc().map_err(|x| self.fault(e(x)))?;
        self.uc.context_save(&mut ctx).map_err(|x| self.fault(e(x)))?;
        let sp = self.uc.reg_read(RegisterARM::SP).unwrap_or(0);
        // the hardware frame with lazily stacked FP context: 104 bytes, 8-aligned
        let nsp = (sp - 104) & !7;
        let ok =
            self.uc.reg_write(RegisterARM::SP, nsp).is_ok() && self.uc.reg_write(RegisterARM::LR, SENTINEL | 1).is_ok();
        self.next_pc = Some(u64::from(handler & !1));
        if !ok {
            return Err(self.fault(format!("cannot enter the handler of IRQ {irq}")));
        }
        self.in_handler = Some(ctx);
        self.in_irq = irq;
        let b = self.board_mut();
        if std::mem::take(&mut b.irq_wait_unmask) {
            b.irq_unmask_entries += 1;
        }
        if irq == IRQ_USB_OTG1 {
            self.stats.usb_calls += 1;
            return Ok(());
        }
        if irq != IRQ_PIT {
            self.stats.uart_calls += 1;
            return Ok(());
        }
        let b = self.board_mut();
        b.in_pit = true;
        let now = b.now;
        let raised = b.pit_raised_at().unwrap_or(now);
        self.stats.pit_calls += 1;
        if self.stats.pit_entries.len() < 1_000_000 {
            self.stats.pit_entries.push(now);
            self.stats.pit_latency.push(now.saturating_sub(raised));
            self.stats.pit_from.push(from);
        }
        Ok(())
    }

    /// The PIT handler's instructions by function (the function each
    /// translated block starts in), largest first: the per-component
    /// profile of the tick interrupt.
    pub fn pit_profile(&self) -> Vec<(String, u64)> {
        let mut by: HashMap<String, u64> = HashMap::new();
        for (&a, &n) in &self.board().pit_blocks {
            let s = self.image.symbolize(a & !1);
            let f = demangle(s.rsplit_once('+').map_or(s.as_str(), |(f, _)| f));
            *by.entry(f).or_insert(0) += n;
        }
        let mut v: Vec<(String, u64)> = by.into_iter().collect();
        v.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
        v
    }

    /// Applies the MPU's registers: the no-access regions of RAM become
    /// protected pages (none while the MPU is off or suspended for the
    /// HardFault handler). A region that is not whole Unicorn pages of
    /// RAM cannot be modelled and stops the run.
    fn apply_mpu(&mut self) -> Result<(), String> {
        self.board_mut().mpu.dirty = false;
        let want = if self.mpu_suspended { Vec::new() } else { self.board().mpu.no_access() };
        if want == self.mpu_protected {
            return Ok(());
        }
        let e = |x: unicorn_engine::uc_error| format!("MPU region: unicorn: {x:?}");
        for &(s, end) in &self.mpu_protected {
            self.uc.mem_protect(s, end - s, Prot::ALL).map_err(e)?;
        }
        self.mpu_protected.clear();
        for &(s, end) in &want {
            let in_ram = [(ITCM, 512 * 1024), (DTCM, 512 * 1024), (OCRAM, 1024 * 1024)]
                .iter()
                .any(|&(base, len)| s >= base && end <= base + len);
            if !in_ram {
                return Err(format!("MPU no-access region {s:#x}..{end:#x} outside the RAM the twin models"));
            }
            self.uc.mem_protect(s, end - s, Prot::NONE).map_err(e)?;
            self.mpu_protected.push((s, end));
        }
        Ok(())
    }

    /// An access the MPU refused: MemManage, which the image leaves
    /// disabled, so it escalates to HardFault at once (ARMv7-M B1.5.8);
    /// the faulting access does not happen. With `HFNMIENA = 0` the MPU is
    /// off while the HardFault handler runs, so its stacking and its own
    /// calls may use the guard. A fault inside a handler (the tick) leaves
    /// that handler for good: the image's HardFault handler never returns.
    fn mem_manage(&mut self, f: MpuFault) -> Result<(), Fault> {
        self.stats.mpu_faults.push(f);
        if !self.board().mpu.on_in_hardfault() {
            self.mpu_suspended = true;
            self.apply_mpu().map_err(|w| self.fault(w))?;
        }
        self.in_handler = None;
        self.board_mut().in_pit = false;
        self.take_exception(3)?;
        Ok(())
    }

    /// Take exception `vector` (vector-table index: 3 = HardFault, 16 + n
    /// = IRQ n) now, as the core would on a fault: the context is saved
    /// (the PIT is then not delivered, as a HardFault's priority -1 blocks
    /// it), `LR` = `EXC_RETURN` 0xFFFF_FFF9 (thread mode, main stack, so
    /// cortex-m-rt's HardFault trampoline passes the MSP frame), `PC` = the
    /// image's own vector. The handlers under test never return.
    pub fn take_exception(&mut self, vector: u32) -> Result<u32, Fault> {
        let vtor = self.board().vtor;
        let handler = read_u32(&self.uc, u64::from(vtor) + 4 * u64::from(vector)).map_err(|w| self.fault(w))?;
        self.enter_at(handler, 0xFFFF_FFF9, &[])?;
        Ok(handler)
    }

    /// Call the image's function `name` as if from the current context
    /// (`r0..` = `args`; return to the sentinel, context restored then), e.g.
    /// the panic handler `rust_begin_unwind`.
    pub fn call_symbol(&mut self, name: &str, args: &[u32]) -> Result<u32, Fault> {
        let Some(a) = self.symbol(name) else {
            return Err(self.fault(format!("no symbol {name}")));
        };
        self.enter_at(a, (SENTINEL | 1) as u32, args)?;
        Ok(a)
    }

    /// Call the code at `addr` (Thumb; e.g. a test's own code written to
    /// unused RAM) like [`Twin::call_symbol`]: from the current context,
    /// which is restored when it returns.
    pub fn call_at(&mut self, addr: u32, args: &[u32]) -> Result<(), Fault> {
        self.enter_at(addr, (SENTINEL | 1) as u32, args)
    }

    fn enter_at(&mut self, target: u32, lr: u32, args: &[u32]) -> Result<(), Fault> {
        let e = |x: unicorn_engine::uc_error| format!("{x:?}");
        if self.in_handler.is_some() {
            return Err(self.fault("already in a handler".into()));
        }
        let mut ctx = self.uc.context_alloc().map_err(|x| self.fault(e(x)))?;
        self.uc.context_save(&mut ctx).map_err(|x| self.fault(e(x)))?;
        let sp = self.uc.reg_read(RegisterARM::SP).unwrap_or(0);
        let nsp = (sp - 104) & !7;
        let regs = [RegisterARM::R0, RegisterARM::R1, RegisterARM::R2, RegisterARM::R3];
        let mut ok = self.uc.reg_write(RegisterARM::SP, nsp).is_ok()
            && self.uc.reg_write(RegisterARM::LR, u64::from(lr)).is_ok();
        for (r, &v) in regs.iter().zip(args) {
            ok &= self.uc.reg_write(*r, u64::from(v)).is_ok();
        }
        if !ok {
            return Err(self.fault("cannot enter the handler".into()));
        }
        self.next_pc = Some(u64::from(target & !1));
        self.in_handler = Some(ctx);
        // An exception taken ends a WFI: the core runs the handler now.
        self.board_mut().sleeping = false;
        Ok(())
    }

    /// A debugger halts the core for `cycles`: no instruction runs;
    /// peripherals keep their clocks except where their debug-mode bits
    /// say otherwise: FlexPWM submodules with `CTRL2[DBGEN] = 0` stop, the
    /// PIT stops if `MCR[FRZ]`, the RTWDOG stops unless `CS[DBG]`, DWT
    /// CYCCNT stops (the core's clock is held).
    pub fn debug_halt(&mut self, cycles: u64) {
        let b = self.board_mut();
        b.sync();
        for p in b.pwm.iter_mut() {
            p.debug_halted = true;
        }
        b.now += cycles;
        b.sync();
        for p in b.pwm.iter_mut() {
            p.debug_halted = false;
        }
        b.debug_halt_time_bases(cycles);
    }

    /// Address of a symbol.
    pub fn symbol(&self, name: &str) -> Option<u32> {
        self.image.symbols.get(name).copied()
    }
}

fn read_u32(uc: &Unicorn<'_, Board>, a: u64) -> Result<u32, String> {
    let mut b = [0u8; 4];
    uc.mem_read(a, &mut b).map_err(|e| format!("read {a:#x}: {e:?}"))?;
    Ok(u32::from_le_bytes(b))
}

/// The PIT interrupt cannot preempt the running code: PRIMASK or FAULTMASK
/// set, or BASEPRI non-zero and not above the PIT's group priority
/// (ARMv7-M B1.5.4: an exception preempts only with a group priority
/// numerically lower than the execution priority, which PRIMASK boosts to
/// 0, FAULTMASK to -1 and a non-zero BASEPRI to its value).
pub fn pit_masked(uc: &Unicorn<'_, Board>) -> bool {
    irq_masked(uc, IRQ_PIT)
}

/// Interrupt `irq` cannot preempt the running code (as [`pit_masked`]).
pub fn irq_masked(uc: &Unicorn<'_, Board>, irq: u32) -> bool {
    let reg = |r| uc.reg_read(r).unwrap_or(0) as u32;
    if reg(RegisterARM::PRIMASK) & 1 != 0 || reg(RegisterARM::FAULTMASK) & 1 != 0 {
        return true;
    }
    let basepri = reg(RegisterARM::BASEPRI) & 0xF0;
    if basepri == 0 {
        return false;
    }
    let b = uc.get_data();
    // AIRCR.PRIGROUP: priority bits [PRIGROUP:0] are the subpriority
    let prigroup = (b.regs.get(&0xE000_ED0C).copied().unwrap_or(0) >> 8) & 7;
    let group = 0xFFu32 << (prigroup + 1);
    let prio = u32::from(b.nvic_ipr[irq as usize]);
    prio & group >= basepri & group
}

fn cyccnt_enabled(b: &Board) -> bool {
    b.demcr & (1 << 24) != 0 && b.dwt_ctrl & 1 != 0
}

fn ppb_read(b: &mut Board, a: u32, size: usize) -> u32 {
    let v = match a & !3 {
        0xE000_1000 => b.dwt_ctrl,
        0xE000_1004 => {
            if cyccnt_enabled(b) {
                (b.now as u32).wrapping_add(b.cyccnt_off)
            } else {
                b.cyccnt_off
            }
        }
        0xE000_ED00 => 0x411F_C271, // CPUID: Cortex-M7 r1p1
        0xE000_ED08 => b.vtor,
        0xE000_EDFC => b.demcr,
        x @ 0xE000_ED90..=0xE000_EDB8 => b.mpu.read(x).unwrap_or(0),
        x @ 0xE000_E100..=0xE000_E11C => b.nvic_en[((x - 0xE000_E100) / 4) as usize],
        x @ 0xE000_E180..=0xE000_E19C => b.nvic_en[((x - 0xE000_E180) / 4) as usize],
        x @ 0xE000_E400..=0xE000_E4EC => {
            let i = (x - 0xE000_E400) as usize;
            u32::from_le_bytes([b.nvic_ipr[i], b.nvic_ipr[i + 1], b.nvic_ipr[i + 2], b.nvic_ipr[i + 3]])
        }
        x => b.regs.get(&x).copied().unwrap_or(0),
    };
    let shift = (a & 3) * 8;
    match size {
        1 => (v >> shift) & 0xFF,
        2 => (v >> shift) & 0xFFFF,
        _ => v,
    }
}

fn ppb_write(b: &mut Board, a: u32, size: usize, v: u32) {
    b.last_write_at = b.now;
    match a & !3 {
        0xE000_E400..=0xE000_E4EC => {
            // NVIC IPR: byte-accessible (the value comes unshifted, at its
            // own address); 4 priority bits implemented
            let i = (a - 0xE000_E400) as usize;
            for (k, byte) in v.to_le_bytes().iter().take(size).enumerate() {
                if let Some(p) = b.nvic_ipr.get_mut(i + k) {
                    *p = byte & 0xF0;
                }
            }
        }
        0xE000_1000 => {
            // entering/leaving the enabled state keeps the count continuous
            let before = ppb_read(b, 0xE000_1004, 4);
            b.dwt_ctrl = (b.dwt_ctrl & 0xF000_0000) | (v & 0x0FFF_FFFF);
            set_cyccnt(b, before);
        }
        0xE000_1004 => set_cyccnt(b, v),
        0xE000_ED08 => b.vtor = v & !0x7F,
        0xE000_EDFC => {
            let before = ppb_read(b, 0xE000_1004, 4);
            b.demcr = v;
            set_cyccnt(b, before);
        }
        x @ 0xE000_E100..=0xE000_E11C => {
            b.nvic_en[((x - 0xE000_E100) / 4) as usize] |= v;
            // Enabling an interrupt that is already pending: the core takes
            // it at once (after this instruction), so the run stops at the
            // next block for the harness to deliver it.
            if v != 0 {
                b.stop_at = b.now + 1;
            }
        }
        x @ 0xE000_E180..=0xE000_E19C => b.nvic_en[((x - 0xE000_E180) / 4) as usize] &= !v,
        x @ 0xE000_ED90..=0xE000_EDB8 => {
            // the MPU: applied by the harness before the next block runs
            if b.mpu.write(x, v) {
                b.stop_at = b.now + 1;
            }
        }
        x => {
            b.regs.insert(x, v);
        }
    }
    let next = b.next_event();
    b.stop_at = b.stop_at.min(next.max(b.now + 1));
}

fn set_cyccnt(b: &mut Board, value: u32) {
    if cyccnt_enabled(b) {
        b.cyccnt_off = value.wrapping_sub(b.now as u32);
    } else {
        b.cyccnt_off = value;
    }
}

/// A Rust legacy-mangled symbol (`_ZN6kernel4tick17h0123456789abcdefE`) as a
/// path without its hash (`kernel::tick`); other names unchanged. (Written
/// here: the twin needs only this, not the `rustc-demangle` crate's v0
/// support.)
pub fn demangle(sym: &str) -> String {
    let Some(mut rest) = sym.strip_prefix("_ZN") else {
        return sym.to_string();
    };
    let mut parts: Vec<String> = Vec::new();
    while let Some(len_end) = rest.find(|c: char| !c.is_ascii_digit()) {
        let Ok(len) = rest[..len_end].parse::<usize>() else { break };
        let Some(part) = rest.get(len_end..len_end + len) else { break };
        parts.push(part.to_string());
        rest = &rest[len_end + len..];
    }
    if parts.last().is_some_and(|p| p.len() == 17 && p.starts_with('h')) {
        parts.pop();
    }
    let path = parts.join("::");
    path.replace("$LT$", "<")
        .replace("$GT$", ">")
        .replace("$u20$", " ")
        .replace("$C$", ",")
        .replace("$RF$", "&")
        .replace("$u7b$", "{")
        .replace("$u7d$", "}")
        .replace("..", "::")
}
