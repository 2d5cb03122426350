//! The Teensy 4.1 image: the board binding of the shared composition root
//! ([`firmware::root`]), boot, the PIT interrupt, the main loop, the panic
//! handler. Compiled only for `target_os = "none"`.
//!
//! No logic lives here: [`Teensy`] implements [`TickBoard`] over
//! `hal_imxrt::periph`, `port` implements [`Port`] over USB CDC and
//! LPUART6, and everything else (decode, debounce, sensing, kernel, the
//! enable authority, actuation mapping, telemetry, line formatting, the
//! transmit policy) is `firmware::root`, the same code the simulator runs.
//!
//! `unsafe` appears only here, each with a `// SAFETY:` comment: taking the
//! peripheral instances once, the tick context shared between `main` (init,
//! before the interrupt is unmasked) and the PIT handler (afterwards), the
//! queue link, the panic marker, the panic handler's stolen registers and
//! the MPU's stack-guard registers (and, in `ram_test`, the boot RAM test's word accesses to the statics,
//! the vector table and the free stack before anything uses them).

mod logger;
mod port;
mod ram_test;

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;
use core::sync::atomic::{AtomicU32, Ordering};

use teensy4_bsp as bsp;

use bsp::board;
use bsp::interrupt;
use bsp::ral;
use cortex_m::peripheral::NVIC;

use hal_imxrt::periph::clock_check::ClockCheck;
use hal_imxrt::periph::cycles::CycleCounter;
use hal_imxrt::periph::frame_capture::FrameCapture;
use hal_imxrt::periph::gpio::{Gpios, Limits};
use hal_imxrt::periph::step::StepOutputs;
use hal_imxrt::periph::tick::Tick;
use hal_imxrt::periph::uart::Serial1;
use hal_imxrt::periph::watchdog::Watchdog;
use hal_imxrt::periph::{clocks, iomux, panic_stop};
use hal_imxrt::pure::clock::{
    pit_load_value, rtwdog_toval, rtwdog_win, CYCLES_PER_MS, OSC_HZ, RTWDOG_LPO_HZ, TICK_HZ, WATCHDOG_TIMEOUT_US,
    WATCHDOG_WINDOW_US,
};
use hal_imxrt::pure::frame::Snapshot;
use hal_imxrt::pure::pins::PinMap;
use hal_imxrt::pure::reset_cause::{self, ResetCause};
use hal_imxrt::pure::step::StepCommand;
use hal_imxrt::pure::uart::{lpuart_divisor, BaudDivisor};

use firmware::board::{Port, TickBoard};
use firmware::image::{covered_len, ImageFault, Stamp};
use firmware::root::{self, BootReport, Bootloader, Controller, Host, HostConfig, RootLink};
use kernel::config::{AXES, PAROL6, PAROL6_VALIDATED};
use protocol::report::config_fingerprint;

use port::Wake;

#[cfg(feature = "tmc5160-spi")]
use hal_imxrt::periph::lpspi::TmcLink;
#[cfg(feature = "tmc5160-spi")]
use hal_imxrt::pure::pins::TMC_WIRING;
#[cfg(feature = "tmc5160-spi")]
use hal_imxrt::pure::tmc5160::{self, Datagram, Monitor, Reply};

