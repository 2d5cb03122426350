//! A test rig: the kernel against a minimal plant, with the safety
//! invariants asserted at every tick.
#![allow(dead_code, clippy::needless_range_loop)] // six axes: indices read best

use kernel::config::{ArmConfig, Direction, AXES, PAROL6};
use kernel::{Authority, EncoderSample, Event, Kernel, MotionTarget, Request, Scalar, Sense, State, TickOutput};

/// Six steppers that follow their step rate exactly, MT6816 encoders on the
/// motor shafts, and limit switches at the configured switch positions.
#[derive(Clone, Debug)]
pub struct Plant {
    pub cfg: ArmConfig,
    /// True joint angles (rad), in the homed frame.
    pub q: [f64; AXES],
    /// Motor angle offset of each encoder (rad), so readings are not 0 at q = 0.
    pub enc_offset: [f64; AXES],
    pub encoder_lost: [bool; AXES],
    /// Extra counts added to a reading (a glitch).
    pub glitch: [i32; AXES],
    /// Switches forced pressed regardless of position.
    pub force_switch: u8,
    /// Extra joint velocity not commanded (a runaway, a falling arm).
    pub disturbance: [f64; AXES],
}

impl Plant {
    pub fn new(q: [f64; AXES]) -> Self {
        Plant {
            cfg: PAROL6,
            q,
            enc_offset: [0.7, 2.1, 3.3, 5.9, 1.1, 4.4],
            encoder_lost: [false; AXES],
            glitch: [0; AXES],
            force_switch: 0,
            disturbance: [0.0; AXES],
        }
    }

    pub fn counts(&self, i: usize) -> u16 {
        let j = &self.cfg.joints[i];
        let motor = self.q[i] * j.gear_ratio as f64 + self.enc_offset[i];
        let c = (motor / core::f64::consts::TAU * 4096.0).floor() as i64 + self.glitch[i] as i64;
        c.rem_euclid(4096) as u16
    }

    pub fn switches(&self) -> u8 {
        let mut m = self.force_switch;
        for (i, j) in self.cfg.joints.iter().enumerate() {
            let s = j.homing.switch_position as f64;
            let pressed = match j.homing.direction {
                Direction::Positive => self.q[i] >= s,
                Direction::Negative => self.q[i] <= s,
            };
            if pressed {
                m |= 1 << i;
            }
        }
        m
    }

    pub fn sense(&self) -> Sense {
        let mut enc = [EncoderSample::Lost; AXES];
        for (i, e) in enc.iter_mut().enumerate() {
            if !self.encoder_lost[i] {
                *e = EncoderSample::Count(self.counts(i));
            }
        }
        Sense { encoders: enc, limits: self.switches(), hardware_fault: None }
    }

    /// Applies step rates for one tick.
    pub fn apply(&mut self, step_rate: &[i32; AXES]) {
        let dt = 1.0 / self.cfg.tick_hz as f64;
        for i in 0..AXES {
            let spr = self.cfg.joints[i].steps_per_rad();
            self.q[i] += (step_rate[i] as f64 / spr + self.disturbance[i]) * dt;
        }
    }
}

/// Kernel + plant + invariant checks.
pub struct Rig<S: Scalar> {
    pub k: Kernel<S>,
    pub auth: Authority,
    pub plant: Plant,
    pub events: Vec<Event>,
    pub last: Option<TickOutput<S>>,
    pub ticks: u32,
}

pub fn target<S: Scalar>(p: [f64; AXES]) -> MotionTarget<S> {
    MotionTarget { position: p.map(|x| S::from_f32(x as f32)), velocity: [S::ZERO; AXES] }
}

impl<S: Scalar> Rig<S> {
    pub fn new(q: [f64; AXES]) -> Self {
        let (k, auth) = Kernel::new(&PAROL6);
        Rig { k, auth, plant: Plant::new(q), events: Vec::new(), last: None, ticks: 0 }
    }

    pub fn tick(&mut self, req: Option<Request<S>>) -> TickOutput<S> {
        let sense = self.plant.sense();
        let out = self.k.tick(&sense, req);
        self.check_invariants(&out);
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
    pub fn run_until(&mut self, max: u32, f: impl Fn(&TickOutput<S>) -> bool) -> Option<u32> {
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

    pub fn rejected(&self) -> usize {
        self.events.iter().filter(|e| matches!(e, Event::Rejected { .. })).count()
    }

    fn check_invariants(&self, out: &TickOutput<S>) {
        let st = out.status.state;
        for (i, v) in out.act.velocity.iter().enumerate() {
            let vmax = PAROL6.joints[i].max_velocity;
            assert!(v.is_finite() && v.to_f32().abs() <= vmax * 1.0001, "axis {i} output {v:?} out of bounds");
        }
        let zero = out.act.velocity.iter().all(|v| *v == S::ZERO) && out.act.step_rate.iter().all(|r| *r == 0);
        if matches!(st, State::Boot | State::Unhomed | State::SoftEstop | State::Fault) {
            assert!(zero, "state {st:?} must output zero: {:?}", out.act);
        }
        if st == State::Homing {
            let phases = self.k.homing_phases();
            for i in 0..AXES {
                if !phases[i].is_moving() {
                    assert_eq!(out.act.velocity[i], S::ZERO, "axis {i} not homing must be still");
                } else {
                    let needs = Kernel::<S>::dependencies(i);
                    assert_eq!(out.status.homed & needs, needs, "axis {i} moving before its dependencies");
                }
            }
        }
        // Step rate sign follows velocity sign.
        for i in 0..AXES {
            let v = out.act.velocity[i].to_f32();
            let r = out.act.step_rate[i];
            // Zero velocity gives zero rate; otherwise the rate has the
            // velocity's sign (or truncates to zero for tiny speeds).
            let ok = if v == 0.0 { r == 0 } else { r == 0 || (v > 0.0) == (r > 0) };
            assert!(ok, "axis {i}: v {v} rate {r}");
        }
    }
}
