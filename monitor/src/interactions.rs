//! Checks of where modes meet: whether the arm can always be brought back,
//! and whether an input that is mostly "pressed" is ever seen. The
//! per-requirement checks of [`crate::Monitor`] judge one mode at a time;
//! these judge what a sequence of modes leaves behind.
//!
//! | check | requirement |
//! |---|---|
//! | [`Interactions`]: after the arm has rested, an `<ENABLE>` in a latched state with no physical cause in the sensors (no hardware fault, every encoder read, no homed joint's switch pressed, every homed joint inside its limits) is accepted (no lock-up) | SR-6 |
//! | [`Interactions`]: a latch needs a physical cause: `FAULT LIMIT_SWITCH Jn` only with Jn's switch pressed and Jn homed, `FAULT POSITION_LIMIT Jn` only with Jn homed | SR-10, SR-19 |
//! | [`SwitchWatch`]: a switch that read closed in at least half of the last 6 raw samples entered the limit mask the kernel sensed within them | SR-10 |
//! | [`FrameWatch`]: no accepted frame is dropped (`QUEUE_FULL`) while the tick runs on time | SR-26 |
//!
//! The fourth interaction, a latch at the command timeout with every
//! set-point at rest on its target, is judged by [`crate::Monitor`]'s SR-29
//! check (it needs the set-point history kept there).

use crate::{bit, f, is_count, Sr, Violation, ALL};
use kernel::config::{ArmConfig, AXES};
use kernel::{Event, FaultReason, Reject, RequestKind, Scalar, Sense, State, TickOutput};

/// Ticks at rest (every output zero, every estimated speed below
/// [`REST_SPEED`], the switches unchanged) after which the arm counts as
/// rested: its estimates have settled.
pub const REST_TICKS: u32 = 300;
/// Estimated speed (rad/s) below which a joint counts as at rest.
pub const REST_SPEED: f64 = 0.05;
/// Distance (rad) inside the limits plus margin a homed joint must be for
/// its position to count as no cause (the kernel's and the monitor's
/// arithmetic may differ by rounding at the bound).
const LIMIT_SLACK: f64 = 1e-3;

/// Lock-up and latches without a cause (SR-6, SR-10, SR-19).
#[derive(Clone, Debug)]
pub struct Interactions {
    cfg: ArmConfig,
    prev_state: State,
    prev_homed: u8,
    prev_limits: u8,
    rest: u32,
}

fn violation<S: Scalar>(sr: Sr, what: &'static str, out: &TickOutput<S>) -> Violation {
    Violation { sr, axis: None, what, got: None, bound: None, tick: out.status.tick, state: out.status.state }
}

impl Interactions {
    /// Checks for a kernel created with `cfg` (no tick run yet).
    pub fn new(cfg: &ArmConfig) -> Self {
        Interactions { cfg: *cfg, prev_state: State::Boot, prev_homed: 0, prev_limits: 0, rest: 0 }
    }

    /// Ticks the arm has rested so far (see [`REST_TICKS`]).
    pub fn rested(&self) -> u32 {
        self.rest
    }

    /// Checks one tick: `sense` as handed to the kernel, `enable_sent`
    /// whether this tick's request was an `<ENABLE>`, `out` as returned.
    /// Call it for every tick, also after a violation.
    pub fn check<S: Scalar>(&mut self, sense: &Sense, enable_sent: bool, out: &TickOutput<S>) -> Result<(), Violation> {
        let r = self.check_inner(sense, enable_sent, out);
        let still = out.act.velocity.iter().all(|v| *v == S::ZERO)
            && out.status.velocity.iter().all(|v| f(*v).abs() < REST_SPEED)
            && sense.limits == self.prev_limits
            && sense.hardware_fault.is_none();
        self.rest = if still { self.rest.saturating_add(1) } else { 0 };
        self.prev_state = out.status.state;
        self.prev_homed = out.status.homed;
        self.prev_limits = sense.limits;
        r
    }

