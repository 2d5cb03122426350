//! The one test plant (feature `plant`, needs std for `f64::floor`): six
//! steppers that follow their step rate exactly, MT6816 encoders on the
//! motor shafts (motor and encoder directions as the configuration's
//! `motor_reversed` and `encoder_reversed` say), limit switches at the configured switch positions, and the
//! faults tests inject (encoder loss, out-of-range counts, count glitches,
//! stuck switches, hardware faults, outside forces, encoder slips).
//!
//! [`Witness`] keeps the book of what was injected and when, and produces
//! the [`PlantFacts`] the monitor's plant-dependent checks need.

use kernel::config::{ArmConfig, Direction, AXES, PAROL6};
use kernel::{EncoderSample, Event, HardwareFault, Sense, TickOutput};

use crate::PlantFacts;

/// Motor angle offsets (rad) of the encoders when a test does not choose
/// them, so that readings are not 0 at q = 0.
pub const DEFAULT_OFFSETS: [f64; AXES] = [0.7, 2.1, 3.3, 5.9, 1.1, 4.4];

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
    /// The host link is reported lost (USB port closed).
    pub link_lost: bool,
    /// Joints whose motor turns the wrong way (DIR wired inverted).
    pub reversed: u8,
    /// Joints whose motor does not turn (stalled, driver off, lost steps).
    pub stalled: u8,
    /// Joints whose limit switch never closes (broken wire).
    pub dead_switch: u8,
}

impl Plant {
    /// The `PAROL6` arm at rest at `q` with the given encoder offsets (rad of
    /// motor angle).
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
            link_lost: false,
            reversed: 0,
            stalled: 0,
            dead_switch: 0,
        }
    }

    /// The same arm with another configuration (another tick rate, say).
    pub fn with_config(mut self, cfg: ArmConfig) -> Self {
        self.cfg = cfg;
        self
    }

    /// The arm at rest at `q` with [`DEFAULT_OFFSETS`].
    pub fn at(q: [f64; AXES]) -> Self {
        Self::new(q, DEFAULT_OFFSETS)
    }

    /// The true 12-bit reading of axis `i` plus its glitch (0 for an axis
    /// that does not exist).
    pub fn counts(&self, i: usize) -> u16 {
        let (Some(j), Some(q), Some(off), Some(g)) =
            (self.cfg.joints.get(i), self.q.get(i), self.enc_offset.get(i), self.glitch.get(i))
        else {
            return 0;
        };
        // An encoder mounted reversed (`encoder_reversed`) counts down as
        // the joint turns positive.
        let sign = if j.encoder_reversed { -1.0 } else { 1.0 };
        let motor = sign * (q * f64::from(j.gear_ratio) + off);
        let c = ((motor / core::f64::consts::TAU * 4096.0).floor() as i64).saturating_add(i64::from(*g));
        c.rem_euclid(4096) as u16
    }

    /// Switches pressed by position (bit per joint), plus forced ones.
    pub fn switches(&self) -> u8 {
        let mut m = self.force_switch & 0b11_1111;
        for (i, (j, q)) in self.cfg.joints.iter().zip(self.q.iter()).enumerate() {
            let s = f64::from(j.homing.switch_position);
            let pressed = match j.homing.direction {
                Direction::Positive => *q >= s,
                Direction::Negative => *q <= s,
            };
            if pressed && self.dead_switch & crate::bit(i) == 0 {
                m |= crate::bit(i);
            }
        }
        m
    }

    /// This tick's sensors.
    pub fn sense(&self) -> Sense {
        let mut enc = [EncoderSample::Lost; AXES];
        for (i, (e, fault)) in enc.iter_mut().zip(self.encoder.iter()).enumerate() {
            *e = match *fault {
                EncoderFault::None => EncoderSample::Count(self.counts(i)),
                EncoderFault::Lost => EncoderSample::Lost,
                EncoderFault::OutOfRange(c) => EncoderSample::Count(c),
            };
        }
        Sense { encoders: enc, limits: self.switches(), hardware_fault: self.hardware_fault, link_lost: self.link_lost }
    }

    /// Applies step rates for one tick.
    pub fn apply(&mut self, step_rate: &[i32; AXES]) {
        let dt = 1.0 / f64::from(self.cfg.tick_hz);
        for (i, (((q, r), j), d)) in
            self.q.iter_mut().zip(step_rate.iter()).zip(self.cfg.joints.iter()).zip(self.disturbance.iter()).enumerate()
        {
            let m = crate::bit(i);
            // A motor wired reversed as the configuration says
            // (`motor_reversed`) turns the joint negative on positive steps;
            // `reversed` is a wiring the configuration does not know.
            let dir = if (self.reversed & m != 0) != j.motor_reversed { -1.0 } else { 1.0 };
            let turns = if self.stalled & m != 0 { 0.0 } else { 1.0 };
            *q += (dir * turns * f64::from(*r) / j.steps_per_rad() + d) * dt;
        }
    }

    /// Clears every injected fault (the environment is clean again).
    pub fn clear_faults(&mut self) {
        self.encoder = [EncoderFault::None; AXES];
        self.glitch = [0; AXES];
        self.force_switch = 0;
        self.disturbance = [0.0; AXES];
        self.hardware_fault = None;
        self.link_lost = false;
        self.reversed = 0;
        self.stalled = 0;
        self.dead_switch = 0;
    }

    /// True if nothing is injected that can move a joint off its command
    /// or fool its estimate (a lost link and a dead switch cannot).
    pub fn motion_clean(&self) -> bool {
        self.encoder == [EncoderFault::None; AXES]
            && self.glitch == [0; AXES]
            && self.force_switch == 0
            && self.disturbance == [0.0; AXES]
            && self.hardware_fault.is_none()
            && self.reversed == 0
            && self.stalled == 0
    }

    /// True if nothing is injected.
    pub fn is_clean(&self) -> bool {
        self.encoder == [EncoderFault::None; AXES]
            && self.glitch == [0; AXES]
            && self.force_switch == 0
            && self.disturbance == [0.0; AXES]
            && self.hardware_fault.is_none()
            && !self.link_lost
            && self.reversed == 0
            && self.stalled == 0
            && self.dead_switch == 0
    }
}

