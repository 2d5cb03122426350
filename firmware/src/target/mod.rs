//! The Teensy 4.1 image: boot, the 1 kHz tick, the main loop, the panic
//! handler. Compiled only for `target_os = "none"`.
//!
//! This is the composition root (as `sim/src/root.rs` is for the simulator):
//! it owns every peripheral once, holds the kernel's [`Authority`], and
//! wires HAL <-> queues <-> kernel.
//!
//! `unsafe` appears only here, each with a `// SAFETY:` comment: taking the
//! peripheral instances once, the tick context shared between `main` (init,
//! before the interrupt is unmasked) and the PIT handler (afterwards), the
//! queue link, the panic marker and the panic handler's stolen registers.

mod logger;
mod port;

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use teensy4_bsp as bsp;

use bsp::board;
use bsp::interrupt;
use bsp::ral;
use cortex_m::peripheral::NVIC;

use hal_imxrt::periph::cycles::CycleCounter;
use hal_imxrt::periph::frame_capture::FrameCapture;
use hal_imxrt::periph::gpio::{Gpios, Limits};
use hal_imxrt::periph::step::StepOutputs;
use hal_imxrt::periph::tick::Tick;
use hal_imxrt::periph::uart::Serial1;
use hal_imxrt::periph::watchdog::Watchdog;
use hal_imxrt::periph::{clocks, iomux, panic_stop};
use hal_imxrt::pure::clock::{pit_load_value, rtwdog_toval, OSC_HZ, RTWDOG_LPO_HZ, TICK_HZ, WATCHDOG_TIMEOUT_US};
use hal_imxrt::pure::encoder::{EncoderReading, LossReason, Tracker, TrackerConfig};
use hal_imxrt::pure::frame::FrameDecoder;
use hal_imxrt::pure::pins::{PinMap, DEFAULT_PIN_MAP};
use hal_imxrt::pure::step::StepConfig;
use hal_imxrt::pure::uart::{lpuart_divisor, BaudDivisor};

use firmware::{CMD_SLOTS, TEL_SLOTS};
use kernel::config::{AXES, PAROL6};
use kernel::{Authority, HardwareFault, KernelF32, State};
use protocol::feedback::{configurator_line, driver_line, FeedbackDivider, FeedbackMode};
use protocol::queue::{HostEnd, Link, Telemetry, TickEnd};
use protocol::receiver::{Received, Receiver};
use protocol::report::{
    banner_line, config_fingerprint, event_line, events_lost_line, queue_full_line, telemetry_lost_line,
};
use protocol::{Line, ProtocolConfig};

use port::Port;

#[cfg(feature = "tmc5160-selftest")]
compile_error!("tmc5160-selftest: not implemented (no TMC5160 SPI chip-select wiring in the pin map)");

/// The pin map (checked at compile time by `PinMap::validated`).
const MAP: PinMap = DEFAULT_PIN_MAP;
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
/// Serial1 at 115200 from the 24 MHz UART clock.
const BAUD: BaudDivisor = match lpuart_divisor(OSC_HZ, 115_200) {
    Ok(v) => v,
    Err(_) => panic!("baud"),
};
/// Boot self-test length (ms): enough for the frame decoder and the
/// tracker to acquire (about 5 frames) with margin.
const SELF_TEST_MS: u32 = 30;
/// Feedback lines: as the simulator (driver format).
const FEEDBACK: FeedbackMode = FeedbackMode::Driver;
/// Teensy LED: pin 13 = GPIO_B0_03 = GPIO2 bit 3.
const LED_BIT: u32 = 1 << 3;