/// The pin map (checked at compile time by `PinMap::validated`): the
/// original wiring (J6 STEP on pin 7 through XBARA1), or J6 on pin 36 with
/// the `j6-pin36` feature.
#[cfg(not(feature = "j6-pin36"))]
const MAP: PinMap = hal_imxrt::pure::pins::DEFAULT_PIN_MAP;
#[cfg(feature = "j6-pin36")]
const MAP: PinMap = hal_imxrt::pure::pins::J6_PIN36_PIN_MAP;
/// The drivers' enable output (pin 3, active low to `DRV_ENN`), checked
/// against both pin maps at compile time.
#[cfg(feature = "driver-enable")]
const DRIVER_ENABLE: hal_imxrt::pure::pins::EnablePin = hal_imxrt::pure::pins::DRIVER_ENABLE;
/// PIT reload for 1 kHz from the 24 MHz PERCLK that `clocks::configure` sets.
const PIT_LDVAL: u32 = match pit_load_value(OSC_HZ, TICK_HZ) {
    Ok(v) => v,
    Err(_) => panic!("PIT load"),
};
/// RTWDOG timeout (20 ms of the 32 kHz LPO).
const WDOG_TOVAL: u16 = match rtwdog_toval(WATCHDOG_TIMEOUT_US, RTWDOG_LPO_HZ, false) {
    Some(v) => v,
    None => panic!("watchdog timeout"),
};
/// RTWDOG window (0.5 ms of the 32 kHz LPO): an earlier refresh resets.
const WDOG_WIN: u16 = match rtwdog_win(WATCHDOG_WINDOW_US, RTWDOG_LPO_HZ, false) {
    Some(v) => v,
    None => panic!("watchdog window"),
};
/// Serial1 at 115200 from the 24 MHz UART clock.
const BAUD: BaudDivisor = match lpuart_divisor(OSC_HZ, 115_200) {
    Ok(v) => v,
    Err(_) => panic!("baud"),
};
/// The main loop's settings: both clients on USB, the Serial1 budget on
/// Serial1 (see `HostConfig::SERIAL1`).
#[cfg(not(feature = "serial1"))]
const HOST_CFG: HostConfig = HostConfig::USB;
#[cfg(feature = "serial1")]
const HOST_CFG: HostConfig = HostConfig::SERIAL1;
/// Teensy LED: pin 13 = GPIO_B0_03 = GPIO2 bit 3.
const LED_BIT: u32 = 1 << 3;

/// The board as the tick sees it: the peripheral drivers behind
/// [`TickBoard`].
struct Teensy {
    tick: Tick,
    cycles: CycleCounter,
    capture: FrameCapture,
    gpios: Gpios,
    limits: Limits,
    steps: StepOutputs,
    wdog: Watchdog,
    clock: ClockCheck,
    /// The drivers' enable output (`DRIVER_ENABLE`), configured inactive.
    #[cfg(feature = "driver-enable")]
    enable: hal_imxrt::pure::pins::GpioBit,
    /// The TMC5160 link and its run-time monitor.
    #[cfg(feature = "tmc5160-spi")]
    tmc: TmcLink,
    #[cfg(feature = "tmc5160-spi")]
    drivers: Monitor,
}

impl TickBoard for Teensy {
    #[inline(always)]
    fn capture(&mut self) -> [Snapshot; AXES] {
        self.capture.sample(&self.cycles)
    }
    #[inline(always)]
    fn limit_levels(&mut self) -> u8 {
        self.limits.levels(&self.gpios)
    }
    #[inline(always)]
    fn apply(&mut self, cmds: &[StepCommand; AXES]) {
        self.steps.apply(&self.gpios, &self.cycles, cmds);
    }
    #[inline(always)]
    fn feed_watchdog(&mut self) {
        self.wdog.feed();
    }
    #[inline(always)]
    fn cycles(&self) -> u32 {
        self.cycles.now()
    }
    #[inline(always)]
    fn end_of_tick(&mut self) -> bool {
        self.tick.end_of_handler()
    }
    #[inline(always)]
    fn clock_fault(&mut self) -> bool {
        self.clock.poll(self.cycles.now())
    }
    #[cfg(feature = "driver-enable")]
    #[inline(always)]
    fn drivers_enable(&mut self, on: bool) {
        let high = firmware::driver_enable::enable_level_high(on, DRIVER_ENABLE.active_high);
        self.gpios.write(self.enable, high);
    }
    /// Collect the `DRV_STATUS` read started in the previous tick, then
    /// start the next one (one driver per tick, `tmc5160::Monitor`).
    #[cfg(feature = "tmc5160-spi")]
    #[inline(always)]
    fn driver_fault(&mut self) -> Option<(u8, kernel::DriverCause)> {
        let reply = self.tmc.finish(&self.gpios);
        self.drivers.on_reply(reply);
        self.tmc.start(&self.gpios, self.drivers.driver(), Datagram::read(tmc5160::REG_DRV_STATUS));
        self.drivers.fault().map(|(axis, f)| (axis, firmware::driver_cause(f)))
    }
    fn boot_wait_ms(&mut self) {
        let t = self.cycles.now();
        self.cycles.wait_since(t, CYCLES_PER_MS);
        self.wdog.feed();
    }
    fn can_poll_capture(&self) -> bool {
        // `capture` reads the QuadTimer registers and CYCCNT at the moment
        true
    }
}

/// Everything the tick touches. Lives in DTCM (`.bss`, teensy4-bsp's
/// imxrt-rt layout); the code that runs on it is in ITCM (`.text`).
struct TickCtx {
    controller: Controller<'static>,
    board: Teensy,
}

