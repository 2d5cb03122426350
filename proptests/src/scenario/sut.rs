//! One kernel against its plant, every tick checked by the monitor
//! ([`Sut`]), and the homed snapshot a test may start from.

use std::collections::VecDeque;
use std::sync::OnceLock;

use kernel::config::{AXES, PAROL6, PAROL6_VALIDATED};
use kernel::{Authority, Fx, Kernel, MotionKind, MotionTarget, Request, Scalar, Sense, State, TickOutput};

use monitor::plant::{EncoderFault, Plant, Witness};
use monitor::{Monitor, Sent};

use super::{Bad, Driver, Req, Start, HOMING_WAIT_MAX, OFFSETS, START};

/// A numeric variant of the kernel, with what the tests need per variant.
pub trait Variant: Scalar {
    /// `"f32"` or `"fx"`.
    const NAME: &'static str;
    /// The variant's worst value for a target field: NaN or infinity for
    /// `f32`; the largest representable value for fixed point, which has no
    /// non-finite values.
    fn non_finite(nan: bool, negative: bool) -> Self;
    /// A kernel homed from [`START`] (with its plant and monitor), made once.
    fn homed_snapshot() -> &'static Snapshot<Self>;
}

/// A kernel, plant and monitor to start a test from.
#[derive(Clone, Debug)]
pub struct Snapshot<S: Scalar> {
    kernel: Kernel<S>,
    plant: Plant,
    mon: Monitor<S>,
    ticks: u64,
}

fn make_snapshot<S: Variant>() -> Snapshot<S> {
    let mut sut = Sut::<S>::fresh(START, OFFSETS);
    sut.tick(None);
    sut.tick(Some(Req::Home));
    for _ in 0..HOMING_WAIT_MAX {
        if sut.k.state() != State::Homing {
            break;
        }
        sut.tick(None);
    }
    assert_eq!(sut.k.state(), State::Operational, "{} snapshot: homing from START failed", S::NAME);
    Snapshot { kernel: sut.k, plant: sut.plant, mon: sut.mon, ticks: sut.ticks }
}

impl Variant for f32 {
    const NAME: &'static str = "f32";
    fn non_finite(nan: bool, negative: bool) -> Self {
        match (nan, negative) {
            (true, _) => f32::NAN,
            (false, false) => f32::INFINITY,
            (false, true) => f32::NEG_INFINITY,
        }
    }
    fn homed_snapshot() -> &'static Snapshot<Self> {
        static S: OnceLock<Snapshot<f32>> = OnceLock::new();
        S.get_or_init(make_snapshot::<f32>)
    }
}

impl Variant for Fx {
    const NAME: &'static str = "fx";
    fn non_finite(_nan: bool, negative: bool) -> Self {
        if negative {
            Fx::MIN
        } else {
            Fx::MAX
        }
    }
    fn homed_snapshot() -> &'static Snapshot<Self> {
        static S: OnceLock<Snapshot<Fx>> = OnceLock::new();
        S.get_or_init(make_snapshot::<Fx>)
    }
}

/// One kernel against its plant, every tick checked by the monitor.
#[derive(Debug)]
pub struct Sut<S: Variant> {
    /// The kernel under test.
    pub k: Kernel<S>,
    auth: Authority,
    /// Its plant.
    pub plant: Plant,
    /// The monitor.
    pub mon: Monitor<S>,
    /// Ticks run.
    pub ticks: u64,
    /// What was injected into the plant and when (the monitor's plant facts).
    wit: Witness,
    boot_lost_until: Option<(usize, u64)>,
    recent: VecDeque<(u64, Sense, Option<Req>, TickOutput<S>)>,
    /// The last tick's output.
    pub last: Option<TickOutput<S>>,
    /// Its outputs do not move the arm (the fixed-point kernel of a
    /// [`Pair`]): the monitor's clean-plant checks (SR-19's overrun, SR-28's
    /// following error) do not apply to it.
    pub follower: bool,
}

impl<S: Variant> Sut<S> {
    /// A kernel and its plant, monitor and tick count; no history yet.
    fn from_parts(k: Kernel<S>, auth: Authority, plant: Plant, mon: Monitor<S>, ticks: u64) -> Self {
        Sut {
            k,
            auth,
            plant,
            mon,
            ticks,
            wit: Witness::new(),
            boot_lost_until: None,
            recent: VecDeque::new(),
            last: None,
            follower: false,
        }
    }

    /// Power-on at `q`.
    pub fn fresh(q: [f64; AXES], offset: [f64; AXES]) -> Self {
        let (k, auth) = Kernel::new(&PAROL6_VALIDATED);
        Self::from_parts(k, auth, Plant::new(q, offset), Monitor::new(&PAROL6), 0)
    }