/// Everything the tick touches. Lives in DTCM (`.bss`, teensy4-bsp's
/// imxrt-rt layout); the code that runs on it is in ITCM (`.text`).
struct TickCtx {
    kernel: KernelF32,
    authority: Authority,
    tick: Tick,
    cycles: CycleCounter,
    capture: FrameCapture,
    decoders: [FrameDecoder; AXES],
    trackers: [Tracker; AXES],
    gpios: Gpios,
    limits: Limits,
    steps: StepOutputs,
    wdog: Watchdog,
    link: TickEnd<'static, f32, CMD_SLOTS, TEL_SLOTS>,
    divider: FeedbackDivider,
    pending_fault: Option<HardwareFault>,
    last_us: u32,
}

/// Initialised by `main` before the PIT interrupt is unmasked; afterwards
/// used only by the PIT handler.
static mut TICK_CTX: MaybeUninit<TickCtx> = MaybeUninit::uninit();
/// The command/telemetry link; split once in `main`.
static mut LINK: Link<f32, CMD_SLOTS, TEL_SLOTS> = Link::new();
/// Survives a reset (imxrt-rt `.uninit`, not zeroed at start-up): set by the
/// panic handler, read and cleared at boot.
// SAFETY: `.uninit.parol6_panic` is placed by imxrt-rt's linker script in the
// `.uninit` output section (OCRAM, not zero-initialised, not overlapping any
// other object); the static is `MaybeUninit`, so an arbitrary bit pattern at
// power-on is a valid value, and it is only read as a plain `u32` marker.
#[unsafe(link_section = ".uninit.parol6_panic")]
static mut PANIC_MARK: MaybeUninit<u32> = MaybeUninit::uninit();

impl TickCtx {
    /// One control tick: sense -> kernel (one request) -> act -> telemetry
    /// -> watchdog -> overrun check. No allocation, no blocking (the only
    /// wait is the bounded 1.5 us DIR settle inside `StepOutputs::apply`),
    /// no formatting.
    #[inline(always)]
    fn run(&mut self) {
        let t0 = self.cycles.now();
        let _ = self.tick.on_interrupt();
        // 1. sense
        let snaps = self.capture.sample(&self.cycles);
        let mut enc = [EncoderReading::Lost(LossReason::Acquiring); AXES];
        for (((e, s), d), t) in
            enc.iter_mut().zip(snaps.iter()).zip(self.decoders.iter_mut()).zip(self.trackers.iter_mut())
        {
            *e = t.update(d.update(*s));
        }
        let limits = self.limits.sample(&self.gpios);
        let sense = firmware::sense(&enc, &limits, self.pending_fault.take());
        // 2. one request; ENABLE becomes a capability only here (a HOME
        // that arrives during Boot is queued by the kernel itself)
        let cmd = self.link.recv();
        let authority = &self.authority;
        let request = cmd.map(|c| c.into_request(authority));
        // 3. kernel
        let out = self.kernel.tick(&sense, request);
        // 4. act (all six or none)
        let (cmds, refused) = firmware::act(&out.act.step_rate, &StepConfig::DEFAULT);
        self.steps.apply(&self.gpios, &self.cycles, &cmds);
        if let Some(axis) = refused {
            self.pending_fault = Some(HardwareFault::Driver { axis });
        }
        // 5. telemetry (never blocks; losses are counted by the link)
        for e in out.events.iter() {
            self.link.send(Telemetry::Event(*e));
        }
        if out.events.dropped() > 0 {
            self.link.send(Telemetry::EventsLost(out.events.dropped()));
        }
        if self.divider.tick() {
            self.link.send(Telemetry::Status { status: out.status, tick_us: self.last_us });
        }
        // Policy (as the simulator's root): a latched tracker re-acquires
        // while the kernel holds a fault; ENABLE then re-initialises the axis.
        if out.status.state == State::Fault {
            for t in self.trackers.iter_mut() {
                let mut probe = *t;
                if probe.update(EncoderReading::Lost(LossReason::NoSignal))
                    == EncoderReading::Lost(LossReason::Unrecoverable)
                {
                    t.reset();
                }
            }
        }
        self.wdog.feed();
        if self.tick.end_of_handler() {
            self.pending_fault = Some(HardwareFault::TickOverrun);
        }
        self.last_us = firmware::cycles_to_us(self.cycles.now().wrapping_sub(t0));
    }
}

