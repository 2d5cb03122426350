//! A simple plant: six steppers that follow their step rate exactly, MT6816
//! encoders on the motor shafts, limit switches at the configured switch
//! positions, and the faults the property tests inject (encoder loss,
//! out-of-range counts, count glitches, stuck switches, hardware faults,
//! outside forces).
//!
//! Adapted from `kernel/tests/common/mod.rs` (same physics), with the fault
//! injection this crate needs.
#![allow(clippy::needless_range_loop)] // six axes: indices read best

use kernel::config::{ArmConfig, Direction, AXES, PAROL6};
use kernel::{EncoderSample, HardwareFault, Sense};

/// What the encoder of one axis delivers besides its true reading.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EncoderFault {
    /// The true reading (plus any glitch).
    None,
    /// [`EncoderSample::Lost`].
    Lost,
    /// A count outside 0..=4095 (a corrupted PWM decode).
    OutOfRange(u16),
}

/// The simulated arm.
#[derive(Clone, Debug)]
pub struct Plant {
    /// The configuration the plant's mechanics follow.
    pub cfg: ArmConfig,
    /// True joint angles (rad), in the homed frame.
    pub q: [f64; AXES],
    /// Motor angle offset of each encoder (rad), so readings are not 0 at q = 0.
    pub enc_offset: [f64; AXES],
    /// Encoder faults.
    pub encoder: [EncoderFault; AXES],
    /// Extra counts added to a reading (a glitch).
    pub glitch: [i32; AXES],
    /// Switches forced pressed regardless of position.
    pub force_switch: u8,
    /// Extra joint velocity not commanded (a runaway, a falling arm, an
    /// operator moving a de-energised joint), rad/s.
    pub disturbance: [f64; AXES],
    /// A hardware fault reported with the next sensors.
    pub hardware_fault: Option<HardwareFault>,
}

impl Plant {
    /// The arm at rest at `q` with the given encoder offsets (rad of motor angle).
    pub fn new(q: [f64; AXES], enc_offset: [f64; AXES]) -> Self {
        Plant {
            cfg: PAROL6,
            q,
            enc_offset,
            encoder: [EncoderFault::None; AXES],
            glitch: [0; AXES],
            force_switch: 0,
            disturbance: [0.0; AXES],
            hardware_fault: None,
        }
    }

    /// The true 12-bit reading of axis `i` plus its glitch.
    pub fn counts(&self, i: usize) -> u16 {
        let j = &self.cfg.joints[i];
        let motor = self.q[i] * j.gear_ratio as f64 + self.enc_offset[i];
        let c = (motor / core::f64::consts::TAU * 4096.0).floor() as i64 + self.glitch[i] as i64;
        c.rem_euclid(4096) as u16
    }

    /// Switches pressed by position (bit per joint), plus forced ones.
    pub fn switches(&self) -> u8 {
        let mut m = self.force_switch & 0b11_1111;
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

    /// This tick's sensors.
    pub fn sense(&self) -> Sense {
        let mut enc = [EncoderSample::Lost; AXES];
        for (i, e) in enc.iter_mut().enumerate() {
            *e = match self.encoder[i] {
                EncoderFault::None => EncoderSample::Count(self.counts(i)),
                EncoderFault::Lost => EncoderSample::Lost,
                EncoderFault::OutOfRange(c) => EncoderSample::Count(c),
            };
        }
        Sense { encoders: enc, limits: self.switches(), hardware_fault: self.hardware_fault }
    }

    /// Applies step rates for one tick.
    pub fn apply(&mut self, step_rate: &[i32; AXES]) {
        let dt = 1.0 / self.cfg.tick_hz as f64;
        for i in 0..AXES {
            let spr = self.cfg.joints[i].steps_per_rad();
            self.q[i] += (step_rate[i] as f64 / spr + self.disturbance[i]) * dt;
        }
    }

    /// Clears every injected fault (the environment is clean again).
    pub fn clear_faults(&mut self) {
        self.encoder = [EncoderFault::None; AXES];
        self.glitch = [0; AXES];
        self.force_switch = 0;
        self.disturbance = [0.0; AXES];
        self.hardware_fault = None;
    }

    /// True if nothing is injected.
    pub fn is_clean(&self) -> bool {
        self.encoder == [EncoderFault::None; AXES]
            && self.glitch == [0; AXES]
            && self.force_switch == 0
            && self.disturbance == [0.0; AXES]
            && self.hardware_fault.is_none()
    }
}