    /// From a start description.
    pub fn new(start: &Start) -> Self {
        match start {
            Start::Fresh { q, offset, boot_lost } => {
                let mut s = Self::fresh(*q, *offset);
                if let Some((axis, ticks)) = *boot_lost {
                    s.plant.encoder[axis] = EncoderFault::Lost;
                    s.boot_lost_until = Some((axis, ticks));
                }
                s
            }
            Start::Homed => {
                let s = S::homed_snapshot().clone();
                // A capability works only on the kernel that minted it: the
                // snapshot's authority was not kept, so fork it (same state,
                // fresh identity, its own authority).
                let (kernel, auth) = s.kernel.fork();
                Self::from_parts(kernel, auth, s.plant, s.mon, s.ticks)
            }
        }
    }

    fn request(&self, r: &Req) -> Request<S> {
        let conv = |a: [f64; AXES]| a.map(|x| S::from_f32(x as f32));
        match *r {
            Req::Motion(p, v) => {
                let t = MotionTarget { position: conv(p), velocity: conv(v), kind: MotionKind::Stream };
                Request::Motion(t)
            }
            Req::GoTo(p) => {
                Request::Motion(MotionTarget { position: conv(p), velocity: [S::ZERO; AXES], kind: MotionKind::GoTo })
            }
            Req::BadMotion { base, axis, bad } => {
                let mut t = MotionTarget { position: conv(base), velocity: [S::ZERO; AXES], kind: MotionKind::Stream };
                let j = &PAROL6.joints[axis];
                match bad {
                    Bad::OutOfLimits(e) => {
                        let x = if e < 0.0 { f64::from(j.limit_min) + e } else { f64::from(j.limit_max) + e };
                        t.position[axis] = S::from_f32(x as f32);
                    }
                    Bad::NanPosition => t.position[axis] = S::non_finite(true, false),
                    Bad::InfPosition(neg) => t.position[axis] = S::non_finite(false, neg),
                    Bad::NanVelocity => t.velocity[axis] = S::non_finite(true, false),
                    Bad::VelocityTooHigh(f) => t.velocity[axis] = S::from_f32(j.max_velocity * (1.0 + f as f32)),
                }
                Request::Motion(t)
            }
            Req::Home => Request::Home,
            Req::HomeJoint(j) => Request::HomeJoint(j),
            Req::Enable => Request::Enable(self.auth.enable()),
        }
    }

    /// One tick: sense, kernel, monitor (panics on a violation), plant.
    pub fn tick(&mut self, req: Option<Req>) -> TickOutput<S> {
        self.ticks += 1;
        if let Some((axis, until)) = self.boot_lost_until {
            if self.ticks > until {
                self.plant.encoder[axis] = EncoderFault::None;
                self.boot_lost_until = None;
            }
        }
        let sense = self.plant.sense();
        let request = req.as_ref().map(|r| self.request(r));
        let sent = request.as_ref().map(Sent::of);
        self.wit.before(&self.plant);
        let out = self.k.tick(&sense, request);
        let mut facts = self.wit.after(&self.plant, &out);
        // A kernel whose outputs do not move the arm (the follower of a
        // differential pair) sees an arm driven by someone else.
        facts.disturbed |= self.follower;
        if self.recent.len() == 6 {
            self.recent.pop_front();
        }
        self.recent.push_back((self.ticks, sense, req, out));
        let checked = self.mon.check(&sense, sent.as_ref(), &out, Some(&self.k.homing_phases()), Some(&facts));
        let checked = checked.map_err(|e| e.to_string()).and_then(|()| match self.k.invariant() {
            true => Ok(()),
            false => Err(format!("the kernel's state invariant (Kernel::invariant) broken: {:?}", self.k)),
        });
        if let Err(e) = checked {
            let mut msg = format!("[{}] tick {}: {e}\n  recent ticks:\n", S::NAME, self.ticks);
            for (t, s, r, o) in &self.recent {
                msg += &format!("   #{t} sense {s:?}\n      req {r:?}\n      out {o:?}\n");
            }
            panic!("{msg}");
        }
        self.plant.apply(&out.act.step_rate);
        self.last = Some(out);
        out
    }
}

impl<S: Variant> Driver for Sut<S> {
    fn q(&self) -> [f64; AXES] {
        self.plant.q
    }
    fn env(&mut self, f: &dyn Fn(&mut Plant)) {
        // Injections, slips (encoder offset changes) included, are seen by
        // the witness at the next tick.
        f(&mut self.plant);
    }
    fn tick(&mut self, req: Option<Req>) {
        Sut::tick(self, req);
    }
    fn state(&self) -> State {
        self.k.state()
    }
    fn phases(&self) -> [kernel::homing::Phase; AXES] {
        self.k.homing_phases()
    }
}
