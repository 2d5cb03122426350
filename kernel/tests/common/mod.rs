//! A test rig: the kernel against the one test plant (`monitor::plant`),
//! with the one safety monitor (`monitor::Monitor`) asserted at every tick.
#![allow(dead_code, clippy::needless_range_loop)] // six axes: indices read best

use kernel::config::{Validated, AXES, PAROL6_VALIDATED};
use kernel::{Authority, Event, Kernel, MotionTarget, Request, Scalar, Sense, State, TickOutput};
use monitor::plant::Witness;
#[allow(unused_imports)]
pub use monitor::plant::{EncoderFault, Plant};
use monitor::{Monitor, Sent};

/// The arm's pose at power-on in most tests: every joint off its home
/// position and inside its limits, so that homing moves each of them.
pub const START: [f64; AXES] = [0.3, 0.2, -0.4, 0.5, -0.3, 1.0];

/// A rig at `START`, booted and homed (in Operational).
pub fn homed<S: Scalar>() -> Rig<S> {
    let mut r = Rig::<S>::new(START);
    r.boot_and_home();
    r
}

/// Kernel + plant + the monitor, checked at every tick.
pub struct Rig<S: Scalar> {
    pub k: Kernel<S>,
    pub auth: Authority,
    pub plant: Plant,
    pub mon: Monitor<S>,
    wit: Witness,
    pub events: Vec<Event>,
    pub last: Option<TickOutput<S>>,
    pub ticks: u32,
}

pub fn target<S: Scalar>(p: [f64; AXES]) -> MotionTarget<S> {
    MotionTarget {
        position: p.map(|x| S::from_f32(x as f32)),
        velocity: [S::ZERO; AXES],
        kind: kernel::MotionKind::Stream,
    }
}

/// A configurator-style go-to (every velocity zero, `MotionKind::GoTo`).
pub fn goto<S: Scalar>(p: [f64; AXES]) -> MotionTarget<S> {
    MotionTarget { kind: kernel::MotionKind::GoTo, ..target(p) }
}

impl<S: Scalar> Rig<S> {
    pub fn new(q: [f64; AXES]) -> Self {
        Self::with_config(q, &PAROL6_VALIDATED)
    }

    /// The rig on another (validated) configuration: kernel, plant and
    /// monitor all use it.
    pub fn with_config(q: [f64; AXES], cfg: &Validated) -> Self {
        let (k, auth) = Kernel::new(cfg);
        Rig {
            k,
            auth,
            plant: Plant::at(q).with_config(*cfg.config()),
            mon: Monitor::new(cfg.config()),
            wit: Witness::new(),
            events: Vec::new(),
            last: None,
            ticks: 0,
        }
    }

    pub fn tick(&mut self, req: Option<Request<S>>) -> TickOutput<S> {
        let sense = self.plant.sense();
        self.tick_sensing(sense, req)
    }

    /// One tick with hand-made sensors (counted as an injection), checked
    /// like every other.
    pub fn tick_with(&mut self, sense: Sense, req: Option<Request<S>>) -> TickOutput<S> {
        if sense != self.plant.sense() {
            self.wit.injected();
        }
        self.tick_sensing(sense, req)
    }

    fn tick_sensing(&mut self, sense: Sense, req: Option<Request<S>>) -> TickOutput<S> {
        self.wit.before(&self.plant);
        let sent = req.as_ref().map(Sent::of);
        let out = self.k.tick(&sense, req);
        assert!(self.k.invariant(), "tick {}: the kernel's state invariant: {:?}", self.ticks, self.k);
        let facts = self.wit.after(&self.plant, &out);
        if let Err(v) = self.mon.check(&sense, sent.as_ref(), &out, Some(&self.k.homing_phases()), Some(&facts)) {
            panic!("tick {}: {v}\n  sense {sense:?}\n  request {sent:?}\n  out {out:?}", self.ticks);
        }
        self.plant.apply(&out.act.step_rate);
        self.events.extend(out.events.iter().copied());
        self.last = Some(out);
        self.ticks += 1;
        out
    }

    pub fn run(&mut self, n: u32) -> TickOutput<S> {
        let mut out = self.tick(None);
        for _ in 1..n {
            out = self.tick(None);
        }
        out
    }

    /// Runs until `f` holds or `max` ticks pass; returns ticks taken.
    pub fn run_until(&mut self, max: u32, mut f: impl FnMut(&TickOutput<S>) -> bool) -> Option<u32> {
        for n in 1..=max {
            let out = self.tick(None);
            if f(&out) {
                return Some(n);
            }
        }
        None
    }