    /// A physical cause the operator must remove, in this tick's sensors
    /// and the estimates of the joints homed before it.
    fn physical_cause<S: Scalar>(&self, sense: &Sense, out: &TickOutput<S>) -> bool {
        let m = f64::from(self.cfg.position_margin);
        let outside = self.cfg.joints.iter().zip(out.status.position.iter()).enumerate().any(|(i, (j, x))| {
            let x = f(*x);
            self.prev_homed & bit(i) != 0
                && (x < f64::from(j.limit_min) - m + LIMIT_SLACK || x > f64::from(j.limit_max) + m - LIMIT_SLACK)
        });
        sense.hardware_fault.is_some()
            || !sense.encoders.iter().all(is_count)
            || sense.limits & self.prev_homed & ALL != 0
            || outside
    }

    fn check_inner<S: Scalar>(&self, sense: &Sense, enable_sent: bool, out: &TickOutput<S>) -> Result<(), Violation> {
        // SR-10, SR-19: a latch needs a physical cause. The joints homed
        // before this tick are the ones whose switch is a limit.
        for e in out.events.iter() {
            if let Event::Fault(reason) = e {
                let (axis, ok) = match *reason {
                    FaultReason::LimitSwitch { axis } => {
                        let b = bit(usize::from(axis));
                        (axis, sense.limits & b != 0 && self.prev_homed & b != 0)
                    }
                    FaultReason::PositionLimit { axis } => (axis, self.prev_homed & bit(usize::from(axis)) != 0),
                    _ => continue,
                };
                if !ok {
                    let what = match reason {
                        FaultReason::LimitSwitch { .. } => "a limit-switch fault on a joint not homed or not pressed",
                        _ => "a position-limit fault on a joint not homed",
                    };
                    return Err(violation(Sr::Sr10, what, out).on(usize::from(axis)));
                }
            }
        }
        // SR-6, no lock-up: once the arm has rested, an enable in a latched
        // state with no physical cause present is accepted.
        let latched = matches!(self.prev_state, State::Fault | State::SoftEstop);
        let accepted = out.events.iter().any(|e| matches!(e, Event::Enabled(_)));
        if !(enable_sent && latched && !accepted && self.rest >= REST_TICKS) || self.physical_cause(sense, out) {
            return Ok(());
        }
        // Judged for the causes a rested arm's sensors and homed estimates
        // decide; a sensor fault detected in this very tick (a glitch) is a
        // cause the sensors do not show.
        let refused = out.events.iter().find_map(|e| match e {
            Event::Rejected {
                request: RequestKind::Enable,
                reason:
                    Reject::CauseActive(
                        FaultReason::LimitSwitch { axis }
                        | FaultReason::PositionLimit { axis }
                        | FaultReason::Runaway { axis },
                    ),
            } => Some(*axis),
            _ => None,
        });
        if let Some(axis) = refused {
            let v = violation(Sr::Sr6, "enable refused at rest with no physical cause (lock-up)", out)
                .on(usize::from(axis))
                .got(f64::from(self.rest));
            return Err(v);
        }
        Ok(())
    }
}

/// Raw samples in the switch window.
pub const SWITCH_WINDOW: usize = 6;

/// A switch that read closed most of a window was seen (SR-10): fed every
/// tick with the raw closed levels (bit per joint, before debouncing) and
/// the limit mask the kernel sensed.
#[derive(Clone, Debug, Default)]
pub struct SwitchWatch {
    /// Per tick of the window (oldest first): raw closed bits, mask bits.
    raw: [u8; SWITCH_WINDOW],
    mask: [u8; SWITCH_WINDOW],
    ticks: u32,
}

impl SwitchWatch {
    /// An empty window.
    pub fn new() -> Self {
        Self::default()
    }

