//! The arm: six stepper joints driven by STEP pulses and DIR levels, each
//! with an MT6816 on the motor shaft (PWM output) and a limit switch.
//!
//! * A STEP rising edge moves the joint by one microstep, in the direction
//!   given by its DIR pin at that moment (DIR high = positive joint
//!   direction: the wiring assumption of the twin; `motor_reversed` false).
//! * MT6816 PWM: frame of 4119 clocks of 250 ns (150 CPU cycles) = 617 850
//!   cycles, HIGH for `16 + count` clocks at the frame start, `count` =
//!   motor angle * 4096 / 2 pi (mod 4096), sampled at each frame start.
//!   Each encoder has its own frame phase.
//! * Limit switch: closed when the joint is at or beyond its switch position
//!   in the homing direction (`kernel::config::PAROL6`), input low when
//!   closed (pull-up, active low).

use kernel::config::{ArmConfig, Direction, PAROL6};

/// MT6816 PWM clock in CPU cycles (250 ns at 600 MHz). The sensor's figures
/// are the twin's own, not imported from `hal_imxrt::pure::mt6816`, on
/// purpose: an independent model of the sensor the image is checked against.
pub const PWM_CLOCK_CYCLES: u64 = 150;
/// Frame length in PWM clocks.
pub const FRAME_CLOCKS: u64 = 4119;
/// Frame length in CPU cycles.
pub const FRAME_CYCLES: u64 = FRAME_CLOCKS * PWM_CLOCK_CYCLES;

/// One joint.
#[derive(Clone, Debug)]
pub struct Joint {
    /// Angle at power-on (rad).
    pub q0: f64,
    /// Net microsteps since power-on.
    pub steps: i64,
    /// Microsteps per radian.
    pub steps_per_rad: f64,
    /// Gear ratio (motor / joint).
    pub gear: f64,
    /// Switch position (rad) and whether it closes at q >= pos (positive).
    pub switch_at: f64,
    /// Homing direction is positive.
    pub switch_positive: bool,
    /// Forced switch state (fault injection).
    pub force_switch: Option<bool>,
    /// Encoder disconnected (line stuck low).
    pub encoder_cut: bool,
    /// Encoder frame phase (cycles).
    pub phase: u64,
    /// Encoder clock error (frame period = nominal * (1 + ppm/1e6)).
    pub clock_ppm: f64,
    /// Cached current frame: (start, end, high_end).
    frame: (u64, u64, u64),
}

impl Joint {
    /// Joint angle (rad).
    pub fn q(&self) -> f64 {
        self.q0 + self.steps as f64 / self.steps_per_rad
    }
    /// Switch closed.
    pub fn switch_closed(&self) -> bool {
        if let Some(f) = self.force_switch {
            return f;
        }
        if self.switch_positive {
            self.q() >= self.switch_at
        } else {
            self.q() <= self.switch_at
        }
    }
    /// Encoder count (0..4095) of the current angle.
    pub fn count(&self) -> u32 {
        let motor = self.q() * self.gear;
        let c = (motor / std::f64::consts::TAU * 4096.0).round() as i64;
        c.rem_euclid(4096) as u32
    }
    fn period(&self) -> u64 {
        (FRAME_CYCLES as f64 * (1.0 + self.clock_ppm * 1e-6)).round() as u64
    }
    /// Input level at `t` and the next change.
    pub fn wave(&mut self, t: u64) -> (bool, u64) {
        if self.encoder_cut {
            return (false, t + FRAME_CYCLES);
        }
        let p = self.period();
        let (s, e, h) = self.frame;
        let in_frame = t >= s && t < e;
        if !in_frame {
            let k = t.saturating_sub(self.phase) / p;
            let start = if t < self.phase { 0 } else { self.phase + k * p };
            let high = (16 + u64::from(self.count())) * p / FRAME_CLOCKS;
            let end = if t < self.phase { self.phase } else { start + p };
            let high_end = if t < self.phase { 0 } else { start + high };
            self.frame = (start, end, high_end);
        }
        let (_, e, h2) = self.frame;
        let _ = h;
        if t < h2 {
            (true, h2)
        } else {
            (false, e)
        }
    }
}

/// The six joints.
#[derive(Clone, Debug)]
pub struct Plant {
    /// J1..J6.
    pub joints: [Joint; 6],
}

impl Plant {
    /// Joints at `q0` (rad), encoder phases spread over a frame.
    pub fn new(cfg: &ArmConfig, q0: [f64; 6]) -> Self {
        let joints = core::array::from_fn(|i| {
            let j = &cfg.joints[i];
            Joint {
                q0: q0[i],
                steps: 0,
                steps_per_rad: j.steps_per_rad(),
                gear: f64::from(j.gear_ratio),
                switch_at: f64::from(j.homing.switch_position),
                switch_positive: j.homing.direction == Direction::Positive,
                force_switch: None,
                encoder_cut: false,
                phase: 1 + (i as u64) * 97_003,
                clock_ppm: 0.0,
                frame: (0, 0, 0),
            }
        });
        Plant { joints }
    }

    /// PAROL6 with every joint at 0 rad.
    pub fn parol6() -> Self {
        Self::new(&PAROL6, [0.0; 6])
    }

    /// Joint angles.
    pub fn q(&self) -> [f64; 6] {
        core::array::from_fn(|i| self.joints[i].q())
    }
}
