//! Limit-switch debounce: pull-up inputs, switch closes to ground (active
//! low); a new level is accepted after [`SAMPLES`] consecutive equal samples,
//! like the C++ firmware. Until the first level is confirmed the state is
//! [`LimitState::Unknown`], which the kernel must treat as "not safe to move".

/// Consecutive equal samples needed to accept a level.
pub const SAMPLES: u8 = 3;

/// Debounced switch state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LimitState {
    /// Not yet confirmed (start-up).
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
    candidate_high: bool,
    run: u8,
}

impl Default for Debounce {
    fn default() -> Self {
        Self::new()
    }
}

impl Debounce {
    /// Start in `Unknown`.
    pub const fn new() -> Self {
        Self { state: LimitState::Unknown, candidate_high: true, run: 0 }
    }

    /// Current debounced state.
    pub const fn state(&self) -> LimitState {
        self.state
    }

    /// Feed one raw sample (`true` = pin high = released); returns the state.
    pub fn sample(&mut self, pin_high: bool) -> LimitState {
        if self.run == 0 || pin_high != self.candidate_high {
            self.candidate_high = pin_high;
            self.run = 1;
        } else {
            self.run = self.run.saturating_add(1);
        }
        if self.run >= SAMPLES {
            self.state = if pin_high { LimitState::Released } else { LimitState::Pressed };
        }
        self.state
    }
}

// Test code is built with overflow checks on: an overflow fails the test.
#[cfg(test)]
#[allow(clippy::arithmetic_side_effects)]
mod tests {
    use super::*;

    #[test]
    fn starts_unknown_and_needs_three() {
        let mut d = Debounce::new();
        assert_eq!(d.sample(true), LimitState::Unknown);
        assert_eq!(d.sample(true), LimitState::Unknown);
        assert_eq!(d.sample(true), LimitState::Released);
    }

    #[test]
    fn press_needs_three_lows() {
        let mut d = Debounce::new();
        for _ in 0..3 {
            d.sample(true);
        }
        assert_eq!(d.sample(false), LimitState::Released);
        assert_eq!(d.sample(false), LimitState::Released);
        assert_eq!(d.sample(false), LimitState::Pressed);
        assert_eq!(d.sample(false), LimitState::Pressed);
    }

    #[test]
    fn bounce_is_ignored() {
        let mut d = Debounce::new();
        for _ in 0..3 {
            d.sample(true);
        }
        for s in [false, true, false, false, true, false, true] {
            assert_eq!(d.sample(s), LimitState::Released);
        }
        let mut d = Debounce::new();
        for _ in 0..3 {
            d.sample(false);
        }
        for s in [true, true, false, true, false, true, true] {
            assert_eq!(d.sample(s), LimitState::Pressed);
        }
        assert_eq!(d.sample(true), LimitState::Released);
    }

    #[test]
    fn exhaustive_short_sequences_match_reference() {
        // every sequence of 10 samples: state == level of the last run of >= 3
        for bits in 0u32..1024 {
            let mut d = Debounce::new();
            let mut want = LimitState::Unknown;
            let mut hist: [bool; 10] = [false; 10];
            for i in 0..10 {
                let s = bits & (1 << i) != 0;
                hist[i] = s;
                if i >= 2 && hist[i] == hist[i - 1] && hist[i] == hist[i - 2] {
                    want = if s { LimitState::Released } else { LimitState::Pressed };
                }
                assert_eq!(d.sample(s), want, "bits {bits:010b} at {i}");
            }
        }
    }
}
