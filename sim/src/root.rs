//! The composition root, as in the firmware: bytes from the host go through
//! the protocol crate's [`Receiver`] (framer, parser, sequence filter) into
//! the command queue; the 1 kHz tick takes at most one command, turns
//! `<ENABLE>` into [`kernel::Request::Enable`] with the [`Authority`] it
//! alone holds, runs the kernel on the plant's sensors, applies the outputs
//! to the plant and queues status and events; the main loop turns telemetry
//! into lines with the protocol crate's formatters.

use std::time::Instant;

use kernel::config::{ArmConfig, AXES};
use kernel::homing::Phase;
use kernel::{Authority, KernelF32, RequestKind, TickOutput};
use protocol::feedback::{configurator_line, driver_line, FeedbackDivider, FeedbackMode};
use protocol::queue::{HostEnd, Link, Telemetry, TickEnd};
use protocol::receiver::{Received, Receiver};
use protocol::report::{
    banner_line, config_fingerprint, event_line, events_lost_line, queue_full_line, telemetry_lost_line,
};
use protocol::{Command, Line, ProtocolConfig};

use crate::plant::{Plant, PlantOptions};

/// Command queue slots (as the firmware's default).
pub const CMD_SLOTS: usize = 8;
/// Telemetry queue slots.
pub const TEL_SLOTS: usize = 16;

/// What one step did.
#[derive(Clone, Debug)]
pub struct Step {
    /// Simulated time of this tick (ms since power-on).
    pub t_ms: u64,
    /// The kernel's output.
    pub out: TickOutput<f32>,
    /// The request handed to the kernel this tick.
    pub request: Option<RequestKind>,
    /// The motion target of that request, if it was one.
    pub target: Option<[f32; AXES]>,
    /// Homing phase of every axis after the tick.
    pub phases: [Phase; AXES],
    /// Every line sent to the host during this step, in order.
    pub lines: Vec<String>,
}

/// Kernel, plant and protocol wired as in the firmware.
pub struct Root {
    cfg: ArmConfig,
    kernel: KernelF32,
    authority: Authority,
    /// The simulated arm.
    pub plant: Plant,
    rx: Receiver<f32>,
    host: HostEnd<'static, f32, CMD_SLOTS, TEL_SLOTS>,
    tick: TickEnd<'static, f32, CMD_SLOTS, TEL_SLOTS>,
    divider: FeedbackDivider,
    mode: FeedbackMode,
    t_ms: u64,
    line: Line,
}

impl std::fmt::Debug for Root {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Root").field("t_ms", &self.t_ms).field("state", &self.kernel.state()).finish()
    }
}

impl Root {
    /// A powered-on (not yet ticked) controller on a plant.
    pub fn new(cfg: &ArmConfig, plant: PlantOptions, mode: FeedbackMode) -> Self {
        let (kernel, authority) = KernelF32::new(cfg);
        // The firmware keeps its link in a `static`; the sim leaks one small
        // link (a few kB) per controller to get the same `'static` ends.
        let link: &'static mut Link<f32, CMD_SLOTS, TEL_SLOTS> = Box::leak(Box::new(Link::new()));
        let (host, tick) = link.split();
        Root {
            cfg: *cfg,
            kernel,
            authority,
            plant: Plant::new(cfg, plant),
            rx: Receiver::new(cfg, ProtocolConfig::DEFAULT),
            host,
            tick,
            divider: FeedbackDivider::default_for(cfg.tick_hz),
            mode,
            t_ms: 0,
            line: Line::new(),
        }
    }

    /// The boot banner line.
    pub fn banner(&mut self) -> String {
        let fp = config_fingerprint(&self.cfg);
        match banner_line(
            &mut self.line,
            concat!("sim-", env!("CARGO_PKG_VERSION")),
            fp,
            self.rx.parser().lock(),
            self.mode,
        ) {
            Ok(()) => self.line.to_string(),
            Err(_) => "BOOT (banner did not fit)\n".to_string(),
        }
    }

    /// Protocol counters.
    pub fn counters(&self) -> protocol::receiver::Counters {
        self.rx.counters()
    }