#[bsp::rt::interrupt]
fn PIT() {
    // SAFETY: `TICK_CTX` is written by `main` before the PIT interrupt is
    // unmasked and never touched by `main` again; this handler is the only
    // user afterwards and cannot re-enter itself (same priority).
    let ctx = unsafe { (*addr_of_mut!(TICK_CTX)).assume_init_mut() };
    ctx.run();
}

fn led_on(io: &ral::iomuxc::RegisterBlock, gpio2: &ral::gpio::RegisterBlock) {
    ral::write_reg!(ral::gpio, gpio2, DR_SET, LED_BIT);
    ral::modify_reg!(ral::gpio, gpio2, GDIR, |v| v | LED_BIT);
    ral::write_reg!(ral::iomuxc, io, SW_MUX_CTL_PAD_GPIO_B0_03, 5);
}

#[bsp::rt::entry]
fn main() -> ! {
    // --- clocks: teensy4-bsp's policy (ARM 600 MHz, IPG 150 MHz, PLL3 for
    // USB), then the thin HAL's roots (PERCLK, UART_CLK = 24 MHz) and gates.
    let mut inst = board::instances();
    board::prepare_clocks_and_power(&mut inst.CCM, &mut inst.CCM_ANALOG, &mut inst.DCDC);
    clocks::configure(&inst.CCM);

    // --- reset cause and panic marker, before anything can panic again.
    let srsr = ral::read_reg!(ral::src, inst.SRC, SRSR);
    ral::write_reg!(ral::src, inst.SRC, SRSR, srsr); // w1c
    let watchdog_reset = srsr & ral::src::SRSR::WDOG3_RST_B::mask != 0;
    // SAFETY: single-threaded boot, interrupts not yet enabled; the word is
    // plain memory (uninitialised after power-on: any value is fine, only
    // the exact marker means "previous panic").
    let marker = unsafe {
        let p = addr_of_mut!(PANIC_MARK).cast::<u32>();
        let m = core::ptr::read_volatile(p);
        core::ptr::write_volatile(p, 0);
        m
    };

    // --- watchdog first: from here on a hang resets the chip.
    let wdog = Watchdog::start(inst.RTWDOG, WDOG_TOVAL);

    let Some(mut cp) = cortex_m::Peripherals::take() else { halt() };
    let cycles = CycleCounter::enable(&mut cp.DCB, &mut cp.DWT);

    // --- pins and drivers (STEP outputs masked low, DIR low)
    if iomux::configure_pins(&inst.IOMUXC, &inst.IOMUXC_GPR, &MAP).is_err() {
        halt()
    }
    let gpios = Gpios::new(inst.GPIO1, inst.GPIO2, inst.GPIO3, inst.GPIO4);
    let Ok(steps) = StepOutputs::new(inst.PWM1, inst.PWM2, inst.PWM3, inst.PWM4, &gpios, &MAP) else { halt() };
    let Ok(limits) = Limits::new(&gpios, &MAP) else { halt() };
    let Ok(capture) = FrameCapture::new(inst.TMR1, inst.TMR3, &MAP) else { halt() };
    let serial1 = Serial1::new(inst.LPUART6, BAUD);
    if marker == firmware::PANIC_MARKER {
        // keep signalling the previous panic until the fault is handled
        led_on(&inst.IOMUXC, &unsafe_gpio2());
    }

    // --- encoder self-test: run the capture for SELF_TEST_MS; the warmed-up
    // decoders and trackers go to the tick, so the first kernel readings
    // initialise the observers at the real angles (nothing moves).
    let mut decoders = [FrameDecoder::new(); AXES];
    let mut trackers = [Tracker::new(TrackerConfig::DEFAULT); AXES];
    let mut last = [EncoderReading::Lost(LossReason::Acquiring); AXES];
    let mut t = cycles.now();
    for _ in 0..SELF_TEST_MS {
        cycles.wait_since(t, 600_000);
        t = t.wrapping_add(600_000);
        let snaps = capture.sample(&cycles);
        for (((l, s), d), tr) in last.iter_mut().zip(snaps.iter()).zip(decoders.iter_mut()).zip(trackers.iter_mut()) {
            *l = tr.update(d.update(*s));
        }
        wdog.feed();
    }
    let enc_fail = firmware::encoder_self_test(&last);
    let boot_fault = firmware::boot_fault(marker, watchdog_reset, enc_fail);

    // --- protocol side
    // SAFETY: `LINK` is split exactly once, here, before the tick runs; the
    // two ends go to the main loop and the tick respectively.
    let link: &'static mut Link<f32, CMD_SLOTS, TEL_SLOTS> = unsafe { &mut *addr_of_mut!(LINK) };
    let (mut host, tick_end) = link.split();
    let (kernel, authority) = KernelF32::new(&PAROL6);

    // --- the tick context, then the tick, then unmask.
    let tick = Tick::start(inst.PIT, PIT_LDVAL);
    let ctx = TickCtx {
        kernel,
        authority,
        tick,
        cycles,
        capture,
        decoders,
        trackers,
        gpios,
        limits,
        steps,
        wdog,
        link: tick_end,
        divider: FeedbackDivider::default_for(PAROL6.tick_hz),
        pending_fault: boot_fault,
        last_us: 0,
    };
    // SAFETY: the PIT interrupt is still masked in the NVIC, so nothing else
    // can observe `TICK_CTX` while it is written.
    unsafe { (*addr_of_mut!(TICK_CTX)).write(ctx) };
    // SAFETY: unmasking the PIT interrupt; its handler only uses `TICK_CTX`,
    // which is initialised above. Highest priority (0), the only interrupt.
    unsafe {
        cp.NVIC.set_priority(interrupt::PIT, 0);
        NVIC::unmask(interrupt::PIT);
    }

    // --- main loop
    let usb = port::Usb::new(inst.USB1, inst.USBPHY1, inst.USBNC1);
    let uart = port::Uart::new(serial1);
    #[cfg(not(feature = "serial1"))]
    let (mut proto, mut log) = (usb, uart);
    #[cfg(feature = "serial1")]
    let (mut proto, mut log) = (uart, usb);

    let mut rx: Receiver<f32> = Receiver::new(&PAROL6, ProtocolConfig::DEFAULT);
    let mut line = Line::new();
    let mut clock = MsClock::new(cycles_now());
    let mut was_open = false;
    defmt::info!(
        "PAROL6 fw {=str} config {=u64:x} boot_fault {=?} enc_fail {=u8:b}",
        firmware::VERSION,
        config_fingerprint(&PAROL6),
        defmt::Debug2Format(&boot_fault),
        enc_fail
    );
    let mut drain = [0u8; 64];
    loop {
        let now_ms = clock.now_ms(cycles_now());
        proto.poll();
        log.poll();
        // Boot banner whenever the host (re)opens the protocol port.
        let open = proto.is_open();
        if open && !was_open {
            line.clear();
            if banner_line(&mut line, firmware::VERSION, config_fingerprint(&PAROL6), rx.parser().lock(), FEEDBACK)
                .is_ok()
            {
                proto.write_line(line.as_bytes());
            }
        }
        was_open = open;
        // bytes -> lines -> commands -> queue
        while let Some(b) = proto.read() {
            let Some(r) = rx.push(b, now_ms) else { continue };
            if let Ok(true) = r.report(&mut line) {
                proto.write_line(line.as_bytes());
            }
            if let Received::Accepted { command, .. } = r {
                if let Err(q) = host.send(command) {
                    if queue_full_line(&mut line, &q).is_ok() {
                        proto.write_line(line.as_bytes());
                    }
                }
            }
        }
        // telemetry -> lines
        drain_telemetry(&mut host, &rx, &mut line, &mut proto);
        // defmt frames -> the log port (never the protocol port)
        let n = logger::drain(&mut drain);
        if n > 0 {
            log.write_raw(drain.get(..n).unwrap_or(&[]));
        }
        proto.flush();
        log.flush();
    }
}

