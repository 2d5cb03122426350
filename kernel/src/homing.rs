//! Homing of one axis: fast seek, back-off, slow seek, zero, release,
//! settle.
//!
//! The sequencing across axes (J6; then J5, J4; then J1, J2, J3) is in the
//! kernel; this is the per-axis state machine. It moves toward one of three
//! speeds (fast, slow, zero) in a known direction, changing its velocity by
//! at most the joint's acceleration per tick (the stop at the switch in the
//! seeks is immediate); it reports the tick at which the zero must be taken
//! from the real encoder reading, and it bounds the travel of every phase
//! (a dead switch or a reversed motor faults before the hard stop).

use crate::scalar::Scalar;

/// Phase of one axis's homing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Phase {
    /// Not part of the current homing run.
    Idle,
    /// Part of the run, waiting for the axes it depends on.
    Waiting,
    /// Moving toward the switch at the fast speed.
    FastSeek,
    /// Moving away until the switch releases, then the back-off distance.
    BackOff,
    /// Moving toward the switch at the slow speed.
    SlowSeek,
    /// Zero taken; moving off the switch by the back-off distance.
    Release,
    /// Decelerating to rest, then resting for the settle time.
    Settle,
    /// Finished for this run.
    Done,
}

impl Phase {
    /// True in the phases where the axis moves.
    pub const fn is_moving(self) -> bool {
        matches!(self, Phase::FastSeek | Phase::BackOff | Phase::SlowSeek | Phase::Release | Phase::Settle)
    }
}

/// Homing parameters of one axis, in the kernel's scalar type.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HomingParams<S> {
    /// Fast seek velocity, signed toward the switch.
    pub fast_toward: S,
    /// Slow seek velocity, signed toward the switch.
    pub slow_toward: S,
    /// Back-off distance past the release point (> 0).
    pub backoff: S,
    /// Ticks allowed for the whole sequence of this axis.
    pub timeout_ticks: u32,
    /// Largest velocity change per tick (rad/s).
    pub dv: S,
    /// Largest travel of the fast seek (rad).
    pub max_travel: S,
    /// Largest travel of any other phase (rad).
    pub phase_travel: S,
    /// Ticks at rest before the axis is done.
    pub settle_ticks: u32,
}

/// What one homing tick asks of the kernel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HomingStep<S> {
    /// Velocity to apply this tick.
    pub velocity: S,
    /// Take the zero from the encoder reading of this tick.
    pub capture_zero: bool,
    /// The axis ran out of time in this phase.
    pub timed_out: Option<Phase>,
    /// The axis travelled farther than allowed in this phase.
    pub too_far: Option<Phase>,
}

/// One axis's homing state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisHoming<S> {
    phase: Phase,
    /// Position where the switch released (back-off and release phases).
    anchor: Option<S>,
    ticks: u32,
    /// Velocity of the last tick (rad/s).
    vel: S,
    /// Position where the current phase started (travel bound).
    origin: S,
    /// Ticks at rest in Settle.
    rest: u32,
    /// A tighter fast-seek travel bound for this run (a joint homed
    /// before), if any.
    fast_bound: Option<S>,
}

/// Hashes what decides this axis's future (for model checkers, through
/// `Kernel`'s `Hash`): the phase and the velocity always; the run's record
/// (release point, tick count, phase origin, ticks at rest, fast-seek
/// bound) only in the phases that read it. In `Idle` and `Done` nothing
/// outside the record depends on it before [`AxisHoming::reset`]
/// overwrites it: `step` returns at once with a zero velocity (and zeroes
/// `vel`), `start` acts only in `Waiting`, `limit_travel` only writes the
/// record and `shift` only moves it, and the fields are private to this
/// module. Two axes equal but for the record in those phases therefore
/// behave alike from then on, so merging them is exact
/// (`tests::idle_and_done_forget_the_run_record`); every field counts in
/// the other phases (`tests::every_field_counts_while_in_a_run`).
impl<S: Scalar + core::hash::Hash> core::hash::Hash for AxisHoming<S> {
    fn hash<H: core::hash::Hasher>(&self, h: &mut H) {
        self.phase.hash(h);
        self.vel.hash(h);
        if !matches!(self.phase, Phase::Idle | Phase::Done) {
            (self.anchor, self.ticks, self.origin, self.rest, self.fast_bound).hash(h);
        }
    }
}

impl<S: Scalar> Default for AxisHoming<S> {
    fn default() -> Self {
        AxisHoming {
            phase: Phase::Idle,
            anchor: None,
            ticks: 0,
            vel: S::ZERO,
            origin: S::ZERO,
            rest: 0,
            fast_bound: None,
        }
    }
}