/// Initialised by `main` before the PIT interrupt is unmasked; afterwards
/// used only by the PIT handler.
static mut TICK_CTX: MaybeUninit<TickCtx> = MaybeUninit::uninit();
/// The main loop's half of the root; written once by `init_root`.
static mut HOST: MaybeUninit<Host<'static>> = MaybeUninit::uninit();
/// The command/telemetry link; split once in `init_root`.
static mut LINK: RootLink = RootLink::new();
/// Survives a reset (imxrt-rt `.uninit`, not zeroed at start-up): set by the
/// panic handler, read and cleared at boot.
// SAFETY: `.uninit.parol6_panic` is placed by imxrt-rt's linker script in the
// `.uninit` output section (OCRAM, not zero-initialised, not overlapping any
// other object); the static is `MaybeUninit`, so an arbitrary bit pattern at
// power-on is a valid value, and it is only read as a plain `u32` marker.
#[unsafe(link_section = ".uninit.parol6_panic")]
static mut PANIC_MARK: MaybeUninit<u32> = MaybeUninit::uninit();

/// PIT interrupts taken so far (wrapping): the main loop sleeps only if no
/// tick ran since its pass began (a tick may have queued lines).
static TICKS: AtomicU32 = AtomicU32::new(0);

#[bsp::rt::interrupt]
fn PIT() {
    // Single writer (this handler): a plain load and store.
    TICKS.store(TICKS.load(Ordering::Relaxed).wrapping_add(1), Ordering::Relaxed);
    // SAFETY: `TICK_CTX` is written by `main` before the PIT interrupt is
    // unmasked and never touched by `main` again; this handler is the only
    // user afterwards and cannot re-enter itself (same priority).
    let ctx = unsafe { (*addr_of_mut!(TICK_CTX)).assume_init_mut() };
    let _ = ctx.board.tick.on_interrupt();
    let _ = ctx.controller.tick(&mut ctx.board);
}

/// Serial1's interrupt only wakes the main loop from WFI: masked again here
/// (level-triggered, it would re-enter at once); the main loop polls the
/// port and unmasks it before its next WFI.
#[bsp::rt::interrupt]
fn LPUART6() {
    NVIC::mask(interrupt::LPUART6);
}

/// USB's interrupt, likewise only a wake-up (the stack is polled).
#[bsp::rt::interrupt]
fn USB_OTG1() {
    NVIC::mask(interrupt::USB_OTG1);
}

/// Sleeps until an interrupt if nothing happened since the pass that
/// started at tick count `seen`. The race between that check and WFI is
/// closed by masking interrupts (PRIMASK) around both: an interrupt that
/// becomes pending after the check still ends the WFI (ARMv7-M: WFI wakes
/// on a pending interrupt whatever PRIMASK says), and is taken once the
/// mask is lifted. Serial1 and USB are unmasked in the NVIC here, just
/// before the WFI; their handlers mask them again.
fn sleep_unless_ticked(seen: u32) {
    cortex_m::interrupt::disable();
    if TICKS.load(Ordering::Relaxed) == seen {
        // SAFETY: the LPUART6 and USB_OTG1 handlers above only mask their
        // own line; unmasking them cannot break a critical section (PRIMASK
        // is set until the WFI ends, and no code relies on them masked).
        unsafe {
            NVIC::unmask(interrupt::LPUART6);
            NVIC::unmask(interrupt::USB_OTG1);
        }
        cortex_m::asm::wfi();
    }
    // SAFETY: interrupts were enabled before `disable` above (the main loop
    // runs with them enabled); this restores that state.
    unsafe { cortex_m::interrupt::enable() };
}

fn led_on(io: &ral::iomuxc::RegisterBlock, gpio2: &ral::gpio::RegisterBlock) {
    ral::write_reg!(ral::gpio, gpio2, DR_SET, LED_BIT);
    ral::modify_reg!(ral::gpio, gpio2, GDIR, |v| v | LED_BIT);
    ral::write_reg!(ral::iomuxc, io, SW_MUX_CTL_PAD_GPIO_B0_03, 5);
}

#[bsp::rt::entry]
fn main() -> ! {
    // --- the boot RAM test (`ram_test`: March C- over every static, the
    // vector table and the free stack) before anything uses them; its
    // verdict is acted on once the watchdog runs and Serial1 exists. It runs
    // here, in a frame of a few bytes, so that the stack it tests reaches up
    // to just below it: `start`'s frame (a few KiB) is allocated after.
    let ram = ram_test::run();
    start(ram)
}

