//! The simulated PAROL6: six stepper axes, MT6816 encoders on the motor
//! shafts, and limit switches, sampled once per control tick.

use hal_imxrt::pure::debounce::{Debounce, LimitState};
use kernel::config::{ArmConfig, Direction, AXES};
use kernel::{EncoderSample, Sense};

use crate::encoder::{DecodeMode, Encoder, Line, CPU_HZ};
use crate::rng::Rng;

/// Plant options (all per scenario).
#[derive(Clone, Debug, PartialEq)]
pub struct PlantOptions {
    /// True joint angles at power-on (rad), in the frame the homing defines.
    pub start: [f64; AXES],
    /// Encoder mounting offset of each motor (rad of motor angle).
    pub encoder_offset: [f64; AXES],
    /// Encoder count noise (sigma, counts).
    pub noise_counts: f64,
    /// Encoder PWM clock error (ppm), per axis.
    pub clock_ppm: [f64; AXES],
    /// How the encoder signal is decoded.
    pub decode: DecodeMode,
    /// Step-rate limit of the step generator / driver (steps/s).
    pub max_step_rate: f64,
    /// Joint angle at which each limit switch closes (pressed beyond it in
    /// the homing seek direction).
    pub switch_at: [f64; AXES],
    /// Control-tick sampling jitter (CPU cycles, uniform +-).
    pub jitter_cycles: f64,
    /// Random seed.
    pub seed: u64,
}

impl PlantOptions {
    /// Defaults for a configuration: switches where the kernel expects them.
    pub fn new(cfg: &ArmConfig) -> Self {
        PlantOptions {
            start: [0.0, -0.5, 1.0, 0.0, 0.0, 0.0],
            encoder_offset: [0.7, 2.1, 3.3, 5.9, 1.1, 4.4],
            noise_counts: 0.5,
            clock_ppm: [120.0, -80.0, 35.0, -150.0, 60.0, 10.0],
            decode: DecodeMode::Frame,
            max_step_rate: f64::from(cfg.max_step_rate),
            switch_at: cfg.joints.map(|j| f64::from(j.homing.switch_position)),
            jitter_cycles: 600.0,
            seed: 1,
        }
    }
}

/// One stepper axis.
#[derive(Clone, Debug)]
struct Axis {
    q: f64,
    q_prev: f64,
    step_acc: f64,
    lost_fraction: f64,
    disturbance: f64,
    force_switch: Option<bool>,
    debounce: Debounce,
    encoder: Encoder,
}

/// The arm.
#[derive(Clone, Debug)]
pub struct Plant {
    cfg: ArmConfig,
    opts: PlantOptions,
    axes: Vec<Axis>,
    tick: u64,
    tick_cycles: f64,
    rng: Rng,
    /// Last commanded step rates, after the step-rate limit.
    pub applied_rate: [f64; AXES],
}

impl Plant {
    /// A plant at `opts.start`.
    pub fn new(cfg: &ArmConfig, opts: PlantOptions) -> Self {
        let mut rng = Rng::new(opts.seed);
        let axes = (0..AXES)
            .map(|i| Axis {
                q: opts.start[i],
                q_prev: opts.start[i],
                step_acc: 0.0,
                lost_fraction: 0.0,
                disturbance: 0.0,
                force_switch: None,
                debounce: Debounce::new(),
                encoder: Encoder::new(opts.decode, rng.uniform(), opts.clock_ppm[i], opts.noise_counts),
            })
            .collect();
        Plant {
            cfg: *cfg,
            tick_cycles: CPU_HZ as f64 / f64::from(cfg.tick_hz),
            opts,
            axes,
            tick: 0,
            rng,
            applied_rate: [0.0; AXES],
        }
    }

    /// True joint angles (rad).
    pub fn q(&self) -> [f64; AXES] {
        core::array::from_fn(|i| self.axes[i].q)
    }

    /// Motor angle of axis `i` in encoder counts (continuous).
    fn motor_counts(&self, i: usize, q: f64) -> f64 {
        let j = &self.cfg.joints[i];
        let sign = if j.encoder_reversed { -1.0 } else { 1.0 };
        let motor = sign * q * f64::from(j.gear_ratio) + self.opts.encoder_offset[i];
        motor / std::f64::consts::TAU * 4096.0
    }