impl<S: Scalar> AxisHoming<S> {
    /// Current phase.
    pub fn phase(&self) -> Phase {
        self.phase
    }
    /// Puts the axis in (`true`) or out of a new run.
    pub fn reset(&mut self, in_run: bool) {
        *self = AxisHoming { phase: if in_run { Phase::Waiting } else { Phase::Idle }, ..AxisHoming::default() };
    }
    /// Starts moving if waiting (the kernel calls this when the axis's
    /// group is reached); `x` is the estimated position.
    pub fn start(&mut self, x: S) {
        if self.phase == Phase::Waiting {
            self.enter(Phase::FastSeek, x);
        }
    }
    /// Bounds this run's fast seek to `bound` (rad) if that is tighter than
    /// the configured bound.
    pub fn limit_travel(&mut self, bound: S) {
        self.fast_bound = Some(bound);
    }
    /// The velocity of the last tick.
    pub fn velocity(&self) -> S {
        self.vel
    }
    fn enter(&mut self, phase: Phase, x: S) {
        self.phase = phase;
        self.anchor = None;
        self.origin = x;
    }
    /// Accelerates toward `want` by at most `dv`.
    fn ramp(&mut self, want: S, dv: S) -> S {
        self.vel = crate::ramp::toward(self.vel, want, dv);
        self.vel
    }

    /// Moves away from the switch until it has released and the axis is
    /// `backoff` past the release point; returns true when finished.
    fn away(&mut self, switch: bool, x: S, backoff: S) -> bool {
        match (switch, self.anchor) {
            (true, _) => {
                self.anchor = None;
                false
            }
            (false, None) => {
                self.anchor = Some(x);
                false
            }
            (false, Some(a)) => x.minus(a).abs() >= backoff,
        }
    }

    /// One tick. `switch` is this axis's debounced limit input, `x` its
    /// estimated position.
    pub fn step(&mut self, switch: bool, x: S, p: &HomingParams<S>) -> HomingStep<S> {
        let mut out = HomingStep { velocity: S::ZERO, capture_zero: false, timed_out: None, too_far: None };
        if !self.phase.is_moving() {
            self.vel = S::ZERO;
            return out;
        }
        self.ticks = self.ticks.saturating_add(1);
        if self.ticks > p.timeout_ticks {
            out.timed_out = Some(self.phase);
            self.vel = S::ZERO;
            return out;
        }
        let fast = self.fast_bound.map_or(p.max_travel, |b| b.min(p.max_travel));
        let bound = if self.phase == Phase::FastSeek { fast } else { p.phase_travel };
        if x.minus(self.origin).abs() > bound {
            out.too_far = Some(self.phase);
            self.vel = S::ZERO;
            return out;
        }
        out.velocity = match self.phase {
            Phase::FastSeek if switch => {
                // Stop at the switch (immediate); reverse from the next tick.
                self.enter(Phase::BackOff, x);
                self.vel = S::ZERO;
                S::ZERO
            }
            Phase::FastSeek => self.ramp(p.fast_toward, p.dv),
            Phase::BackOff => {
                if self.away(switch, x, p.backoff) {
                    self.enter(Phase::SlowSeek, x);
                    self.ramp(p.slow_toward, p.dv)
                } else {
                    self.ramp(p.fast_toward.neg(), p.dv)
                }
            }
            Phase::SlowSeek if switch => {
                out.capture_zero = true;
                self.enter(Phase::Release, x);
                self.vel = S::ZERO;
                S::ZERO
            }
            Phase::SlowSeek => self.ramp(p.slow_toward, p.dv),
            Phase::Release => {
                if self.away(switch, x, p.backoff) {
                    self.enter(Phase::Settle, x);
                    self.ramp(S::ZERO, p.dv)
                } else {
                    self.ramp(p.fast_toward.neg(), p.dv)
                }
            }
            Phase::Settle => {
                let v = self.ramp(S::ZERO, p.dv);
                if v == S::ZERO {
                    self.rest = self.rest.saturating_add(1);
                    if self.rest >= p.settle_ticks {
                        self.phase = Phase::Done;
                    }
                }
                v
            }
            Phase::Idle | Phase::Waiting | Phase::Done => S::ZERO,
        };
        out
    }