/// Boot and the main loop; `main` calls it once, after the RAM test.
#[inline(never)]
fn start(ram: Result<(), hal_imxrt::pure::march::MarchFailure>) -> ! {
    // --- clocks: teensy4-bsp's policy (ARM 600 MHz, IPG 150 MHz, PLL3 for
    // USB), then the thin HAL's roots (PERCLK, UART_CLK = 24 MHz) and gates.
    let mut inst = board::instances();
    board::prepare_clocks_and_power(&mut inst.CCM, &mut inst.CCM_ANALOG, &mut inst.DCDC);
    clocks::configure(&inst.CCM);

    // --- reset cause and panic marker, before anything can panic again.
    let srsr = ral::read_reg!(ral::src, inst.SRC, SRSR);
    ral::write_reg!(ral::src, inst.SRC, SRSR, srsr); // w1c
    let reset = reset_cause::decode(srsr);
    // SAFETY: single-threaded boot, interrupts not yet enabled; the word is
    // plain memory (uninitialised after power-on: any value is fine, only
    // the exact marker means "previous panic").
    let marker = unsafe {
        let p = addr_of_mut!(PANIC_MARK).cast::<u32>();
        let m = core::ptr::read_volatile(p);
        core::ptr::write_volatile(p, 0);
        m
    };

    // --- watchdog first: from here on a hang, a refresh inside the window
    // or a broken tick sequence resets the chip; the configuration is locked.
    let wdog = Watchdog::start(inst.RTWDOG, WDOG_TOVAL, WDOG_WIN);

    let Some(mut cp) = cortex_m::Peripherals::take() else { halt() };
    // --- the stack guard: from here on a stack that grows into the guard
    // below it faults at once into the STEP-low fatal stop.
    stack_guard(&mut cp.MPU);
    let cycles = CycleCounter::enable(&mut cp.DCB, &mut cp.DWT);

    // --- pins and drivers (STEP outputs masked low, DIR low)
    if iomux::configure_pins(&inst.IOMUXC, &inst.IOMUXC_GPR, &MAP).is_err() {
        halt()
    }
    #[cfg(feature = "tmc5160-spi")]
    iomux::configure_tmc_pins(&inst.IOMUXC, &inst.IOMUXC_GPR, &TMC_WIRING);
    let gpios = Gpios::new(inst.GPIO1, inst.GPIO2, inst.GPIO3, inst.GPIO4);
    // --- the drivers' enable output: from the pad's reset state (input,
    // the external pull-up holds DRV_ENN high) to an output driven
    // inactive; the tick enables it only in a state that may move.
    #[cfg(feature = "driver-enable")]
    let Ok(enable) = iomux::configure_enable_pin(&inst.IOMUXC, &inst.IOMUXC_GPR, &gpios, DRIVER_ENABLE) else {
        halt()
    };
    let Ok(steps) = StepOutputs::new(inst.PWM1, inst.PWM2, inst.PWM3, inst.PWM4, inst.XBARA1, &gpios, &MAP) else {
        halt()
    };
    let Ok(limits) = Limits::new(&gpios, &MAP) else { halt() };
    let Ok(capture) = FrameCapture::new(inst.TMR1, inst.TMR3, &MAP) else { halt() };
    let mut serial1 = Serial1::new(inst.LPUART6, BAUD);
    if ram.is_err() {
        ram_test::refuse(&mut serial1, &inst.IOMUXC);
    }
    // --- the clock check's reference (32.768 kHz crystal): its first window
    // spans the boot self-test, so the first tick has the boot verdict.
    let clock = ClockCheck::start(inst.GPT2, &inst.CCM, cycles_now);
    if marker == firmware::PANIC_MARKER {
        // keep signalling the previous panic until the fault is handled
        led_on(&inst.IOMUXC, &unsafe_gpio2());
    }

    // --- the image's CRC (firmware::image), before the tick exists: a
    // corrupt or half-written image never starts it.
    if image_check().is_err() {
        #[cfg(not(feature = "serial1"))]
        let proto = port::Usb::new(inst.USB1, inst.USBPHY1, inst.USBNC1);
        #[cfg(feature = "serial1")]
        let proto = port::Uart::new(serial1);
        refuse_to_run(proto, &wdog, &cycles)
    }

    // --- the root, built in its statics by a separate function so that its
    // temporaries leave the stack before the main loop runs (built inline,
    // `main`'s frame reserved 15-16 KiB of the 16 KiB stack and the first
    // event line overflowed it: found by the register-level twin).
    // --- the TMC5160 drivers identified and checked (sanity check at boot);
    // a failing driver is reported from the first tick on.
    #[cfg(feature = "tmc5160-spi")]
    let (tmc, drivers) = {
        let mut link = TmcLink::new(inst.LPSPI3, &inst.CCM, &gpios, &TMC_WIRING);
        let drivers = tmc_boot_check(&mut link, &gpios, &cycles);
        (link, drivers)
    };
    let tick = Tick::start(inst.PIT, PIT_LDVAL);
    let board = Teensy {
        tick,
        cycles,
        capture,
        gpios,
        limits,
        steps,
        wdog,
        clock,
        #[cfg(feature = "driver-enable")]
        enable,
        #[cfg(feature = "tmc5160-spi")]
        tmc,
        #[cfg(feature = "tmc5160-spi")]
        drivers,
    };
    let (host, boot) = init_root(board, marker, reset);

    // SAFETY: unmasking the PIT interrupt; its handler only uses `TICK_CTX`,
    // which is initialised above. Highest priority (0); Serial1 and USB
    // (wake-ups only, unmasked by the main loop before a WFI) below it, so
    // they never delay a tick.
    unsafe {
        cp.NVIC.set_priority(interrupt::PIT, 0);
        cp.NVIC.set_priority(interrupt::LPUART6, 0x80);
        cp.NVIC.set_priority(interrupt::USB_OTG1, 0x80);
        NVIC::unmask(interrupt::PIT);
    }

    // --- main loop
    let usb = port::Usb::new(inst.USB1, inst.USBPHY1, inst.USBNC1);
    let uart = port::Uart::new(serial1);
    #[cfg(not(feature = "serial1"))]
    let (mut proto, mut log) = (usb, port::LogPort::new(uart));
    #[cfg(feature = "serial1")]
    let (mut proto, mut log) = (uart, port::LogPort::new(usb));

    let mut clock = MsClock::new(cycles_now());
    defmt::info!(
        "PAROL6 fw {=str} config {=u64:x} boot_fault {=u8:#x} enc_fail {=u8:b}",
        firmware::VERSION,
        config_fingerprint(&PAROL6),
        firmware::boot_fault_log_code(boot.fault),
        boot.encoder_fail
    );
    let mut drain = [0u8; 64];
    let mut ram_check = ram_test::RunTimeTest::new();
    loop {
        let seen = TICKS.load(Ordering::Relaxed);
        let now_ms = clock.now_ms(cycles_now());
        // the protocol: bytes -> commands, telemetry -> lines -> port
        host.poll(&mut proto, now_ms);
        // defmt frames -> the log port (never the protocol port)
        log.poll();
        let n = logger::drain(&mut drain);
        if n > 0 {
            log.write_raw(drain.get(..n).unwrap_or(&[]));
        }
        log.flush();
        // the run-time RAM test (`ram_test::RunTimeTest`): the next block of
        // the free stack; a failing cell stops the arm as a panic would, and
        // the boot RAM test after the watchdog reset refuses the start.
        if ram_check.step().is_err() {
            fatal_stop()
        }
        // `teensy_loader_cli -s`: the USB line set to 134 baud asks for
        // the bootloader; honoured only at rest, else refused on the wire.
        #[cfg(not(feature = "serial1"))]
        let asked = proto.bootloader_requested();
        #[cfg(feature = "serial1")]
        let asked = log.port_mut().bootloader_requested();
        if asked && host.bootloader_request(&mut proto) == Bootloader::Reboot {
            enter_bootloader();
        }
        // Nothing moved on either port and no log frame: sleep until the
        // next interrupt (the tick, a byte, a USB event, room to transmit).
        let busy = proto.take_busy() | log.take_busy() | (n > 0);
        if !busy {
            sleep_unless_ticked(seen);
        }
    }
}