    /// One tick: `raw_closed` the switches that read closed, `sensed` the
    /// limit mask handed to the kernel, `tick` for the report.
    pub fn check(&mut self, raw_closed: u8, sensed: u8, tick: u32, state: State) -> Result<(), Violation> {
        self.raw.rotate_left(1);
        self.mask.rotate_left(1);
        if let (Some(r), Some(m)) = (self.raw.last_mut(), self.mask.last_mut()) {
            *r = raw_closed & ALL;
            *m = sensed & ALL;
        }
        self.ticks = self.ticks.saturating_add(1);
        if (self.ticks as usize) < SWITCH_WINDOW {
            return Ok(());
        }
        for i in 0..AXES {
            let b = bit(i);
            let closed = self.raw.iter().filter(|r| *r & b != 0).count();
            let seen = self.mask.iter().any(|m| m & b != 0);
            if closed.saturating_mul(2) >= SWITCH_WINDOW && !seen {
                return Err(Violation {
                    sr: Sr::Sr10,
                    axis: u8::try_from(i).ok(),
                    what: "a switch read closed in half of 6 samples never entered the limit mask",
                    got: Some(closed as f64),
                    bound: Some(SWITCH_WINDOW as f64),
                    tick,
                    state,
                });
            }
        }
        Ok(())
    }
}

/// No frame dropped while the tick runs on time (SR-26): fed every tick
/// with the total of commands the queue refused and whether the tick
/// overran.
#[derive(Clone, Debug, Default)]
pub struct FrameWatch {
    refused: u32,
}

