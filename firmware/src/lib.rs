//! The PAROL6 firmware's composition root and its pure glue, host-tested.
//!
//! The image itself (`src/main.rs`, `src/target/`) is built only for
//! `thumbv7em-none-eabihf` by `firmware/build.sh`; it binds the board
//! interface ([`board`]) to `hal_imxrt::periph` and runs [`root`]. The
//! simulator (`sim/`) binds the same interface to a simulated arm and runs
//! the same [`root`], so what the simulator exercises is what is flashed.
//! Everything here is arithmetic or policy without registers:
//!
//! * [`root`]: the composition root (tick half and main-loop half);
//! * [`board`]: the board interface the root is generic over;
//! * [`flow`]: the tick's program-flow check that gates the watchdog refresh;
//! * [`driver_enable`]: when the stepper drivers may be energised;
//! * [`image`]: the image's CRC check at boot;
//! * [`tx`]: the transmit ring with counted, reported drops;
//! * [`sense`]: HAL readings -> [`kernel::Sense`];
//! * [`act`]: kernel step rates -> `hal_imxrt` step commands (all or none);
//! * [`boot_fault`]: reset cause and self-test -> [`kernel::HardwareFault`];
//! * [`cycles_to_us`]: tick duration for the configurator line.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![deny(clippy::arithmetic_side_effects)]

pub mod board;
pub mod driver_enable;
pub mod flow;
pub mod image;
pub mod root;
pub mod tx;

use hal_imxrt::pure::debounce::LimitState;
use hal_imxrt::pure::encoder::EncoderReading;
use hal_imxrt::pure::step::{StepCommand, StepPlan};
use kernel::config::AXES;
use kernel::{EncoderSample, HardwareFault, Sense};

/// Firmware version string for the banner.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

// The kernel's time constants come from its configuration's tick rate; the
// HAL's PIT runs at its own constant. They must be the same rate (C++
// defect 11: a 500 Hz loop with dt hard-coded to 1 ms).
static_assertions::const_assert_eq!(hal_imxrt::pure::clock::TICK_HZ, kernel::config::PAROL6.tick_hz);

// The kernel keeps its own encoder facts (it depends on no HAL); this crate
// sees both, and they must be the HAL's: counts per revolution (the
// unwrapper's modulus, the range of a valid reading) and the frame period
// (the plausibility window allows two frames of motion).
static_assertions::const_assert_eq!(kernel::config::COUNTS_PER_REV as u32, hal_imxrt::pure::mt6816::COUNTS_PER_REV);
const _: () = {
    use hal_imxrt::pure::mt6816::{FRAME_CLOCKS, PWM_CLOCK_NS};
    let hal_s = FRAME_CLOCKS as f64 * PWM_CLOCK_NS as f64 * 1e-9;
    let d = kernel::config::ENCODER_FRAME_S - hal_s;
    // equal to a few rounding steps of 1.03e-3 s
    assert!(d < 1e-15 && d > -1e-15);
};

/// Command queue slots (as the simulator's root).
pub const CMD_SLOTS: usize = 8;
/// Telemetry queue slots.
pub const TEL_SLOTS: usize = 16;

/// HAL readings -> kernel sense. A limit input whose debounce has not yet
/// confirmed a level (`Unknown`) counts as pressed (not safe to move), as in
/// the simulator's plant.
pub fn sense(
    encoders: &[EncoderReading; AXES],
    limits: &[LimitState; AXES],
    hardware_fault: Option<HardwareFault>,
    link_lost: bool,
) -> Sense {
    let mut e = [EncoderSample::Lost; AXES];
    for (o, r) in e.iter_mut().zip(encoders.iter()) {
        *o = match r {
            EncoderReading::Count(c) => EncoderSample::Count(*c),
            EncoderReading::Lost(_) => EncoderSample::Lost,
        };
    }
    let mut bits = 0u8;
    for (i, l) in limits.iter().enumerate() {
        if matches!(l, LimitState::Pressed | LimitState::Unknown) {
            bits |= 1u8 << (i & 7);
        }
    }
    Sense { encoders: e, limits: bits, hardware_fault, link_lost }
}

/// Kernel step rates (steps/s, signed) -> step generator commands, all six
/// or none: if any axis cannot be programmed (rate above the HAL's maximum,
/// which a consistent configuration never asks for), every axis gets
/// `Stop` and the first such axis is returned, to be reported to the kernel
/// as [`HardwareFault::Driver`] on the next tick.
pub fn act(rates: &[i32; AXES], plan: &StepPlan) -> ([StepCommand; AXES], Option<u8>) {
    let mut out = [StepCommand::Stop; AXES];
    let refused = act_into(rates, plan, &mut out);
    (out, refused)
}