/// Programs the MPU's stack guard (`hal_imxrt::pure::mpu`: 1 KiB of no
/// access 1 KiB above the main stack's bottom, the default map elsewhere,
/// the MPU off in the HardFault handler) and turns the MPU on. The main
/// stack is the only stack: thread code and every handler (the tick too)
/// run on the MSP, so the one guard covers them all.
fn stack_guard(mpu: &mut cortex_m::peripheral::MPU) {
    use hal_imxrt::pure::mpu::{GUARD, GUARD_CTRL};
    // SAFETY: the MPU is off while the region is written; the one region
    // covers only the guard (no access), which nothing may use: it lies
    // below the deepest stack the build's stack analysis bounds
    // (firmware/tools/stack_analysis.py), and no static or code is there
    // (the stack is imxrt-rt's first DTCM section, checked by
    // firmware/build.sh). `PRIVDEFENA` keeps the default memory map and its
    // attributes for every other address, so no other access changes.
    unsafe {
        mpu.ctrl.write(0);
        mpu.rbar.write(GUARD.rbar);
        mpu.rasr.write(GUARD.rasr);
        mpu.ctrl.write(GUARD_CTRL);
    }
    cortex_m::asm::dsb();
    cortex_m::asm::isb();
}

/// The boot check of each TMC5160 (`tmc5160::BOOT_SEQUENCE`, waiting for
/// each answer; an answer that does not come counts as a silent line), then
/// the first run-time `DRV_STATUS` read started, so every tick has one to
/// collect.
#[cfg(feature = "tmc5160-spi")]
fn tmc_boot_check(link: &mut TmcLink, gpios: &Gpios, cycles: &CycleCounter) -> Monitor {
    const SILENT: Reply = Reply { status: 0xFF, data: 0xFFFF_FFFF };
    let mut verdicts = [None; tmc5160::DRIVERS];
    for (driver, verdict) in verdicts.iter_mut().enumerate() {
        let mut replies = [SILENT; 5];
        for (r, d) in replies.iter_mut().zip(tmc5160::BOOT_SEQUENCE) {
            *r = link.transfer(gpios, cycles, driver, d).unwrap_or(SILENT);
        }
        *verdict = tmc5160::boot_verdict(&replies);
    }
    let drivers = Monitor::after_boot(verdicts);
    link.start(gpios, drivers.driver(), Datagram::read(tmc5160::REG_DRV_STATUS));
    drivers
}