    /// The raw (undebounced) switch input of axis `i`: true when closed.
    pub fn switch_closed(&self, i: usize) -> bool {
        let a = &self.axes[i];
        if let Some(f) = a.force_switch {
            return f;
        }
        let s = self.opts.switch_at[i];
        match self.cfg.joints[i].homing.direction {
            Direction::Positive => a.q >= s,
            Direction::Negative => a.q <= s,
        }
    }

    /// Samples encoders and switches at the start of the current tick.
    #[allow(clippy::needless_range_loop)] // several per-axis arrays
    pub fn sense(&mut self) -> Sense {
        let jitter = (self.rng.uniform() * 2.0 - 1.0) * self.opts.jitter_cycles;
        let t = (self.tick + 1) as f64 * self.tick_cycles + jitter;
        let mut encoders = [EncoderSample::Lost; AXES];
        let mut limits = 0u8;
        for i in 0..AXES {
            let (cp, cn) = (self.motor_counts(i, self.axes[i].q_prev), self.motor_counts(i, self.axes[i].q));
            let closed = self.switch_closed(i);
            let a = &mut self.axes[i];
            encoders[i] = a.encoder.sample(t, cp, cn, &mut self.rng);
            // Pull-up input, switch to ground: closed reads low. Until the
            // debounce has confirmed a level, report pressed (not safe).
            match a.debounce.sample(!closed) {
                LimitState::Released => {}
                LimitState::Pressed | LimitState::Unknown => limits |= 1 << i,
            }
        }
        Sense { encoders, limits, hardware_fault: None }
    }

    /// Applies step rates (steps/s) for one tick.
    #[allow(clippy::needless_range_loop)] // several per-axis arrays
    pub fn apply(&mut self, step_rate: &[i32; AXES]) {
        let dt = 1.0 / f64::from(self.cfg.tick_hz);
        for i in 0..AXES {
            let j = self.cfg.joints[i];
            let spr = j.steps_per_rad();
            let rate = f64::from(step_rate[i]).clamp(-self.opts.max_step_rate, self.opts.max_step_rate);
            self.applied_rate[i] = rate;
            let a = &mut self.axes[i];
            a.step_acc += rate * dt;
            let steps = a.step_acc.trunc();
            a.step_acc -= steps;
            let kept = steps * (1.0 - a.lost_fraction);
            let dir = if j.motor_reversed { -1.0 } else { 1.0 };
            a.q_prev = a.q;
            a.q += dir * kept / spr + a.disturbance * dt;
        }
        self.tick += 1;
    }

    /// Fault injection: a glitch of `offset` counts on `frames` frames.
    pub fn glitch(&mut self, i: usize, offset: i32, frames: u32) {
        self.axes[i].encoder.glitch = Some((offset, frames.max(1)));
    }
    /// Fault injection: the encoder line of axis `i`.
    pub fn set_line(&mut self, i: usize, line: Line) {
        self.axes[i].encoder.line = line;
    }
    /// Fault injection: a switch forced closed/open, or `None` for the real one.
    pub fn force_switch(&mut self, i: usize, f: Option<bool>) {
        self.axes[i].force_switch = f;
    }
    /// Fault injection: a velocity not commanded (rad/s), e.g. a runaway.
    pub fn set_disturbance(&mut self, i: usize, v: f64) {
        self.axes[i].disturbance = v;
    }
    /// Fault injection: a fraction of steps lost.
    pub fn set_lost_steps(&mut self, i: usize, fraction: f64) {
        self.axes[i].lost_fraction = fraction.clamp(0.0, 1.0);
    }
    /// Encoder noise (sigma, counts) on every axis.
    pub fn set_noise(&mut self, sigma: f64) {
        for a in &mut self.axes {
            a.encoder.noise = sigma;
        }
    }
    /// Encoder decode statistics per axis.
    pub fn decode_stats(&self) -> [crate::encoder::DecodeStats; AXES] {
        core::array::from_fn(|i| self.axes[i].encoder.stats)
    }
    /// Composition-root policy: encoders whose tracker latched
    /// `Unrecoverable` re-acquire (called while the kernel holds a fault, so
    /// the count restarts only under a fault that requires re-homing).
    pub fn reset_latched_trackers(&mut self) {
        for a in &mut self.axes {
            if a.encoder.tracker_latched() {
                a.encoder.reset_tracker();
            }
        }
    }
}