/// [`act`] into caller-owned storage (the tick's record): `out` holds all
/// six commands, or six `Stop`s and the first axis that could not be
/// programmed is returned.
pub fn act_into(rates: &[i32; AXES], plan: &StepPlan, out: &mut [StepCommand; AXES]) -> Option<u8> {
    let mut refused = None;
    for (i, (o, &r)) in out.iter_mut().zip(rates.iter()).enumerate() {
        match plan.command(r.saturating_mul(1000)) {
            Ok(c) => *o = c,
            Err(_) => {
                refused = Some(i as u8);
                break;
            }
        }
    }
    if refused.is_some() {
        *out = [StepCommand::Stop; AXES];
    }
    refused
}

/// CPU cycles (600 MHz) -> whole microseconds.
pub const fn cycles_to_us(cycles: u32) -> u32 {
    cycles / hal_imxrt::pure::clock::CYCLES_PER_US
}

/// Boot-fault codes carried in [`HardwareFault::SelfTest`].
pub mod code {
    /// Encoder self-test failed; the low 6 bits are the failing axes.
    pub const ENCODER: u8 = 0x40;
    /// The previous run ended in a panic (marker survived the reset).
    pub const PREVIOUS_PANIC: u8 = 0x80;
    /// The previous run was reset by the watchdog (the tick stopped).
    pub const WATCHDOG_RESET: u8 = 0x81;
    /// The core clock deviates more than 1 % from the 32.768 kHz reference
    /// (at boot or in any later one-second window; reported on every tick
    /// from then on, so `<ENABLE>` stays refused until a reset).
    pub const CLOCK: u8 = 0x82;
    /// The boot RAM test (March C-) found a failing cell in the image's
    /// statics, its vector table or its free stack: the image does not start (no
    /// tick; the line is written once per boot, then the watchdog resets).
    pub const RAM: u8 = 0x83;
}

/// The line the image writes on Serial1 when the boot RAM test fails, before
/// any of the root exists: the kernel's own wording of
/// `Event::Fault(Hardware(SelfTest(code::RAM)))` (a test checks it against
/// `protocol::report::event_line`; a constant here keeps the line
/// formatter out of the boot path, 6.7 KB of flash when it was called).
pub const RAM_FAULT_LINE: &str = "FAULT HARDWARE SELF_TEST code=131\n";

/// The kernel's name for what a TMC5160's check found
/// (`hal_imxrt::pure::tmc5160`), one to one.
pub const fn driver_cause(f: hal_imxrt::pure::tmc5160::Finding) -> kernel::DriverCause {
    use hal_imxrt::pure::tmc5160::Finding;
    use kernel::DriverCause;
    match f {
        Finding::Missing => DriverCause::Missing,
        Finding::WrongVersion => DriverCause::WrongVersion,
        Finding::Reset => DriverCause::Reset,
        Finding::DriverError => DriverCause::DriverError,
        Finding::ChargePump => DriverCause::ChargePump,
        Finding::Overtemperature => DriverCause::Overtemperature,
        Finding::ShortToGround => DriverCause::ShortToGround,
        Finding::ShortToSupply => DriverCause::ShortToSupply,
        Finding::OpenLoad => DriverCause::OpenLoad,
    }
}

/// Value of the panic marker word kept in non-initialised RAM.
pub const PANIC_MARKER: u32 = 0x5041_4E43; // "PANC"

/// The fault to hand the kernel with the first sense, if any: a previous
/// panic beats a watchdog reset beats an encoder self-test failure. A
/// latched fault needs the host's `<ENABLE>` (and then re-homing), so a
/// controller that crashed never resumes on its own — even if a host sends
/// `<HOME>` as soon as it sees the boot banner.
pub fn boot_fault(panic_marker: u32, watchdog_reset: bool, encoder_fail_mask: u8) -> Option<HardwareFault> {
    if panic_marker == PANIC_MARKER {
        Some(HardwareFault::SelfTest(code::PREVIOUS_PANIC))
    } else if watchdog_reset {
        Some(HardwareFault::SelfTest(code::WATCHDOG_RESET))
    } else if encoder_fail_mask & 0x3F != 0 {
        Some(HardwareFault::SelfTest(code::ENCODER | (encoder_fail_mask & 0x3F)))
    } else {
        None
    }
}