fn cycles_now() -> u32 {
    cortex_m::peripheral::DWT::cycle_count()
}

/// Milliseconds since boot from the wrapping DWT counter (main loop only;
/// it runs far more often than the 7.16 s wrap). Whole milliseconds plus the
/// cycles of the current one: the same count as dividing the 64-bit cycle
/// total by 600,000, with 32-bit division only (no `__aeabi_uldivmod`).
struct MsClock {
    last: u32,
    ms: u32,
    /// Cycles into the current millisecond, < `CYCLES_PER_MS`.
    rem: u32,
}

impl MsClock {
    fn new(now: u32) -> Self {
        Self { last: now, ms: 0, rem: 0 }
    }
    fn now_ms(&mut self, now: u32) -> u32 {
        let d = now.wrapping_sub(self.last);
        self.last = now;
        let mut whole = d / CYCLES_PER_MS;
        // < 2 x 600,000: no overflow
        self.rem += d % CYCLES_PER_MS;
        if self.rem >= CYCLES_PER_MS {
            self.rem -= CYCLES_PER_MS;
            whole += 1;
        }
        self.ms = self.ms.wrapping_add(whole);
        self.ms
    }
}

/// Builds both halves of the root in their statics (`TICK_CTX` for the
/// tick, `HOST` for the main loop), runs the boot self-test, and returns the
/// main loop's half. Not inlined: its temporaries (the root is a few KiB)
/// are released before the main loop starts. Called once, before the PIT
/// interrupt is unmasked.
#[inline(never)]
fn init_root(mut board: Teensy, marker: u32, reset: ResetCause) -> (&'static mut Host<'static>, BootReport) {
    // SAFETY: `LINK` is split exactly once, here, before the tick runs; the
    // two ends go to the tick (controller) and the main loop (host).
    let link: &'static mut RootLink = unsafe { &mut *addr_of_mut!(LINK) };
    let (mut controller, mut host) = root::new(&PAROL6_VALIDATED, link, HOST_CFG);
    host.set_reset_cause(reset);
    // Boot self-test: every encoder's frame period is measured by polling
    // the capture channels (at most `CALIBRATION_MS`), then the encoders
    // and limit inputs are sampled for `SELF_TEST_MS` (longer, at most
    // `SETTLE_MAX_MS`, while an encoder has no reading); the warm channels
    // go to the tick, so the first kernel readings initialise the
    // observers at the real angles (nothing moves).
    let boot = controller.boot(&mut board, marker, reset == ResetCause::Watchdog);
    // The PIT ran through the self-test with its interrupt masked and has
    // its flag set: restart its period so the first tick (and its watchdog
    // refresh) comes a full period after the self-test's last refresh,
    // outside the watchdog's window.
    board.tick.restart();
    // SAFETY: the PIT interrupt is still masked in the NVIC, so nothing else
    // can observe `TICK_CTX` while it is written.
    unsafe { (*addr_of_mut!(TICK_CTX)).write(TickCtx { controller, board }) };
    // SAFETY: called once from `main`; `HOST` is written here and then used
    // only through the returned reference, by the main loop alone.
    let host = unsafe { (*addr_of_mut!(HOST)).write(host) };
    (host, boot)
}

