//! The simulated PAROL6: six stepper axes, MT6816 encoders on the motor
//! shafts, and limit switches, sampled once per control tick.

use hal_imxrt::pure::frame::Snapshot;
use hal_imxrt::pure::step::{achieved_rate_mhz, StepCommand, StepConfig};
use kernel::config::{ArmConfig, Direction, AXES};

use crate::encoder::{Encoder, Line, CPU_HZ};
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
    /// The driver's DIR input is inverted (wiring fault).
    dir_inverted: bool,
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
    /// `JointConfig::steps_per_rad` of each joint, computed once.
    steps_per_rad: [f64; AXES],
    /// The joint angle (its bits) and motor counts of each axis at the
    /// last read.
    last_counts: [Option<(u64, f64)>; AXES],
}

/// `x.trunc()` for `|x| < 2^63` (a step accumulator: a fraction of a step
/// plus one tick's steps) without the libm call `f64::trunc` is on a
/// baseline x86-64 build; the sign of a zero is kept.
#[inline(always)]
fn trunc(x: f64) -> f64 {
    let t = (x as i64) as f64;
    if t == 0.0 {
        0.0f64.copysign(x)
    } else {
        t
    }
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
                dir_inverted: false,
                encoder: Encoder::new(rng.uniform(), opts.clock_ppm[i], opts.noise_counts),
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
            steps_per_rad: cfg.joints.map(|j| j.steps_per_rad()),
            last_counts: [None; AXES],
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
        motor / std::f64::consts::TAU * f64::from(hal_imxrt::pure::mt6816::COUNTS_PER_REV)
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

    /// Reads the six QuadTimer capture channels at the start of the
    /// current tick (as the firmware's `FrameCapture::sample`).
    #[allow(clippy::needless_range_loop)] // several per-axis arrays
    pub fn capture(&mut self) -> [Snapshot; AXES] {
        let jitter = (self.rng.uniform() * 2.0 - 1.0) * self.opts.jitter_cycles;
        let t = (self.tick + 1) as f64 * self.tick_cycles + jitter;
        let mut out =
            [Snapshot { ief: false, input_high: false, capt: 0, cntr: 0, cycles: 0, consistent: false }; AXES];
        for i in 0..AXES {
            let (q_prev, q) = (self.axes[i].q_prev, self.axes[i].q);
            // The previous read's angle is usually this one's start: reuse
            // its counts (the same function of the same value).
            let cp = match self.last_counts[i] {
                Some((bits, c)) if bits == q_prev.to_bits() => c,
                _ => self.motor_counts(i, q_prev),
            };
            let cn = self.motor_counts(i, q);
            self.last_counts[i] = Some((q.to_bits(), cn));
            out[i] = self.axes[i].encoder.sample(t, cp, cn, &mut self.rng);
        }
        out
    }

    /// The raw limit inputs: bit `i` set when J(i+1)'s pin is high (pull-up
    /// input, switch to ground: an open switch reads high).
    pub fn limit_levels(&self) -> u8 {
        (0..AXES).filter(|&i| !self.switch_closed(i)).fold(0u8, |m, i| m | (1 << i))
    }

    /// Applies one tick of step commands: each axis steps at the rate the
    /// step generator actually produces for its command (prescaler and
    /// period quantisation included), limited by `max_step_rate`.
    #[allow(clippy::needless_range_loop)] // several per-axis arrays
    pub fn apply(&mut self, cmds: &[StepCommand; AXES]) {
        let dt = 1.0 / f64::from(self.cfg.tick_hz);
        for i in 0..AXES {
            let j = &self.cfg.joints[i];
            let spr = self.steps_per_rad[i];
            let achieved = achieved_rate_mhz(&cmds[i], &StepConfig::DEFAULT) as f64 / 1000.0;
            let rate = achieved.clamp(-self.opts.max_step_rate, self.opts.max_step_rate);
            self.applied_rate[i] = rate;
            let a = &mut self.axes[i];
            a.step_acc += rate * dt;
            let steps = trunc(a.step_acc);
            a.step_acc -= steps;
            let kept = steps * (1.0 - a.lost_fraction);
            let dir = if j.motor_reversed != a.dir_inverted { -1.0 } else { 1.0 };
            a.q_prev = a.q;
            a.q += dir * kept / spr + a.disturbance * dt;
        }
        self.tick += 1;
    }

    /// Fault injection: a glitch of `offset` counts on `frames` frames.
    pub fn glitch(&mut self, i: usize, offset: i32, frames: u32) {
        self.axes[i].encoder.glitch = Some((offset, frames.max(1)));
    }
    /// Fault injection: axis `i`'s encoder reversed (from the next frame on,
    /// mirrored about that frame's count) or restored.
    pub fn reverse_encoder(&mut self, i: usize, on: bool) {
        self.axes[i].encoder.reversed = if on { Some(None) } else { None };
    }
    /// Fault injection: axis `i`'s encoder frozen at its next frame's count
    /// (a valid, unchanging reading) or restored.
    pub fn freeze_encoder(&mut self, i: usize, on: bool) {
        self.axes[i].encoder.frozen = if on { Some(None) } else { None };
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
    /// Fault injection: the DIR signal of axis `i` inverted (`true`) or
    /// normal: every step then turns the motor the other way.
    pub fn set_dir_inverted(&mut self, i: usize, inverted: bool) {
        self.axes[i].dir_inverted = inverted;
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
}