fn drain_telemetry<P: Port>(
    host: &mut HostEnd<'static, f32, CMD_SLOTS, TEL_SLOTS>,
    rx: &Receiver<f32>,
    line: &mut Line,
    out: &mut P,
) {
    while let Some(t) = host.recv() {
        let ok = match t {
            Telemetry::Status { status, tick_us } => match FEEDBACK {
                FeedbackMode::Driver => driver_line(line, rx.last_seq(), &status),
                _ => configurator_line(line, rx.last_seq(), &status, tick_us),
            },
            Telemetry::Event(e) => event_line(line, &e),
            Telemetry::EventsLost(n) => events_lost_line(line, u32::from(n)),
            Telemetry::Lost(n) => telemetry_lost_line(line, n),
        };
        if ok.is_ok() {
            out.write_line(line.as_bytes());
        }
    }
}

fn cycles_now() -> u32 {
    cortex_m::peripheral::DWT::cycle_count()
}

/// Milliseconds since boot from the wrapping DWT counter (main loop only;
/// it runs far more often than the 7.16 s wrap).
struct MsClock {
    last: u32,
    cycles: u64,
}

impl MsClock {
    fn new(now: u32) -> Self {
        Self { last: now, cycles: 0 }
    }
    fn now_ms(&mut self, now: u32) -> u32 {
        self.cycles = self.cycles.wrapping_add(u64::from(now.wrapping_sub(self.last)));
        self.last = now;
        (self.cycles / 600_000) as u32
    }
}