/// The book of what was injected into a [`Plant`] and when, from which the
/// monitor's [`PlantFacts`] follow. Per tick: [`Witness::before`] after
/// sensing (before the kernel's tick), [`Witness::after`] with the kernel's
/// output. Anything a test does to the sensors besides the plant (a
/// hand-made `Sense`) is reported with [`Witness::injected`].
#[derive(Clone, Debug)]
pub struct Witness {
    ticks: u64,
    last_injection: Option<u64>,
    homing_started: Option<u64>,
    rest_q: [f64; AXES],
    offsets: Option<[f64; AXES]>,
    quiet: u32,
    disturbed: bool,
    hand_made: Option<u64>,
}

impl Default for Witness {
    fn default() -> Self {
        Self::new()
    }
}

impl Witness {
    /// Nothing seen yet (power-on).
    pub fn new() -> Self {
        Witness {
            ticks: 0,
            last_injection: None,
            homing_started: None,
            rest_q: [f64::NAN; AXES],
            offsets: None,
            quiet: 0,
            disturbed: false,
            hand_made: None,
        }
    }

    /// An injection in the coming tick (a hand-made sensor value, a slip).
    pub fn injected(&mut self) {
        self.last_injection = Some(self.ticks.saturating_add(1));
        self.hand_made = Some(self.ticks.saturating_add(1));
    }

    /// A tick begins: `plant` is what was sensed. Counts an injection when
    /// the plant is not clean or an encoder offset changed (a slip).
    pub fn before(&mut self, plant: &Plant) {
        self.ticks = self.ticks.saturating_add(1);
        let slipped = self.offsets.is_some_and(|o| o != plant.enc_offset);
        self.offsets = Some(plant.enc_offset);
        if !plant.is_clean() || slipped {
            self.last_injection = Some(self.ticks);
        }
        let moved = plant.q != self.rest_q;
        self.rest_q = plant.q;
        let injected_now = self.last_injection.is_some_and(|i| i >= self.ticks);
        self.disturbed = !plant.motion_clean() || slipped || self.hand_made.is_some_and(|i| i >= self.ticks);
        self.quiet = if moved || injected_now { 0 } else { self.quiet.saturating_add(1) };
    }

    /// The kernel's output of the tick begun with [`Witness::before`]: the
    /// facts for the monitor.
    pub fn after<S>(&mut self, plant: &Plant, out: &TickOutput<S>) -> PlantFacts {
        if out.events.iter().any(|e| matches!(e, Event::HomingStarted { .. })) {
            self.homing_started = Some(self.ticks);
        }
        PlantFacts {
            q: plant.q,
            clean_since_start: self.last_injection.is_none(),
            quiet_ticks: self.quiet,
            clean_homing: match (self.homing_started, self.last_injection) {
                (Some(h), Some(i)) => i < h,
                (_, None) => true,
                (None, Some(_)) => false,
            },
            disturbed: self.disturbed,
            broken_motor: (plant.reversed | plant.stalled) & 0b11_1111,
        }
    }
}