/// The boot fault as one byte for the boot log line (no `core::fmt` in the
/// image): 0 none, the [`code`] of a self-test fault; `0xE0 | axis` a
/// driver's own diagnostic, `0xF0 | axis` a refused step rate and `0xFF` a
/// tick overrun never occur at boot (the TMC5160 boot check's finding
/// reaches the kernel through the first tick, not through this fault).
pub const fn boot_fault_log_code(fault: Option<HardwareFault>) -> u8 {
    match fault {
        None => 0,
        Some(HardwareFault::SelfTest(c)) => c,
        Some(HardwareFault::Driver { axis }) => 0xF0 | (axis & 0x0F),
        Some(HardwareFault::DriverDiagnostic { axis, .. }) => 0xE0 | (axis & 0x0F),
        Some(HardwareFault::TickOverrun) => 0xFF,
    }
}

/// Samples at the end of the boot self-test in which an axis must have
/// read a count: the kernel coasts through `encoder_invalid_limit` (2)
/// lost samples in a row, so one more than that. A fast MT6816 (a frame
/// shorter than the 1 ms sample) now and then has no fresh frame in a
/// sample; judging the last sample alone failed such an encoder at random
/// (the twin's 5 %-fast J1, `twin/tests/defects.rs` defect6).
pub const SELF_TEST_WINDOW: u32 = 3;

/// Which axes failed the boot self-test: `recent[i]` has bit `k` set if
/// axis `i` read a count `k` samples before the last; an axis passes if
/// it read one in the last [`SELF_TEST_WINDOW`] samples.
pub fn encoder_self_test(recent: &[u8; AXES]) -> u8 {
    const WINDOW: u8 = (1u8 << SELF_TEST_WINDOW) - 1;
    let mut mask = 0u8;
    for (i, r) in recent.iter().enumerate() {
        if r & WINDOW == 0 {
            mask |= 1u8 << (i & 7);
        }
    }
    mask
}

// Test code is built with overflow checks on: an overflow fails the test.
#[cfg(test)]
#[allow(clippy::arithmetic_side_effects)]
mod tests {
    use super::*;
    use hal_imxrt::pure::encoder::LossReason;
    use hal_imxrt::pure::step::{achieved_rate_mhz, Direction, StepConfig};
    use kernel::config::PAROL6;

    #[test]
    fn sense_maps_counts_losses_and_limits() {
        let enc = [
            EncoderReading::Count(0),
            EncoderReading::Count(4095),
            EncoderReading::Lost(LossReason::NoSignal),
            EncoderReading::Count(17),
            EncoderReading::Lost(LossReason::Acquiring),
            EncoderReading::Count(2048),
        ];
        let lim = [
            LimitState::Released,
            LimitState::Pressed,
            LimitState::Unknown,
            LimitState::Released,
            LimitState::Released,
            LimitState::Pressed,
        ];
        let s = sense(&enc, &lim, Some(HardwareFault::TickOverrun), false);
        assert_eq!(
            s.encoders,
            [
                EncoderSample::Count(0),
                EncoderSample::Count(4095),
                EncoderSample::Lost,
                EncoderSample::Count(17),
                EncoderSample::Lost,
                EncoderSample::Count(2048)
            ]
        );
        assert_eq!(s.limits, 0b10_0110);
        assert_eq!(s.hardware_fault, Some(HardwareFault::TickOverrun));
    }

    #[test]
    fn act_maps_every_axis_and_sign() {
        let cfg = StepConfig::DEFAULT;
        let rates = [0, 19, 20, -20, 110_592, -50_000];
        let (cmds, err) = act(&rates, &StepPlan::DEFAULT);
        assert_eq!(err, None);
        assert_eq!(cmds[0], StepCommand::Stop);
        assert_eq!(cmds[1], StepCommand::Stop); // below the 20 steps/s minimum
        for (i, &r) in rates.iter().enumerate().skip(2) {
            let got = achieved_rate_mhz(&cmds[i], &cfg);
            let want = i64::from(r) * 1000;
            assert!((got - want).abs() * 2_000 <= want.abs(), "axis {i}: {got} vs {want}"); // <= 0.05 %
            let StepCommand::Run(t) = cmds[i] else { panic!() };
            assert_eq!(t.dir == Direction::Positive, r > 0);
        }
    }