/// GPIO2 for the LED at boot (before `Gpios` owns the ports, or after: the
/// LED bit is not used by any driver).
fn unsafe_gpio2() -> ral::gpio::GPIO2 {
    // SAFETY: only the atomic DR_SET register and a read-modify-write of
    // GDIR bit 3 (LED, owned by no driver) are touched through this alias,
    // at boot before interrupts are enabled.
    unsafe { ral::gpio::GPIO2::instance() }
}

/// Unrecoverable boot error: outputs are still masked; stop here and let
/// the watchdog reset the chip.
fn halt() -> ! {
    loop {
        cortex_m::asm::nop();
    }
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo<'_>) -> ! {
    cortex_m::interrupt::disable();
    // SAFETY: interrupts are disabled and this function never returns, so
    // the drivers that own these peripherals never run again; the aliases
    // are used for the STEP shutdown, the marker and the LED only.
    unsafe {
        let pwm1 = ral::pwm::PWM1::instance();
        let pwm2 = ral::pwm::PWM2::instance();
        let pwm3 = ral::pwm::PWM3::instance();
        let pwm4 = ral::pwm::PWM4::instance();
        let gpio1 = ral::gpio::GPIO1::instance();
        let gpio2 = ral::gpio::GPIO2::instance();
        let gpio3 = ral::gpio::GPIO3::instance();
        let gpio4 = ral::gpio::GPIO4::instance();
        let io = ral::iomuxc::IOMUXC::instance();
        // 1. every STEP output low, stepping stopped
        panic_stop::force_steps_low([&pwm1, &pwm2, &pwm3, &pwm4], [&gpio1, &gpio2, &gpio3, &gpio4], &io, &MAP);
        // 2. remember it across the watchdog reset
        core::ptr::write_volatile(addr_of_mut!(PANIC_MARK).cast::<u32>(), firmware::PANIC_MARKER);
        // 3. signal
        led_on(&io, &gpio2);
    }
    // The tick no longer feeds the watchdog: the chip resets within 20 ms and
    // boots into a latched fault (`SelfTest(0x80)`) with the LED on.
    loop {
        cortex_m::asm::nop();
    }
}
