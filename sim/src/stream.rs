//! The host programs' periodic motion streams and their sequence numbers,
//! shared by the simulator's runner and the twin's, so both send the same
//! frames at the same milliseconds.

use kernel::config::AXES;

use crate::client::{configurator_line, driver_line};
use crate::scenario::{Client, Motion};

/// A motion stream in progress: frames of `motion` from pose `p0`, one every
/// `1000 / rate_hz` ms from `start` to `end` (the frame at or after `end` is
/// the last).
#[derive(Clone, Debug)]
pub struct Stream {
    /// Who sends.
    pub client: Client,
    start: u64,
    end: u64,
    period: f64,
    next: f64,
    motion: Motion,
    p0: [f64; AXES],
    finished: bool,
    /// Frames are held and sent this many at once (1: each when due).
    burst: usize,
    held: Vec<String>,
}

impl Stream {
    /// A stream of `client` starting at `t` (ms) from pose `p0`.
    pub fn new(client: Client, rate_hz: f64, duration_ms: u64, motion: Motion, t: u64, p0: [f64; AXES]) -> Self {
        Stream {
            client,
            start: t,
            end: t + duration_ms,
            period: 1000.0 / rate_hz,
            next: t as f64,
            motion,
            p0,
            finished: false,
            burst: 1,
            held: Vec::new(),
        }
    }

    /// The same stream delivered `n` frames at once (a loaded host, a USB
    /// stack that coalesces): each frame is made when due and held until
    /// `n` are waiting or the stream ends.
    pub fn with_burst(mut self, n: usize) -> Self {
        self.burst = n.max(1);
        self
    }

    /// Its last frame has been sent.
    pub fn finished(&self) -> bool {
        self.finished
    }

    /// The continuous reference pose and velocity at `t` (ms); the jog's
    /// final pose, at velocity 0, after its end.
    pub fn sample(&self, t: u64) -> ([f64; AXES], [f64; AXES]) {
        self.motion.sample(&self.p0, self.start, self.end, t)
    }

    /// The pose and velocity of the frame due at `t` (ms), if one is due;
    /// calls at every millisecond in order.
    pub fn due(&mut self, t: u64) -> Option<([f64; AXES], [f64; AXES])> {
        if self.finished || (t as f64) + 1e-9 < self.next {
            return None;
        }
        self.next += self.period;
        self.finished = t >= self.end;
        Some(self.sample(t))
    }
}

/// The two host programs' sequence numbers: each formats its frames with
/// its own counter, starting at 0.
#[derive(Clone, Debug, Default)]
pub struct Hosts {
    driver_seq: u32,
    config_seq: u32,
}

impl Hosts {
    /// `client`'s next frame for pose `p` and velocity `v`.
    pub fn frame(&mut self, client: Client, p: &[f64; AXES], v: &[f64; AXES]) -> String {
        match client {
            Client::Driver => {
                let l = driver_line(self.driver_seq, p, v);
                self.driver_seq = self.driver_seq.wrapping_add(1);
                l
            }
            Client::Configurator => {
                let l = configurator_line(self.config_seq, p, v);
                self.config_seq = self.config_seq.wrapping_add(1);
                l
            }
        }
    }

    /// The frames `streams` send at `t` (ms), in stream order.
    pub fn due(&mut self, streams: &mut [Stream], t: u64) -> Vec<String> {
        let mut lines = Vec::new();
        for s in streams.iter_mut() {
            if let Some((p, v)) = s.due(t) {
                s.held.push(self.frame(s.client, &p, &v));
                if s.held.len() >= s.burst || s.finished {
                    lines.append(&mut s.held);
                }
            }
        }
        lines
    }
}