impl FrameWatch {
    /// Nothing refused yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// One tick: `refused` the queue's refusals so far, `overrun` whether
    /// this tick (or the one before it) overran.
    pub fn check(&mut self, refused: u32, overrun: bool, tick: u32, state: State) -> Result<(), Violation> {
        let new = refused.saturating_sub(self.refused);
        self.refused = refused;
        if new > 0 && !overrun {
            return Err(Violation {
                sr: Sr::Sr26,
                axis: None,
                what: "a frame dropped (QUEUE_FULL) while the tick ran on time",
                got: Some(f64::from(new)),
                bound: None,
                tick,
                state,
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plant::Plant;
    use kernel::config::{PAROL6, PAROL6_VALIDATED};
    use kernel::{Kernel, KernelF32, Request};

    /// The kernel against the test plant, every tick through
    /// [`Interactions`]; `tamper` may change what the check sees.
    struct Rig {
        k: KernelF32,
        auth: kernel::Authority,
        plant: Plant,
        ix: Interactions,
        mon: crate::Monitor<f32>,
    }

    impl Rig {
        fn new(q: [f64; AXES]) -> Self {
            let (k, auth) = Kernel::new(&PAROL6_VALIDATED);
            Rig { k, auth, plant: Plant::at(q), ix: Interactions::new(&PAROL6), mon: crate::Monitor::new(&PAROL6) }
        }
        fn tick_with(
            &mut self,
            req: Option<Request<f32>>,
            tamper: impl FnOnce(&mut Sense, &mut TickOutput<f32>),
        ) -> Result<(), Violation> {
            let mut sense = self.plant.sense();
            let enable = matches!(req, Some(Request::Enable(_)));
            let sent = req.as_ref().map(crate::Sent::of);
            let mut out = self.k.tick(&sense, req);
            self.plant.apply(&out.act.step_rate);
            tamper(&mut sense, &mut out);
            // This module's checks first, then the whole monitor's.
            let ix = self.ix.check(&sense, enable, &out);
            ix.and(self.mon.check(&sense, sent.as_ref(), &out, None, None))
        }
        fn run(&mut self, n: u32) {
            for _ in 0..n {
                self.tick_with(None, |_, _| {}).expect("clean");
            }
        }
    }

    /// J1 waits on its switch while J6 homes; the link is lost: latched
    /// with J1 unhomed and pressed. The kernel is clean under the checks.
    fn latched_with_j1_on_its_switch() -> Rig {
        let mut r = Rig::new([-1.75, -0.5, 1.0, 0.0, 0.0, 0.0]);
        r.run(3);
        r.tick_with(Some(Request::Home), |_, _| {}).expect("clean");
        r.run(1500);
        r.plant.link_lost = true;
        r.run(700);
        assert_eq!(r.k.state(), State::SoftEstop);
        r.plant.link_lost = false;
        r
    }

    fn homed() -> Rig {
        let mut r = Rig::new([0.0, -0.5, 1.0, 0.0, 0.0, 0.0]);
        r.run(3);
        r.tick_with(Some(Request::Home), |_, _| {}).expect("clean");
        for _ in 0..60_000 {
            r.tick_with(None, |_, _| {}).expect("clean");
            if r.k.state() == State::Operational {
                break;
            }
        }
        assert_eq!(r.k.state(), State::Operational);
        r
    }

    /// Real events of a homed kernel with J1's switch pressed: the tick it
    /// faults (`FAULT LIMIT_SWITCH J1`), and an enable refused 300 ticks
    /// later (`CAUSE_ACTIVE LIMIT_SWITCH J1`). The kernel's own event list
    /// cannot be written outside it, so the tamper tests take these.
    fn j1_pressed_events() -> (kernel::Events, kernel::Events) {
        let mut r = homed();
        r.plant.force_switch = 0b1;
        let fault = r.k.tick(&r.plant.sense(), None).events;
        for _ in 0..300 {
            r.k.tick(&r.plant.sense(), None);
        }
        let cap = r.auth.enable();
        let refusal = r.k.tick(&r.plant.sense(), Some(Request::Enable(cap))).events;
        (fault, refusal)
    }

    #[test]
    fn the_kernel_recovers_cleanly() {
        let mut r = latched_with_j1_on_its_switch();
        assert!(r.ix.rested() >= REST_TICKS);
        let cap = r.auth.enable();
        r.tick_with(Some(Request::Enable(cap)), |_, _| {}).expect("enable taken");
        assert_eq!(r.k.state(), State::Unhomed);
    }

    #[test]
    fn tamper_a_refused_enable_with_no_physical_cause_is_a_lock_up() {
        let (_, refusal) = j1_pressed_events();
        assert!(refusal.iter().any(|e| matches!(e, Event::Rejected { reason: Reject::CauseActive(_), .. })));
        let mut r = latched_with_j1_on_its_switch();
        let cap = r.auth.enable();
        // The refusal the kernel gave when it took an unhomed joint's
        // switch for a limit.
        let v = r
            .tick_with(Some(Request::Enable(cap)), |_, out| {
                out.events = refusal;
                out.status.state = State::SoftEstop;
            })
            .expect_err("a lock-up");
        assert_eq!((v.sr, v.axis), (Sr::Sr6, Some(0)), "{v}");
    }

    #[test]
    fn tamper_a_limit_fault_on_an_unhomed_joint_has_no_cause() {
        let (fault, _) = j1_pressed_events();
        let mut r = Rig::new([-1.75, -0.5, 1.0, 0.0, 0.0, 0.0]);
        r.run(3);
        r.tick_with(Some(Request::Home), |_, _| {}).expect("clean");
        r.run(1500);
        r.plant.link_lost = true;
        // The fault the kernel raised when the run stopped with J1 waiting
        // on its switch.
        let v = r.tick_with(None, |_, out| out.events = fault).expect_err("no cause");
        assert_eq!((v.sr, v.axis), (Sr::Sr10, Some(0)), "{v}");
    }

    #[test]
    fn a_limit_fault_of_a_homed_pressed_joint_is_a_cause() {
        let mut r = homed();
        r.plant.force_switch = 0b10;
        r.tick_with(None, |_, _| {}).expect("a real cause");
        assert_eq!(r.k.state(), State::Fault);
    }

    fn stream(p: [f32; AXES]) -> kernel::MotionTarget<f32> {
        kernel::MotionTarget { position: p, velocity: [0.0; AXES], kind: kernel::MotionKind::Stream }
    }

    /// SR-29 (judged by `Monitor`): a stream that stops at 1.5 rad/s holds
    /// with its set-point at rest on the last sample; the latch the kernel
    /// gave there when it also judged the residual output is caught.
    #[test]
    fn tamper_a_latch_with_the_set_points_at_rest_is_caught() {
        let mut r = homed();
        // Samples to 0.3 rad away in a burst (continuous by SR-30): the
        // set-point still travels at the timeout, so the kernel latches:
        // the events of that tick.
        let (mut fork, mut arm) = (r.k.fork().0, r.plant.clone());
        let mut p = fork.status(0).setpoint;
        for d in [0.04f32, 0.1, 0.1, 0.06] {
            p[0] += d;
            let o = fork.tick(&arm.sense(), Some(Request::Motion(stream(p))));
            assert!(o.events.is_empty(), "{:?}", o.events);
            arm.apply(&o.act.step_rate);
        }
        let mut latch = None;
        for _ in 0..200 {
            let o = fork.tick(&arm.sense(), None);
            arm.apply(&o.act.step_rate);
            if o.events.iter().any(|e| matches!(e, Event::SoftEstop { .. })) {
                latch = Some(o.events);
                break;
            }
        }
        let latch = latch.expect("a far stream cut while moving latches");
        // The real run: J1 streamed at 1.5 rad/s, then silence.
        let mut p = r.k.status(0).position;
        for _ in 0..30 {
            p[0] += 0.015;
            r.tick_with(Some(Request::Motion(stream(p))), |_, _| {}).expect("clean");
            for _ in 0..9 {
                r.tick_with(None, |_, _| {}).expect("clean");
            }
        }
        // Until the tick before the timeout, then that tick with the latch.
        let mut fork = r.k.fork().0;
        let mut arm = r.plant.clone();
        let mut n = 0;
        while n < 200 {
            let o = fork.tick(&arm.sense(), None);
            arm.apply(&o.act.step_rate);
            if o.events.iter().any(|e| *e == Event::Holding) {
                break;
            }
            n += 1;
        }
        assert!(n < 200, "the stream holds");
        r.run(n);
        let v = r
            .tick_with(None, |_, out| {
                assert!(out.events.iter().any(|e| *e == Event::Holding));
                out.events = latch;
                out.status.state = State::Stopping;
            })
            .expect_err("a latch at rest");
        assert_eq!(v.sr, Sr::Sr29, "{v}");
        assert!(v.what.contains("every set-point at rest"), "{v}");
    }

    /// The rule the debouncer had: a level accepted after 3 equal samples
    /// in a row.
    fn three_in_a_row(hist: &mut (bool, u8), closed: bool, state: &mut bool) {
        if closed == hist.0 {
            hist.1 = hist.1.saturating_add(1);
        } else {
            *hist = (closed, 1);
        }
        if hist.1 >= 3 {
            *state = closed;
        }
    }

    /// Closed 2 ms, open 1 ms: each rule's mask through the watch.
    fn chatter(rule: impl Fn(&[bool]) -> bool) -> Result<(), Violation> {
        let mut w = SwitchWatch::new();
        let mut raw = std::vec::Vec::new();
        for t in 0..300u32 {
            let closed = t % 3 != 2;
            raw.push(closed);
            let mask = if rule(&raw) { 0b10 } else { 0 };
            w.check(if closed { 0b10 } else { 0 }, mask, t, State::Operational)?;
        }
        Ok(())
    }

    #[test]
    fn tamper_a_chattering_switch_hidden_by_three_in_a_row_is_caught() {
        let old = |raw: &[bool]| {
            let (mut h, mut s) = ((false, 0), false);
            for c in raw {
                three_in_a_row(&mut h, *c, &mut s);
            }
            s
        };
        let v = chatter(old).expect_err("hidden");
        assert_eq!((v.sr, v.axis), (Sr::Sr10, Some(1)), "{v}");
        // Pressed wins (2 of the last 3 closed): seen.
        let new = |raw: &[bool]| raw.iter().rev().take(3).filter(|c| **c).count() >= 2;
        chatter(new).expect("seen");
    }

    #[test]
    fn tamper_a_frame_dropped_on_time_is_caught() {
        let mut w = FrameWatch::new();
        w.check(0, false, 1, State::Operational).expect("nothing dropped");
        w.check(2, true, 2, State::Operational).expect("dropped while the tick overran");
        w.check(2, false, 3, State::Operational).expect("nothing new");
        let v = w.check(3, false, 4, State::Operational).expect_err("dropped on time");
        assert_eq!(v.sr, Sr::Sr26);
    }
}
