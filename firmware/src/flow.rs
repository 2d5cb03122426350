//! Program-flow monitoring of the control tick: the watchdog is refreshed
//! only after a tick in which every step ran exactly once and in order.
//!
//! Each step of [`crate::root::Controller::tick`] marks itself with
//! [`FlowMonitor::mark`] where its work is done; the tick asks
//! [`FlowMonitor::end_of_tick`] before it refreshes the watchdog. A step
//! skipped, repeated or run out of order breaks the sequence; a broken
//! sequence is latched (until the chip resets), so the tick never refreshes
//! the watchdog again and the RTWDOG resets the chip within its timeout.
//! Latching matters: without it one bad tick would only delay one refresh,
//! which the 20 ms timeout absorbs.
//!
//! The check is a step counter rather than an accumulated hash signature:
//! it has no aliasing (every wrong sequence is caught, not all but a
//! fraction 2^-32 of them) and costs a compare and an increment per step.

/// The steps of one control tick, in the order they must run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Step {
    /// Encoder capture snapshots read.
    Sense = 0,
    /// Frame decode and tracking, limit debounce: the sensed state.
    Estimate = 1,
    /// At most one host command taken and turned into a request.
    Request = 2,
    /// The kernel's supervised tick (modes, limits, homing).
    Supervise = 3,
    /// The kernel's step rates mapped to step commands (all six or none).
    Act = 4,
    /// The step commands programmed on the board.
    StepCommands = 5,
    /// Events and status pushed to the telemetry queue.
    Telemetry = 6,
}

/// Number of steps in a complete tick.
pub const STEPS: u8 = 7;

/// The latched "sequence broken" state (never a step index).
const BROKEN: u8 = u8::MAX;

const _: () = assert!(Step::Telemetry as u8 + 1 == STEPS && STEPS < BROKEN);

/// The per-tick sequence check (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FlowMonitor {
    /// The step expected next, or [`BROKEN`].
    next: u8,
}

impl Default for FlowMonitor {
    fn default() -> Self {
        Self::new()
    }
}

impl FlowMonitor {
    /// At the start of a tick, nothing broken.
    pub const fn new() -> Self {
        Self { next: 0 }
    }

    /// Step `s` has run. Anything but the expected next step breaks the
    /// sequence for good.
    #[inline(always)]
    pub fn mark(&mut self, s: Step) {
        // no overflow: `next` equals a step index here, below `STEPS`
        self.next = if self.next == s as u8 { self.next.wrapping_add(1) } else { BROKEN };
    }

    /// End of a tick: `true` (refresh the watchdog) only if every step ran
    /// once and in order since the previous call and nothing was ever
    /// broken; starts the next tick's sequence. `false` is latched.
    #[inline(always)]
    pub fn end_of_tick(&mut self) -> bool {
        let ok = self.next == STEPS;
        self.next = if ok { 0 } else { BROKEN };
        ok
    }

    /// The sequence has been broken (latched).
    pub fn broken(&self) -> bool {
        self.next == BROKEN
    }
}

#[cfg(test)]
#[allow(clippy::arithmetic_side_effects)]
mod tests {
    use super::*;

    const ALL: [Step; STEPS as usize] =
        [Step::Sense, Step::Estimate, Step::Request, Step::Supervise, Step::Act, Step::StepCommands, Step::Telemetry];

    fn run(f: &mut FlowMonitor, steps: &[Step]) -> bool {
        for &s in steps {
            f.mark(s);
        }
        f.end_of_tick()
    }

    #[test]
    fn complete_ticks_refresh() {
        let mut f = FlowMonitor::new();
        for _ in 0..3 {
            assert!(run(&mut f, &ALL));
        }
        assert!(!f.broken());
    }

    #[test]
    fn every_skip_repeat_and_swap_is_caught_and_latched() {
        // exhaustive over single skips, single repeats and adjacent swaps
        for (i, &step) in ALL.iter().enumerate() {
            let mut skipped: Vec<Step> = ALL.to_vec();
            skipped.remove(i);
            let mut repeated: Vec<Step> = ALL.to_vec();
            repeated.insert(i, step);
            let mut cases = vec![skipped, repeated];
            if i + 1 < ALL.len() {
                let mut swapped = ALL.to_vec();
                swapped.swap(i, i + 1);
                cases.push(swapped);
            }
            for case in cases {
                let mut f = FlowMonitor::new();
                assert!(run(&mut f, &ALL));
                assert!(!run(&mut f, &case), "{case:?} accepted");
                assert!(f.broken());
                // latched: later complete ticks do not refresh
                assert!(!run(&mut f, &ALL));
                assert!(!run(&mut f, &ALL));
            }
        }
    }

    #[test]
    fn an_empty_tick_is_caught() {
        let mut f = FlowMonitor::new();
        assert!(!f.end_of_tick());
        assert!(!run(&mut f, &ALL));
    }
}
