//! The simulator's board: the firmware's composition root
//! ([`firmware::root`], the code that is flashed) on a simulated arm.
//!
//! Only the board binding is the simulator's own: [`SimBoard`] implements
//! [`TickBoard`] over the [`Plant`] (QuadTimer capture snapshots, raw limit
//! levels, step commands at the rate the step generator produces them) and
//! [`SimPort`] implements [`Port`] over in-memory bytes or a pseudo-terminal.
//! Decode, debounce, sensing, the kernel, the enable authority, actuation,
//! telemetry, line formatting and the transmit policy are
//! `firmware::root`, the same type the Teensy image builds (see the test
//! `firmware_and_simulator_share_the_root` in `sim/tests/live.rs`).

use std::collections::VecDeque;
use std::time::Instant;

use firmware::board::{Port, TickBoard};
use firmware::root::{self, Controller, Host, HostConfig, RootLink, TickRecord};
use firmware::tx::TxCounters;
use hal_imxrt::pure::frame::Snapshot;
use hal_imxrt::pure::step::StepCommand;
use kernel::config::{Validated, AXES};
use kernel::homing::Phase;
use kernel::{KernelF32, MotionTarget, RequestKind, Sense, TickOutput};

use crate::encoder::DecodeStats;
use crate::plant::{Plant, PlantOptions};

/// What one step did.
#[derive(Clone, Debug)]
pub struct Step {
    /// Simulated time of this tick (ms since the first tick).
    pub t_ms: u64,
    /// The kernel's output.
    pub out: TickOutput<f32>,
    /// The request handed to the kernel this tick.
    pub request: Option<RequestKind>,
    /// The motion target of that request, if it was one.
    pub target: Option<MotionTarget<f32>>,
    /// What the kernel sensed this tick.
    pub sense: Sense,
    /// Homing phase of every axis after the tick.
    pub phases: [Phase; AXES],
    /// Every complete line the port took during this step, in order.
    pub lines: Vec<String>,
    /// The raw switch inputs the tick read, a bit per closed switch
    /// (before debouncing).
    pub raw_closed: u8,
    /// Commands the full queue refused so far (`QUEUE_FULL`).
    pub queue_refused: u32,
    /// The tick reported an overrun (injected).
    pub overrun: bool,
}

/// The simulated arm as the tick sees it.
#[derive(Debug)]
pub struct SimBoard {
    /// The simulated arm.
    pub plant: Plant,
    /// Fault injection: the next tick reports an overrun.
    pub overrun: bool,
    /// Watchdog refreshes so far.
    pub watchdog_feeds: u64,
    /// The levels of the last limit-input read (bit set: pin high, open).
    pub last_levels: u8,
    /// The last tick reported an overrun.
    pub overran: bool,
    started: Instant,
}

impl TickBoard for SimBoard {
    fn capture(&mut self) -> [Snapshot; AXES] {
        self.plant.capture()
    }
    fn limit_levels(&mut self) -> u8 {
        self.last_levels = self.plant.limit_levels();
        self.last_levels
    }
    fn apply(&mut self, cmds: &[StepCommand; AXES]) {
        self.plant.apply(cmds);
    }
    fn feed_watchdog(&mut self) {
        self.watchdog_feeds += 1;
    }
    fn cycles(&self) -> u32 {
        // The host's own time at 600 MHz: the tick duration on the
        // configurator line is the simulator's, not the Teensy's.
        // (In u64: the same value as `as_nanos() * 3 / 5` in u128 for the
        // first 195 years of a run, without 128-bit arithmetic per tick.)
        let d = self.started.elapsed();
        let ns = d.as_secs().wrapping_mul(1_000_000_000).wrapping_add(u64::from(d.subsec_nanos()));
        (ns.wrapping_mul(3) / 5) as u32
    }
    fn end_of_tick(&mut self) -> bool {
        self.overran = std::mem::take(&mut self.overrun);
        self.overran
    }
    fn boot_wait_ms(&mut self) {
        self.plant.apply(&[StepCommand::Stop; AXES]);
    }
}

/// Where the port's transmitted bytes go: returns how many it took.
pub type Sink = Box<dyn FnMut(&[u8]) -> usize + Send>;

/// A byte link to the simulated host.
pub struct SimPort {
    /// Bytes from the host not yet read by the firmware.
    pub input: VecDeque<u8>,
    /// A host has the port open (USB: configured with DTR).
    pub open: bool,
    sink: Option<Sink>,
    taken: Vec<u8>,
}

impl std::fmt::Debug for SimPort {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimPort").field("input", &self.input.len()).field("open", &self.open).finish()
    }
}

impl SimPort {
    /// An open port whose host takes every byte at once.
    pub fn unlimited() -> Self {
        SimPort { input: VecDeque::new(), open: true, sink: None, taken: Vec::new() }
    }
    /// An open port whose bytes go to `sink` (which may take fewer).
    pub fn with_sink(sink: Sink) -> Self {
        SimPort { input: VecDeque::new(), open: true, sink: Some(sink), taken: Vec::new() }
    }
}