    /// Shifts the positions this axis remembers by `d` (the zero was taken:
    /// the estimate moved by `d`).
    pub fn shift(&mut self, d: S) {
        self.origin = self.origin.plus(d);
        self.anchor = self.anchor.map(|a| a.plus(d));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A one-axis plant: the switch is pressed at x <= -1.0 (negative seek).
    fn simulate(start: f32) -> (Vec<Phase>, u32, f32) {
        let p = params(-0.5, -0.05, 20_000);
        let mut h = AxisHoming::default();
        h.reset(true);
        h.start(start);
        let mut x = start;
        let mut phases = vec![h.phase()];
        let mut captured = 0;
        let mut zero_at = f32::NAN;
        for _ in 0..20_000 {
            let s = h.step(x <= -1.0, x, &p);
            assert!(s.timed_out.is_none());
            if s.capture_zero {
                captured += 1;
                zero_at = x;
            }
            x += s.velocity * 0.001;
            if phases.last() != Some(&h.phase()) {
                phases.push(h.phase());
            }
            if h.phase() == Phase::Done {
                break;
            }
        }
        (phases, captured, zero_at)
    }

    #[test]
    fn full_sequence_in_order_with_one_zero_capture() {
        let (phases, captured, zero_at) = simulate(0.3);
        use Phase::*;
        assert_eq!(phases, vec![FastSeek, BackOff, SlowSeek, Release, Settle, Done]);
        assert_eq!(captured, 1);
        assert!((zero_at + 1.0).abs() < 1e-3, "{zero_at}");
    }

    #[test]
    fn starting_on_the_switch_backs_off_first() {
        let (phases, captured, _) = simulate(-1.01);
        use Phase::*;
        assert_eq!(phases, vec![FastSeek, BackOff, SlowSeek, Release, Settle, Done]);
        assert_eq!(captured, 1);
    }

    fn params(fast: f32, slow: f32, timeout_ticks: u32) -> HomingParams<f32> {
        HomingParams {
            fast_toward: fast,
            slow_toward: slow,
            backoff: 0.05,
            timeout_ticks,
            dv: 0.06,
            max_travel: 3.0,
            phase_travel: 0.3,
            settle_ticks: 50,
        }
    }

    #[test]
    fn times_out_when_the_switch_never_comes() {
        let p = params(1.0, 0.1, 10);
        let mut h = AxisHoming::default();
        h.reset(true);
        h.start(0.0);
        for _ in 0..10 {
            assert!(h.step(false, 0.0, &p).velocity > 0.0);
        }
        let s = h.step(false, 0.0, &p);
        assert_eq!(s.timed_out, Some(Phase::FastSeek));
        assert_eq!(s.velocity, 0.0);
    }

    #[test]
    fn the_seek_accelerates_gradually_and_its_travel_is_bounded() {
        let p = params(2.0, 0.1, 100_000);
        let mut h = AxisHoming::default();
        h.reset(true);
        h.start(0.0);
        let (mut x, mut prev) = (0.0f32, 0.0f32);
        for n in 0.. {
            let s = h.step(false, x, &p);
            if let Some(phase) = s.too_far {
                // A fault: the kernel zeroes every output at once.
                assert_eq!(phase, Phase::FastSeek);
                assert!(x > 3.0 && x < 3.01, "{x}");
                assert_eq!(s.velocity, 0.0);
                break;
            }
            assert!((s.velocity - prev).abs() <= 0.0601, "{prev} -> {}", s.velocity);
            assert!(n < 10_000);
            prev = s.velocity;
            x += s.velocity * 0.001;
        }
    }

    use crate::Fx;
    use core::hash::{Hash, Hasher};
    use std::hash::DefaultHasher;

    fn h(a: &AxisHoming<Fx>) -> u64 {
        let mut s = DefaultHasher::new();
        a.hash(&mut s);
        s.finish()
    }

    fn fx(x: f32) -> Fx {
        Fx::from_f32(x)
    }

    /// The run records the tests set in place of the default: every field
    /// that `Hash` leaves out in `Idle` and `Done`, at values a run leaves.
    fn records(phase: Phase) -> [AxisHoming<Fx>; 4] {
        let base = AxisHoming { phase, ..AxisHoming::default() };
        [
            base,
            AxisHoming {
                anchor: Some(fx(0.3)),
                ticks: 7,
                origin: fx(-1.25),
                rest: 2,
                fast_bound: Some(fx(0.5)),
                ..base
            },
            AxisHoming { anchor: None, ticks: 1, origin: fx(2.0), rest: 0, fast_bound: None, ..base },
            AxisHoming {
                anchor: Some(fx(-2.0)),
                ticks: u32::MAX,
                origin: fx(0.0),
                rest: 50,
                fast_bound: Some(fx(0.01)),
                ..base
            },
        ]
    }

    /// One operation of the axis's interface, and what it returned.
    #[derive(Debug, PartialEq)]
    enum Seen {
        Step(HomingStep<Fx>),
        Phase(Phase),
        Velocity(Fx),
        Nothing,
    }

    const OPS: usize = 10;

    fn apply(a: &mut AxisHoming<Fx>, op: usize, p: &HomingParams<Fx>) -> Seen {
        match op {
            0 => Seen::Step(a.step(false, fx(0.2), p)),
            1 => Seen::Step(a.step(true, fx(0.2), p)),
            2 => Seen::Step(a.step(false, fx(-3.0), p)),
            3 => {
                a.start(fx(0.4));
                Seen::Nothing
            }
            4 => {
                a.limit_travel(fx(0.25));
                Seen::Nothing
            }
            5 => {
                a.shift(fx(0.125));
                Seen::Nothing
            }
            6 => {
                a.reset(true);
                Seen::Nothing
            }
            7 => {
                a.reset(false);
                Seen::Nothing
            }
            8 => Seen::Phase(a.phase()),
            _ => Seen::Velocity(a.velocity()),
        }
    }

    /// The merge `Hash` makes in `Idle` and `Done` is exact: from an axis
    /// with the default record and from one with any other record, every
    /// sequence of up to three operations of the axis's interface (each
    /// step with the switch released and pressed, near and far from the
    /// origin; start; a travel bound; a shift; both resets; the phase and
    /// velocity getters) returns the same values and leaves states that
    /// hash alike. Every sequence of the ten operations (1,110 per pair)
    /// for three records in each of the two phases.
    #[test]
    fn idle_and_done_forget_the_run_record() {
        let p = HomingParams {
            fast_toward: fx(-0.5),
            slow_toward: fx(-0.05),
            backoff: fx(0.05),
            timeout_ticks: 8,
            dv: fx(0.06),
            max_travel: fx(3.0),
            phase_travel: fx(0.3),
            settle_ticks: 2,
        };
        let mut pairs = 0;
        for phase in [Phase::Idle, Phase::Done] {
            let [base, others @ ..] = records(phase);
            for other in others {
                assert_eq!(h(&base), h(&other), "{phase:?}: the record is hashed");
                for len in 1..=3u32 {
                    for code in 0..OPS.pow(len) {
                        let (mut a, mut b) = (base, other);
                        let mut c = code;
                        for _ in 0..len {
                            let op = c % OPS;
                            c /= OPS;
                            assert_eq!(apply(&mut a, op, &p), apply(&mut b, op, &p), "{phase:?}, {other:?}, op {op}");
                            assert_eq!(h(&a), h(&b), "{phase:?}, {other:?}: differ after op {op}: {a:?} / {b:?}");
                        }
                        pairs += 1;
                    }
                }
            }
        }
        assert_eq!(pairs, 2 * 3 * (10 + 100 + 1000));
    }

    /// Outside `Idle` and `Done` the hash keeps every field: changing any
    /// one changes it (so the model merges no two axes in a run).
    #[test]
    fn every_field_counts_while_in_a_run() {
        use Phase::*;
        for phase in [Waiting, FastSeek, BackOff, SlowSeek, Release, Settle] {
            let a = AxisHoming { phase, ..AxisHoming::default() };
            let changed = [
                AxisHoming { anchor: Some(fx(0.0)), ..a },
                AxisHoming { ticks: 1, ..a },
                AxisHoming { vel: fx(0.01), ..a },
                AxisHoming { origin: fx(0.01), ..a },
                AxisHoming { rest: 1, ..a },
                AxisHoming { fast_bound: Some(fx(0.0)), ..a },
                AxisHoming { phase: Done, ..a },
            ];
            for b in changed {
                assert_ne!(h(&a), h(&b), "{b:?} hashes as {a:?}");
            }
        }
        // In Idle and Done the phase and the velocity still count.
        let done = AxisHoming { phase: Done, ..AxisHoming::<Fx>::default() };
        assert_ne!(h(&done), h(&AxisHoming { phase: Idle, ..done }));
        assert_ne!(h(&done), h(&AxisHoming { vel: fx(0.01), ..done }));
    }

    #[test]
    fn idle_and_waiting_axes_output_zero() {
        let p = params(1.0, 0.1, 10);
        let mut h = AxisHoming::default();
        assert_eq!(h.step(true, 0.0, &p).velocity, 0.0);
        h.reset(true);
        assert_eq!(h.step(false, 0.0, &p).velocity, 0.0);
    }
}