/// GPIO2 for the LED at boot (before `Gpios` owns the ports, or after: the
/// LED bit is not used by any driver).
fn unsafe_gpio2() -> ral::gpio::GPIO2 {
    // SAFETY: only the atomic DR_SET register and a read-modify-write of
    // GDIR bit 3 (LED, owned by no driver) are touched through this alias,
    // at boot before interrupts are enabled.
    unsafe { ral::gpio::GPIO2::instance() }
}

/// The image's CRC stamp (`firmware::image`): in flash (`.xip`, whose run
/// address is its load address), written after the link by
/// `firmware/build.sh` (`firmware/tools/stamp_crc.py`, which finds it by
/// this symbol name).
#[unsafe(link_section = ".xip.parol6_stamp")]
#[unsafe(no_mangle)]
#[used]
static PAROL6_IMAGE_STAMP: Stamp = Stamp::UNSTAMPED;

/// FlexSPI flash, memory-mapped: the image's first byte.
const FLASH_BASE: usize = 0x6000_0000;

/// Recomputes the image's CRC from flash and compares it with the stamp.
fn image_check() -> Result<(), ImageFault> {
    let p = core::ptr::addr_of!(PAROL6_IMAGE_STAMP);
    // SAFETY: `p` points at a live, aligned static; read volatile because
    // its value in flash is the stamping tool's, not the compiled constant
    // the optimiser would otherwise substitute.
    let stamp = unsafe { core::ptr::read_volatile(p) };
    let offset = (p as usize).wrapping_sub(FLASH_BASE);
    let len = covered_len(&stamp, offset)?;
    // SAFETY: the FlexSPI flash is mapped read-only from `FLASH_BASE` over
    // the 1984 KiB linked region; `covered_len` bounds `len` by it
    // (`IMAGE_MAX`), so the slice lies inside mapped memory that nothing
    // writes while the image runs.
    let image = unsafe { core::slice::from_raw_parts(FLASH_BASE as *const u8, len) };
    firmware::image::check(image, &stamp, offset)
}

/// The image failed its CRC check: the tick never starts, the outputs stay
/// as boot set them (STEP masked low, DIR low), and the protocol port
/// carries `FAULT HARDWARE IMAGE_CRC` every 200 ms. The watchdog is
/// refreshed every millisecond (outside its window) so that the chip stays
/// here, saying why, instead of resetting into the same check every 20 ms.
fn refuse_to_run<P: Port>(mut proto: P, wdog: &Watchdog, cycles: &CycleCounter) -> ! {
    const LINE: &[u8] = b"FAULT HARDWARE IMAGE_CRC\n";
    const EVERY_MS: u32 = 200;
    let mut ms: u32 = EVERY_MS;
    let mut sent = LINE.len();
    loop {
        let t = cycles.now();
        cycles.wait_since(t, CYCLES_PER_MS);
        wdog.feed();
        proto.poll();
        ms = ms.saturating_add(1);
        if ms >= EVERY_MS && sent == LINE.len() {
            ms = 0;
            sent = 0;
        }
        if sent < LINE.len() && proto.is_open() {
            let n = proto.write(LINE.get(sent..).unwrap_or(&[]));
            sent = sent.saturating_add(n).min(LINE.len());
        }
    }
}

/// Unrecoverable boot error: outputs are still masked; stop here and let
/// the watchdog reset the chip.
fn halt() -> ! {
    loop {
        cortex_m::asm::nop();
    }
}