impl Port for SimPort {
    fn is_open(&self) -> bool {
        self.open
    }
    fn read(&mut self) -> Option<u8> {
        self.input.pop_front()
    }
    fn write(&mut self, bytes: &[u8]) -> usize {
        if !self.open {
            return 0;
        }
        let n = match &mut self.sink {
            Some(s) => s(bytes).min(bytes.len()),
            None => bytes.len(),
        };
        self.taken.extend_from_slice(&bytes[..n]);
        n
    }
}

/// The firmware's composition root on a [`SimBoard`] and a [`SimPort`].
pub struct Root {
    controller: Controller<'static>,
    host: Host<'static>,
    /// The simulated board.
    pub board: SimBoard,
    /// The simulated link.
    pub port: SimPort,
    stats: [DecodeStats; AXES],
    t_ms: u64,
    partial: Vec<u8>,
}

impl std::fmt::Debug for Root {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Root").field("t_ms", &self.t_ms).field("controller", &self.controller).finish()
    }
}

impl Root {
    /// A controller on a plant, booted (the firmware's self-test ran for
    /// `SELF_TEST_MS` of simulated time), not yet ticked; an always-open
    /// port that takes every byte.
    pub fn new(cfg: &Validated, plant: PlantOptions, host: HostConfig) -> Self {
        Self::with_port(cfg, plant, host, SimPort::unlimited())
    }

    /// As [`Root::new`] on a given port.
    pub fn with_port(cfg: &Validated, plant: PlantOptions, host: HostConfig, port: SimPort) -> Self {
        // The firmware keeps its link in a `static`; the simulator leaks one
        // small link (a few kB) per controller to get the same `'static`
        // halves.
        let link: &'static mut RootLink = Box::leak(Box::new(RootLink::new()));
        let (mut controller, host) = root::new(cfg, link, host);
        let mut board = SimBoard {
            plant: Plant::new(cfg.config(), plant),
            overrun: false,
            watchdog_feeds: 0,
            last_levels: 0b11_1111,
            overran: false,
            started: Instant::now(),
        };
        let _ = controller.boot(&mut board, 0, false);
        Root { controller, host, board, port, stats: [DecodeStats::default(); AXES], t_ms: 0, partial: Vec::new() }
    }

    /// The firmware's tick half, the very type the Teensy image runs in its
    /// PIT interrupt.
    pub fn controller(&self) -> &Controller<'static> {
        &self.controller
    }

    /// The simulated arm.
    pub fn plant(&mut self) -> &mut Plant {
        &mut self.board.plant
    }

    /// Receiver counters.
    pub fn counters(&self) -> protocol::receiver::Counters {
        self.host.counters()
    }

    /// Transmit counters.
    pub fn tx_counters(&self) -> TxCounters {
        self.host.tx_counters()
    }

    /// Commands refused by the queue.
    pub fn queue_refused(&self) -> u32 {
        self.host.queue_refused()
    }

    /// Kernel (read-only).
    pub fn kernel(&self) -> &KernelF32 {
        self.controller.kernel()
    }

    /// Decode outcomes per axis (the shipped decoder's readings).
    pub fn decode_stats(&self) -> [DecodeStats; AXES] {
        self.stats
    }

    /// One millisecond: the main loop takes `input` (and whatever the port
    /// still holds), one control tick runs, then the main loop formats the
    /// telemetry and moves what the port takes.
    pub fn step(&mut self, input: &[u8]) -> Step {
        self.port.input.extend(input);
        let now = self.t_ms as u32;
        self.host.receive(&mut self.port, now);
        let rec: TickRecord = self.controller.tick(&mut self.board);
        for (s, r) in self.stats.iter_mut().zip(rec.readings) {
            s.add(r);
        }
        self.host.transmit(&mut self.port);
        self.partial.append(&mut self.port.taken);
        let mut lines = Vec::new();
        let mut from = 0;
        while let Some(nl) = self.partial[from..].iter().position(|b| *b == b'\n') {
            let end = from + nl + 1;
            let bytes = &self.partial[from..end];
            // (`from_utf8_lossy` gives the same text; valid UTF-8, the usual
            // case, is checked faster this way.)
            lines.push(match std::str::from_utf8(bytes) {
                Ok(t) => t.to_owned(),
                Err(_) => String::from_utf8_lossy(bytes).into_owned(),
            });
            from = end;
        }
        self.partial.drain(..from);
        let step = Step {
            t_ms: self.t_ms,
            out: TickOutput {
                act: rec.act,
                status: self.controller.kernel().status(rec.sense.limits),
                events: rec.events,
            },
            request: rec.request,
            target: rec.target,
            sense: rec.sense,
            phases: self.controller.homing_phases(),
            lines,
            raw_closed: !self.board.last_levels & 0b11_1111,
            queue_refused: self.host.queue_refused(),
            overrun: self.board.overran,
        };
        self.t_ms += 1;
        step
    }
}