    #[test]
    fn act_is_all_or_nothing() {
        let cfg = StepPlan::DEFAULT;
        let (cmds, err) = act(&[1000, 1000, 1000, 300_000, 1000, 1000], &cfg);
        assert_eq!(err, Some(3));
        assert!(cmds.iter().all(|c| *c == StepCommand::Stop));
        let (cmds, err) = act(&[i32::MIN, 0, 0, 0, 0, 0], &cfg);
        assert_eq!(err, Some(0));
        assert!(cmds.iter().all(|c| *c == StepCommand::Stop));
    }

    #[test]
    fn kernel_max_rates_fit_the_step_generator() {
        // Every joint's max velocity, in steps/s, must be programmable.
        for j in PAROL6.joints.iter() {
            let max = (f64::from(j.max_velocity) * j.steps_per_rad()).ceil() as i32;
            let (_, err) = act(&[max, -max, 0, 0, 0, 0], &StepPlan::DEFAULT);
            assert_eq!(err, None, "{max}");
        }
    }

    #[test]
    fn cycles_to_us_is_floor() {
        assert_eq!(cycles_to_us(0), 0);
        assert_eq!(cycles_to_us(599), 0);
        assert_eq!(cycles_to_us(600), 1);
        assert_eq!(cycles_to_us(600_000), 1000);
        assert_eq!(cycles_to_us(u32::MAX), 7_158_278);
    }

    #[test]
    fn the_ram_fault_line_is_the_kernel_event_line() {
        let mut line = protocol::Line::new();
        let e = kernel::Event::Fault(kernel::FaultReason::Hardware(HardwareFault::SelfTest(code::RAM)));
        protocol::report::event_line(&mut line, &e).unwrap();
        assert_eq!(line.as_str(), RAM_FAULT_LINE);
    }

    #[test]
    fn boot_fault_priorities() {
        assert_eq!(boot_fault(0, false, 0), None);
        assert_eq!(boot_fault(PANIC_MARKER, true, 0x3F), Some(HardwareFault::SelfTest(code::PREVIOUS_PANIC)));
        assert_eq!(boot_fault(1, true, 0x3F), Some(HardwareFault::SelfTest(code::WATCHDOG_RESET)));
        assert_eq!(boot_fault(0, false, 0b10_0001), Some(HardwareFault::SelfTest(0x40 | 0b10_0001)));
        assert_eq!(boot_fault(0, false, 0xC0), None);
    }

    #[test]
    fn boot_fault_log_codes() {
        assert_eq!(boot_fault_log_code(None), 0);
        assert_eq!(boot_fault_log_code(boot_fault(PANIC_MARKER, false, 0)), 0x80);
        assert_eq!(boot_fault_log_code(boot_fault(0, true, 0)), 0x81);
        assert_eq!(boot_fault_log_code(boot_fault(0, false, 0b101)), 0x45);
        assert_eq!(boot_fault_log_code(Some(HardwareFault::Driver { axis: 3 })), 0xF3);
        assert_eq!(boot_fault_log_code(Some(HardwareFault::TickOverrun)), 0xFF);
        let diag = HardwareFault::DriverDiagnostic { axis: 2, cause: kernel::DriverCause::OpenLoad };
        assert_eq!(boot_fault_log_code(Some(diag)), 0xE2);
    }

    /// Each TMC5160 finding has its own cause in the kernel (and so its own
    /// token on the wire).
    #[test]
    fn every_driver_finding_maps_to_its_own_cause() {
        use hal_imxrt::pure::tmc5160::Finding;
        let all = [
            Finding::Missing,
            Finding::WrongVersion,
            Finding::Reset,
            Finding::DriverError,
            Finding::ChargePump,
            Finding::Overtemperature,
            Finding::ShortToGround,
            Finding::ShortToSupply,
            Finding::OpenLoad,
        ];
        let names: std::collections::BTreeSet<&str> =
            all.iter().map(|&f| protocol::report::driver_cause_name(driver_cause(f))).collect();
        assert_eq!(names.len(), all.len(), "{names:?}");
        assert_eq!(driver_cause(Finding::Overtemperature), kernel::DriverCause::Overtemperature);
        assert_eq!(driver_cause(Finding::Missing), kernel::DriverCause::Missing);
    }

    #[test]
    fn self_test_mask() {
        // Every axis read a count in the last sample.
        let mut r = [0b1u8; AXES];
        assert_eq!(encoder_self_test(&r), 0);
        // J2: two lost samples after a count: passes (within the window).
        r[1] = 0b100;
        // J1 and J6: nothing in the last three samples (older counts do
        // not count).
        r[0] = 0;
        r[5] = 0b1000;
        assert_eq!(encoder_self_test(&r), 0b10_0001);
    }
}