    pub fn enable(&mut self) -> TickOutput<S> {
        let cap = self.auth.enable();
        self.tick(Some(Request::Enable(cap)))
    }

    /// Boot and full homing; panics if it does not complete in 60 s.
    pub fn boot_and_home(&mut self) -> u32 {
        self.run(3);
        assert_eq!(self.k.state(), State::Unhomed);
        self.tick(Some(Request::Home));
        let n = self.run_until(60_000, |o| o.status.state != State::Homing).expect("homing finishes");
        assert_eq!(self.k.state(), State::Operational, "events: {:?}", self.events);
        n
    }

    pub fn motion(&mut self, p: [f64; AXES]) -> TickOutput<S> {
        self.tick(Some(Request::Motion(target(p))))
    }

    /// Streams toward `p` in a burst, one sample a tick, each continuous by
    /// SR-30: the first 0.04 rad from the set-point (within its reach from
    /// rest on every joint), each next at most 0.1 rad from the one before
    /// (within a longest segment at every joint's speed limit). Returns the
    /// output of the tick that sent `p`.
    pub fn stream_to(&mut self, p: [f64; AXES]) -> TickOutput<S> {
        let sp = self.last.as_ref().map(|o| o.status.setpoint.map(|x| f64::from(x.to_f32())));
        let from = sp.unwrap_or(self.plant.q);
        let far = p.iter().zip(from.iter()).map(|(a, b)| (a - b).abs()).fold(0.0f64, f64::max);
        let n = if far <= 0.04 { 1 } else { 2 + ((far - 0.04) / 0.1) as u32 };
        let mut out = None;
        for k in 1..=n {
            let reach = (0.04 + 0.1 * f64::from(k - 1)).min(far);
            let q: [f64; AXES] = core::array::from_fn(|i| {
                let d = p[i] - from[i];
                if far > 0.0 {
                    from[i] + d * reach / far
                } else {
                    p[i]
                }
            });
            let q = if k == n { p } else { q };
            let o = self.motion(q);
            assert!(o.events.is_empty(), "stream_to: sample {k} of {n}: {:?}", o.events);
            out = Some(o);
        }
        out.expect("at least one sample")
    }

    pub fn goto(&mut self, p: [f64; AXES]) -> TickOutput<S> {
        self.tick(Some(Request::Motion(goto(p))))
    }

    pub fn rejected(&self) -> usize {
        self.events.iter().filter(|e| matches!(e, Event::Rejected { .. })).count()
    }
}

/// One test per numeric variant: `both!(name, ...)` makes
/// `f32_variant::name` and `fixed_variant::name`, each calling `name::<S>()`
/// of the calling module.
#[allow(unused_macros)]
macro_rules! both {
    ($($name:ident),* $(,)?) => {
        mod f32_variant { $( #[test] fn $name() { super::$name::<f32>(); } )* }
        mod fixed_variant { $( #[test] fn $name() { super::$name::<kernel::Fx>(); } )* }
    };
}
#[allow(unused_imports)]
pub(crate) use both;

/// The observer's prediction from `(x, v)` one tick ahead, in the kernel's
/// arithmetic (`x + v dt` at the PAROL6's tick rate).
#[cfg(feature = "proof-states")]
pub fn predicted<S: Scalar>(x: S, v: S) -> S {
    x.plus(v.times(S::from_f32(1.0 / kernel::config::PAROL6.tick_hz as f32)))
}

/// An axis for `Kernel::from_spec`: estimate `(x, v)`, set-point, target
/// and path at `x`, no output; read with encoder count 0 and a homing zero
/// equal to the observer's prediction, so the next tick's reading (count 0)
/// is exactly `x + v dt` and the residual exactly zero: after the tick the
/// estimate is exactly `(x + v dt, v)` (at rest: `(x, 0)`).
#[cfg(feature = "proof-states")]
pub fn axis_spec<S: Scalar>(x: S, v: S) -> kernel::AxisSpec<S> {
    kernel::AxisSpec {
        count: 0,
        zero: predicted(x, v),
        x,
        v,
        setpoint: x,
        target: x,
        sp_velocity: S::ZERO,
        speed: S::ZERO,
        last_out: S::ZERO,
        path: x,
        fe_count: 0,
        invalid: 0,
    }
}
