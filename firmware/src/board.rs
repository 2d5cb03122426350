//! The small board interface the composition root ([`crate::root`]) is
//! generic over. The Teensy 4.1 image binds it to `hal_imxrt::periph`
//! (`src/target/`); the simulator binds it to a simulated arm. Everything
//! above this interface (decode, debounce, sensing, kernel, actuation
//! mapping, telemetry, line formatting, transmit policy) is the same code in
//! both.

use hal_imxrt::pure::frame::Snapshot;
use hal_imxrt::pure::step::StepCommand;
use kernel::config::AXES;
use kernel::DriverCause;

/// What the 1 kHz tick touches. Every method is non-blocking and bounded.
pub trait TickBoard {
    /// One QuadTimer capture snapshot per encoder channel, J1..J6.
    fn capture(&mut self) -> [Snapshot; AXES];
    /// Raw limit-switch input levels, bit `i` = J(i+1) pin high (pull-up:
    /// high = switch open). Debounced by the root.
    fn limit_levels(&mut self) -> u8;
    /// Program all six step outputs at once (the root passes all six or
    /// six `Stop`s).
    fn apply(&mut self, cmds: &[StepCommand; AXES]);
    /// Refresh the watchdog (called once at the end of a tick whose
    /// program-flow check passed, see [`crate::flow`]).
    fn feed_watchdog(&mut self);
    /// Free-running CPU cycle counter (600 MHz on the Teensy).
    fn cycles(&self) -> u32;
    /// Called last in the tick: true if the next tick became due while this
    /// one ran (an overrun, reported to the kernel on the next tick).
    fn end_of_tick(&mut self) -> bool;
    /// Boot only (interrupts masked): wait one millisecond, keeping the
    /// watchdog fed. The simulator advances its arm by one millisecond.
    fn boot_wait_ms(&mut self);
    /// True once the core clock failed its check against the independent
    /// 32.768 kHz reference (`hal_imxrt::pure::clock_check`; sticky until
    /// reset). Read once per tick, before the kernel. A board without the
    /// check (the simulator) never fails it.
    fn clock_fault(&mut self) -> bool {
        false
    }
    /// Drive the stepper drivers' enable output: `on` is
    /// [`crate::driver_enable::drivers_enabled`] of the kernel's state
    /// after this tick's step, so the drivers are de-energised in the tick
    /// a fault is latched. Called once per tick, before the step commands.
    /// A board without the output (the default image, the simulator) does
    /// nothing.
    fn drivers_enable(&mut self, _on: bool) {}
    /// The stepper drivers' own diagnostics (the TMC5160 SPI link,
    /// `hal_imxrt::pure::tmc5160`): the first axis whose driver currently
    /// reports a problem, and the problem. Called once per tick, before the
    /// kernel; the image reads one driver per call. A board without the
    /// link (the simulator, an image built without `tmc5160-spi`) reports
    /// nothing.
    fn driver_fault(&mut self) -> Option<(u8, DriverCause)> {
        None
    }
    /// Boot only: [`TickBoard::capture`] may be called back to back, each
    /// snapshot taken at the board's real time ([`TickBoard::cycles`]), so
    /// the root can poll the capture channels to measure every encoder's
    /// frame period before the first tick (`root::CALIBRATION_MS`). The
    /// Teensy: yes. Default: no (the simulator's arm moves only in
    /// [`TickBoard::boot_wait_ms`]); the decoders then measure the period
    /// from the 1 ms snapshots, and the boot self-test waits for them (at
    /// most `root::SETTLE_MAX_MS`).
    fn can_poll_capture(&self) -> bool {
        false
    }
}

/// A byte link to the host (USB CDC, Serial1, a pseudo-terminal).
pub trait Port {
    /// Service the hardware (USB enumeration and transfers).
    fn poll(&mut self) {}
    /// A host is listening (USB: configured with DTR set; a UART: always).
    fn is_open(&self) -> bool;
    /// One received byte, if any.
    fn read(&mut self) -> Option<u8>;
    /// Hands bytes to the hardware without blocking; returns how many it
    /// took (possibly 0). What it did not take stays in the root's ring.
    fn write(&mut self, bytes: &[u8]) -> usize;
}