    /// Commands refused by the queue.
    pub fn queue_refused(&self) -> u32 {
        self.host.refused()
    }

    /// Kernel (read-only).
    pub fn kernel(&self) -> &KernelF32 {
        &self.kernel
    }

    fn emit(line: &Line, r: Result<(), protocol::Full>, lines: &mut Vec<String>) {
        match r {
            Ok(()) => lines.push(line.to_string()),
            Err(_) => lines.push("LINE_OVERFLOW\n".to_string()),
        }
    }

    /// One millisecond: the main loop handles `input`, then one control
    /// tick runs, then the main loop formats the telemetry.
    pub fn step(&mut self, input: &[u8]) -> Step {
        let mut lines = Vec::new();
        let now = self.t_ms as u32;
        // Main loop: bytes -> lines -> commands -> queue.
        for &b in input {
            let Some(r) = self.rx.push(b, now) else { continue };
            match r.report(&mut self.line) {
                Ok(true) => lines.push(self.line.to_string()),
                Ok(false) => {}
                Err(_) => lines.push("LINE_OVERFLOW\n".to_string()),
            }
            if let Received::Accepted { command, .. } = r {
                if let Err(q) = self.host.send(command) {
                    let res = queue_full_line(&mut self.line, &q);
                    Self::emit(&self.line, res, &mut lines);
                }
            }
        }
        // Tick: sense, one request, kernel, act.
        let sense = self.plant.sense();
        // At most one command per tick (a HOME that arrives during Boot is
        // queued by the kernel itself: Event::HomingQueued).
        let cmd = self.tick.recv();
        let target = match &cmd {
            Some(Command::Motion { target, .. }) => Some(target.position),
            _ => None,
        };
        let request = cmd.map(|c| c.into_request(&self.authority));
        let kind = request.as_ref().map(|r| r.kind());
        let started = Instant::now();
        let out = self.kernel.tick(&sense, request);
        let tick_us = started.elapsed().as_micros().min(u128::from(u32::MAX)) as u32;
        self.plant.apply(&out.act.step_rate);
        for e in out.events.iter() {
            self.tick.send(Telemetry::Event(*e));
        }
        if out.events.dropped() > 0 {
            self.tick.send(Telemetry::EventsLost(out.events.dropped()));
        }
        if self.divider.tick() {
            self.tick.send(Telemetry::Status { status: out.status, tick_us });
        }
        if self.kernel.state() == kernel::State::Fault {
            // Policy of this composition root: an encoder whose continuity
            // tracker latched re-acquires while the kernel holds a fault;
            // the kernel re-initialises that axis on ENABLE and requires
            // re-homing.
            self.plant.reset_latched_trackers();
        }
        // Main loop: telemetry -> lines.
        while let Some(t) = self.host.recv() {
            match t {
                Telemetry::Status { status, tick_us } => {
                    let seq = self.rx.last_seq();
                    if matches!(self.mode, FeedbackMode::Configurator | FeedbackMode::Both) {
                        let r = configurator_line(&mut self.line, seq, &status, tick_us);
                        Self::emit(&self.line, r, &mut lines);
                    }
                    if matches!(self.mode, FeedbackMode::Driver | FeedbackMode::Both) {
                        let r = driver_line(&mut self.line, seq, &status);
                        Self::emit(&self.line, r, &mut lines);
                    }
                }
                Telemetry::Event(e) => {
                    let r = event_line(&mut self.line, &e);
                    Self::emit(&self.line, r, &mut lines);
                }
                Telemetry::EventsLost(n) => {
                    let r = events_lost_line(&mut self.line, u32::from(n));
                    Self::emit(&self.line, r, &mut lines);
                }
                Telemetry::Lost(n) => {
                    let r = telemetry_lost_line(&mut self.line, n);
                    Self::emit(&self.line, r, &mut lines);
                }
            }
        }
        let step = Step { t_ms: self.t_ms, out, request: kind, target, phases: self.kernel.homing_phases(), lines };
        self.t_ms += 1;
        step
    }
}
