//! The MT6816 magnetic encoder's PWM output: the facts the decoder, the
//! simulator's sensor model and the firmware's boot code share (the
//! register-level twin keeps its own, independent copies on purpose).
//!
//! One frame is [`FRAME_CLOCKS`] PWM clocks of [`PWM_CLOCK_NS`] (1029.75 us,
//! 971.1 Hz at the nominal clock; the chip's clock is an on-chip oscillator,
//! so the decoder measures each sensor's own frame period). The output is
//! HIGH for [`START_CLOCKS`] clocks plus `count` (0..=[`MAX_COUNT`]) clocks,
//! then LOW to the end of the frame, so the duty is `(16 + count) / 4119`,
//! in `[16/4119, 4111/4119]`, and `angle = count / COUNTS_PER_REV * 2 pi`.

use super::clock::CPU_HZ;

/// PWM clocks per frame.
pub const FRAME_CLOCKS: u32 = 4119;
/// HIGH start clocks preceding the count.
pub const START_CLOCKS: u32 = 16;
/// Largest 12-bit count.
pub const MAX_COUNT: u16 = 4095;
/// Counts per revolution (12 bits).
pub const COUNTS_PER_REV: u32 = 4096;
/// Nominal PWM clock period, ns.
pub const PWM_CLOCK_NS: u32 = 250;
/// Nominal PWM clock period in CPU cycles (150 at 600 MHz).
pub const CYCLES_PER_PWM_CLOCK: u32 = CPU_HZ / (1_000_000_000 / PWM_CLOCK_NS);
/// Nominal frame period in CPU cycles (617 850).
pub const NOMINAL_FRAME_CYCLES: u32 = FRAME_CLOCKS * CYCLES_PER_PWM_CLOCK;

// The PWM clock is a whole number of CPU cycles, and the count fills the
// frame but for the start clocks and at least one LOW clock.
const _: () =
    assert!(CPU_HZ.is_multiple_of(1_000_000_000 / PWM_CLOCK_NS) && 1_000_000_000u32.is_multiple_of(PWM_CLOCK_NS));
const _: () = assert!(CYCLES_PER_PWM_CLOCK == 150 && NOMINAL_FRAME_CYCLES == 617_850);
const _: () = assert!(COUNTS_PER_REV == MAX_COUNT as u32 + 1);
const _: () = assert!(START_CLOCKS + (MAX_COUNT as u32) < FRAME_CLOCKS);
