//! Limit-switch debounce: pull-up inputs, switch closes to ground (active
//! low), sampled once per tick. Fail-safe: **pressed wins**.
//!
//! - A press is recognised as soon as [`PRESS_OF_WINDOW`] of the last
//!   [`WINDOW`] samples read closed (2 of 3).
//! - A release needs [`RELEASE_RUN`] consecutive open samples (3).
//! - Until the first level is recognised the state is
//!   [`LimitState::Unknown`], which the firmware treats as pressed.
//!
//! Worst case (checked exhaustively below over every 12-sample pattern):
//! a contact that reads closed in at least half of any [`WORST_CASE_WINDOW`]
//! consecutive samples (3 of 6) is recognised as pressed at one of them,
//! within 6 ms at the 1 kHz tick: three closed samples among six cannot all
//! be three or more apart, so two of them fall inside one window of three.
//! A chattering contact that opens one sample in three is therefore seen
//! (and stays pressed: it never opens three samples in a row), while a
//! single closed sample is not a press.
//!
//! Hand-written rather than taken from a crate: the debounce crates on
//! crates.io (`debouncr`, `unflappable`, `bounced`, `timed-debouncer`) wait
//! for a run of equal samples or integrate symmetrically (the rules that
//! hide a chattering switch); none has this asymmetric rule.

/// Samples in the press window.
pub const WINDOW: u32 = 3;
/// Closed samples in the press window that make a press.
pub const PRESS_OF_WINDOW: u32 = 2;
/// Consecutive open samples needed for a release.
pub const RELEASE_RUN: u8 = 3;
/// The window of the worst case: any contact closed in at least half of
/// this many consecutive samples is recognised as pressed within them.
pub const WORST_CASE_WINDOW: u32 = 6;

/// Mask of the press window's bits in the history.
const WINDOW_MASK: u8 = 0b111;

// The configuration, checked at compile time: the mask holds the window,
// a press needs at least two closed samples (one is a bounce), a release
// at least one open sample.
const _: () = assert!(WINDOW_MASK.count_ones() == WINDOW && WINDOW_MASK.trailing_ones() == WINDOW);
const _: () = assert!(PRESS_OF_WINDOW >= 2 && PRESS_OF_WINDOW <= WINDOW);
const _: () = assert!(RELEASE_RUN >= 1);

/// Debounced switch state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LimitState {
    /// Not yet recognised (start-up).
    Unknown,
    /// Input high (pulled up): switch open.
    Released,
    /// Input low: switch closed.
    Pressed,
}

/// One debounced input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Debounce {
    state: LimitState,
    /// The last [`WINDOW`] samples, a set bit per closed one (bit 0: the
    /// newest).
    closed: u8,
    /// Consecutive open samples, saturating at [`RELEASE_RUN`].
    open_run: u8,
}

impl Default for Debounce {
    fn default() -> Self {
        Self::new()
    }
}

impl Debounce {
    /// Start in `Unknown`.
    pub const fn new() -> Self {
        Self { state: LimitState::Unknown, closed: 0, open_run: 0 }
    }

    /// Current debounced state.
    pub const fn state(&self) -> LimitState {
        self.state
    }

    /// Feed one raw sample (`true` = pin high = released); returns the state.
    pub fn sample(&mut self, pin_high: bool) -> LimitState {
        let closed = !pin_high;
        self.closed = (self.closed.wrapping_shl(1) | u8::from(closed)) & WINDOW_MASK;
        self.open_run = if closed { 0 } else { self.open_run.saturating_add(1).min(RELEASE_RUN) };
        if self.closed.count_ones() >= PRESS_OF_WINDOW {
            self.state = LimitState::Pressed;
        } else if self.open_run >= RELEASE_RUN {
            self.state = LimitState::Released;
        }
        self.state
    }
}

// Test code is built with overflow checks on: an overflow fails the test.
#[cfg(test)]
#[allow(clippy::arithmetic_side_effects)]
mod tests {
    use super::*;

    fn feed(d: &mut Debounce, closed: &[bool]) -> LimitState {
        let mut s = d.state();
        for c in closed {
            s = d.sample(!c);
        }
        s
    }

    #[test]
    fn starts_unknown_and_needs_three_open_to_release() {
        let mut d = Debounce::new();
        assert_eq!(d.sample(true), LimitState::Unknown);
        assert_eq!(d.sample(true), LimitState::Unknown);
        assert_eq!(d.sample(true), LimitState::Released);
    }

    #[test]
    fn press_needs_two_closed_of_three() {
        let mut d = Debounce::new();
        feed(&mut d, &[false; 3]);
        assert_eq!(d.sample(false), LimitState::Released, "one closed sample is no press");
        assert_eq!(d.sample(false), LimitState::Pressed);
        let mut d = Debounce::new();
        feed(&mut d, &[false; 3]);
        assert_eq!(feed(&mut d, &[true, false]), LimitState::Released);
        assert_eq!(d.sample(false), LimitState::Pressed, "closed, open, closed is a press");
    }

    #[test]
    fn a_single_closed_sample_never_presses() {
        let mut d = Debounce::new();
        feed(&mut d, &[false; 3]);
        for _ in 0..20 {
            assert_eq!(feed(&mut d, &[true, false, false]), LimitState::Released);
        }
    }

    #[test]
    fn chatter_closed_two_of_three_is_pressed_and_stays() {
        // Closed 2 ms, open 1 ms: recognised within 3 samples, never released.
        let mut d = Debounce::new();
        feed(&mut d, &[false; 3]);
        assert_eq!(feed(&mut d, &[true, true]), LimitState::Pressed);
        for _ in 0..134 {
            assert_eq!(feed(&mut d, &[false, true, true]), LimitState::Pressed);
        }
        assert_eq!(feed(&mut d, &[false, false]), LimitState::Pressed);
        assert_eq!(d.sample(true), LimitState::Released, "three open samples release");
    }

    /// The stated worst case, exhaustively over every pattern of 12 samples
    /// after a released start: wherever some 6 consecutive samples hold 3 or
    /// more closed ones, the state is Pressed by the last of them; and the
    /// state is exactly the reference rule (pressed wins; 3 open releases).
    #[test]
    fn exhaustive_worst_case_and_reference() {
        const N: usize = 12;
        for bits in 0u32..(1 << N) {
            let mut d = Debounce::new();
            feed(&mut d, &[false; 3]);
            let mut want = LimitState::Released;
            let mut hist = [false; N];
            let mut pressed_at = [false; N];
            for i in 0..N {
                let c = bits & (1 << i) != 0;
                hist[i] = c;
                let lo = i.saturating_sub(2);
                let closed3 = hist[lo..=i].iter().filter(|x| **x).count();
                if closed3 >= 2 {
                    want = LimitState::Pressed;
                } else if i >= 2 && !hist[i] && !hist[i - 1] && !hist[i - 2] {
                    want = LimitState::Released;
                }
                let got = d.sample(!c);
                assert_eq!(got, want, "bits {bits:012b} at {i}");
                pressed_at[i] = got == LimitState::Pressed;
                if i + 1 >= WORST_CASE_WINDOW as usize {
                    let w = &hist[i + 1 - WORST_CASE_WINDOW as usize..=i];
                    let closed = w.iter().filter(|x| **x).count();
                    if 2 * closed >= w.len() {
                        let seen = pressed_at[i + 1 - WORST_CASE_WINDOW as usize..=i].iter().any(|p| *p);
                        assert!(seen, "bits {bits:012b}: closed {closed} of 6 ending at {i} not recognised");
                    }
                }
            }
        }
    }
}