/// The last-resort stop shared by the panic handler, the HardFault handler
/// and the default handler (twin defect 5, twin/README.md: cortex-m-rt's
/// own HardFault and DefaultHandler are `loop {}` and leave STEP pulsing
/// until the watchdog reset): interrupts off, every STEP pin low (masked, counter stopped, pad
/// switched to GPIO driven low), the drivers' enable output inactive (with
/// the `driver-enable` feature), the marker for the next boot
/// (`SelfTest(0x80)`), the LED on, then wait for the watchdog reset (the
/// tick no longer feeds it: within 20 ms).
fn fatal_stop() -> ! {
    cortex_m::interrupt::disable();
    // SAFETY: interrupts are disabled and this function never returns, so
    // the drivers that own these peripherals never run again (the PIT
    // handler cannot preempt a HardFault, nor run with PRIMASK set); the
    // aliases are used for the STEP shutdown, the marker and the LED only.
    unsafe {
        // 1. every STEP output low, stepping stopped; the drivers' enable
        // output inactive: torque off
        stop_outputs();
        // 2. remember it across the watchdog reset
        core::ptr::write_volatile(addr_of_mut!(PANIC_MARK).cast::<u32>(), firmware::PANIC_MARKER);
        // 3. signal
        let io = ral::iomuxc::IOMUXC::instance();
        let gpio2 = ral::gpio::GPIO2::instance();
        led_on(&io, &gpio2);
    }
    loop {
        cortex_m::asm::nop();
    }
}

/// Every STEP output low and stepping stopped, and (with the
/// `driver-enable` feature) the drivers' enable output inactive: the part
/// of the fatal stop and the bootloader hand-over that removes motion.
///
/// # Safety
/// Interrupts must be disabled and the caller must never return to the
/// drivers that own these peripherals (it aliases them).
unsafe fn stop_outputs() {
    // SAFETY: the caller's contract: no owner of these peripherals runs
    // again, so the aliases cannot race with it.
    let (pwm1, pwm2, pwm3, pwm4) = unsafe {
        (ral::pwm::PWM1::instance(), ral::pwm::PWM2::instance(), ral::pwm::PWM3::instance(), ral::pwm::PWM4::instance())
    };
    // SAFETY: as above.
    let (gpio1, gpio2, gpio3, gpio4, io) = unsafe {
        (
            ral::gpio::GPIO1::instance(),
            ral::gpio::GPIO2::instance(),
            ral::gpio::GPIO3::instance(),
            ral::gpio::GPIO4::instance(),
            ral::iomuxc::IOMUXC::instance(),
        )
    };
    panic_stop::force_steps_low([&pwm1, &pwm2, &pwm3, &pwm4], [&gpio1, &gpio2, &gpio3, &gpio4], &io, &MAP);
    #[cfg(feature = "driver-enable")]
    panic_stop::force_enable_inactive([&gpio1, &gpio2, &gpio3, &gpio4], &io, DRIVER_ENABLE);
}

/// Hands the chip to the Teensy's bootloader (asked over USB, the arm at
/// rest): interrupts off, every STEP output low as in [`fatal_stop`] (no
/// panic marker: this is no fault), then `bkpt #251`, the breakpoint the
/// Teensy 4.x bootloader chip watches for (Teensyduino's
/// `_reboot_Teensyduino_` does the same); it presents HalfKay (16C0:0478)
/// and `teensy_loader_cli` writes the new image. Should nothing take the
/// breakpoint (no bootloader chip), it escalates to a HardFault, whose
/// handler stops the same way and lets the watchdog reset the chip.
fn enter_bootloader() -> ! {
    cortex_m::interrupt::disable();
    // SAFETY: interrupts are disabled and this function never returns, so
    // the drivers that own these peripherals never run again; the aliases
    // are used for the STEP shutdown only (as in `fatal_stop`).
    unsafe {
        stop_outputs();
    }
    loop {
        // SAFETY: a breakpoint instruction; it touches no memory or
        // register the program relies on, and control does not come back
        // here with the chip in a state the program depends on.
        unsafe { core::arch::asm!("bkpt #251") };
    }
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo<'_>) -> ! {
    fatal_stop()
}

/// A HardFault (bus/usage/memory fault escalated, or a fault in a handler):
/// stop stepping at once instead of cortex-m-rt's `loop {}`.
#[cortex_m_rt::exception]
unsafe fn HardFault(_frame: &cortex_m_rt::ExceptionFrame) -> ! {
    fatal_stop()
}

/// Any exception or interrupt without a handler of its own (only the PIT,
/// Serial1 and USB interrupts are enabled; anything else reaching here is
/// a fault).
#[cortex_m_rt::exception]
unsafe fn DefaultHandler(_irqn: i16) -> ! {
    fatal_stop()
}
