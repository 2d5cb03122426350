//! Queues between the main loop (host side) and the 1 kHz tick, built on
//! `heapless::spsc::Queue` (lock-free, single producer, single consumer).
//!
//! A [`Link`] holds two queues and splits into a [`HostEnd`] (main loop:
//! sends commands, receives telemetry) and a [`TickEnd`] (interrupt: receives
//! commands, sends telemetry). A whole [`Command`] or [`Telemetry`] is one
//! queue element, so the other side never sees a torn update.
//!
//! # Overflow policy
//!
//! - **Commands** (host to tick; the tick takes at most one per tick at
//!   1 kHz; a burst of frames read at once can fill it, so the main loop
//!   reads input only while [`HostEnd::has_room`] holds and the burst
//!   waits in the port): the last [`CONTROL_RESERVE`] slots are reserved for
//!   `HOME`, `HOMEn` and `ENABLE`. A motion target that would take a reserved
//!   slot is *rejected* (the newest is dropped: a single-producer queue cannot
//!   drop its oldest element from the producer side), counted and returned as
//!   [`QueueFull`] for a `QUEUE_FULL` report line. A control command is
//!   refused only if even the reserved slots are full; it is then also
//!   returned as [`QueueFull`] and reported, never dropped silently.
//! - **Telemetry** (tick to host): the tick never blocks. An element that
//!   does not fit is dropped and counted; the count is delivered as
//!   [`Telemetry::Lost`] ahead of the next element that fits.

use crate::Command;
use core::sync::atomic::{AtomicBool, Ordering};
use heapless::spsc::{Consumer, Producer, Queue};
use kernel::{Event, Status};

/// Command-queue slots only control commands (HOME, HOMEn, ENABLE) may use.
pub const CONTROL_RESERVE: usize = 2;

/// What the tick sends back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Telemetry<S> {
    /// A status snapshot for a feedback line, with the measured duration of
    /// the control interrupt (us).
    Status {
        /// The kernel's status.
        status: Status<S>,
        /// Duration of the control interrupt (us).
        tick_us: u32,
        /// SEQ of the last motion frame the kernel took (handed to it and
        /// not refused), for the feedback's ACK field; 0 before the first.
        ack: u32,
    },
    /// A kernel event.
    Event(Event),
    /// The kernel's per-tick event list overflowed by this many.
    EventsLost(u8),
    /// This many telemetry elements were dropped because the queue was full.
    Lost(u32),
}

/// A command that could not be queued.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QueueFull<S> {
    /// The command.
    pub command: Command<S>,
    /// Commands refused so far (saturating), this one included.
    pub count: u32,
}

/// Two SPSC queues: `C` command slots and `T` telemetry slots (a
/// `heapless::spsc::Queue<_, N>` holds `N - 1` elements).
pub struct Link<S, const C: usize = 8, const T: usize = 16> {
    commands: Queue<Command<S>, C>,
    telemetry: Queue<Telemetry<S>, T>,
    /// The host link is gone (set by the main loop, read by the tick). A
    /// single flag, written by one side only: `Relaxed` suffices (no data
    /// is published through it).
    link_lost: AtomicBool,
    /// The arm is at rest (set by the tick every tick from the kernel, read
    /// by the main loop: a reboot into the bootloader is honoured only
    /// then). Starts false; one writer, `Relaxed` as above.
    at_rest: AtomicBool,
}

impl<S, const C: usize, const T: usize> core::fmt::Debug for Link<S, C, T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Link")
            .field("commands", &self.commands.len())
            .field("telemetry", &self.telemetry.len())
            .finish()
    }
}

impl<S, const C: usize, const T: usize> Default for Link<S, C, T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<S, const C: usize, const T: usize> Link<S, C, T> {
    const SIZES_OK: () = assert!(C > CONTROL_RESERVE + 1 && T >= 2, "command queue too small for the reserve");

    /// Empty queues (usable in a `static`).
    pub const fn new() -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::SIZES_OK;
        Link {
            commands: Queue::new(),
            telemetry: Queue::new(),
            link_lost: AtomicBool::new(false),
            at_rest: AtomicBool::new(false),
        }
    }

    /// Splits into the main loop's end and the tick's end.
    pub fn split(&mut self) -> (HostEnd<'_, S, C, T>, TickEnd<'_, S, C, T>) {
        let (cmd_tx, cmd_rx) = self.commands.split();
        let (tel_tx, tel_rx) = self.telemetry.split();
        let (flag, rest) = (&self.link_lost, &self.at_rest);
        (
            HostEnd { cmd_tx, tel_rx, refused: 0, link_lost: flag, at_rest: rest },
            TickEnd { cmd_rx, tel_tx, lost: 0, link_lost: flag, at_rest: rest },
        )
    }
}

/// The main loop's end: sends commands, receives telemetry.
pub struct HostEnd<'a, S, const C: usize, const T: usize> {
    cmd_tx: Producer<'a, Command<S>, C>,
    tel_rx: Consumer<'a, Telemetry<S>, T>,
    refused: u32,
    link_lost: &'a AtomicBool,
    at_rest: &'a AtomicBool,
}

impl<S, const C: usize, const T: usize> core::fmt::Debug for HostEnd<'_, S, C, T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("HostEnd").field("queued", &self.cmd_tx.len()).field("refused", &self.refused).finish()
    }
}

impl<S: Copy, const C: usize, const T: usize> HostEnd<'_, S, C, T> {
    /// Queues a command under the overflow policy (module docs).
    pub fn send(&mut self, command: Command<S>) -> Result<(), QueueFull<S>> {
        let free = self.cmd_tx.capacity().saturating_sub(self.cmd_tx.len());
        let fits = if command.is_motion() { free > CONTROL_RESERVE } else { free > 0 };
        let sent = if fits { self.cmd_tx.enqueue(command).is_ok() } else { false };
        if sent {
            Ok(())
        } else {
            self.refused = self.refused.saturating_add(1);
            Err(QueueFull { command, count: self.refused })
        }
    }
    /// True when a motion command would be queued now (room beyond the
    /// [`CONTROL_RESERVE`]): any command then fits. The main loop reads
    /// input only while this holds, so a burst waits in the port instead
    /// of being dropped (the tick only frees slots).
    pub fn has_room(&self) -> bool {
        self.cmd_tx.capacity().saturating_sub(self.cmd_tx.len()) > CONTROL_RESERVE
    }
    /// Next telemetry element, if any.
    pub fn recv(&mut self) -> Option<Telemetry<S>> {
        self.tel_rx.dequeue()
    }
    /// Commands refused so far.
    pub fn refused(&self) -> u32 {
        self.refused
    }
    /// Tells the tick whether the transport knows the host link is gone.
    pub fn set_link_lost(&self, lost: bool) {
        self.link_lost.store(lost, Ordering::Relaxed);
    }
    /// The arm was at rest at the last tick (false before the first).
    pub fn at_rest(&self) -> bool {
        self.at_rest.load(Ordering::Relaxed)
    }
}

/// The tick's end: receives commands, sends telemetry.
pub struct TickEnd<'a, S, const C: usize, const T: usize> {
    cmd_rx: Consumer<'a, Command<S>, C>,
    tel_tx: Producer<'a, Telemetry<S>, T>,
    lost: u32,
    link_lost: &'a AtomicBool,
    at_rest: &'a AtomicBool,
}

impl<S, const C: usize, const T: usize> core::fmt::Debug for TickEnd<'_, S, C, T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("TickEnd").field("pending", &self.cmd_rx.len()).field("lost", &self.lost).finish()
    }
}

impl<S: Copy, const C: usize, const T: usize> TickEnd<'_, S, C, T> {
    /// Next command, if any (take at most one per tick: the kernel handles
    /// one request per tick).
    pub fn recv(&mut self) -> Option<Command<S>> {
        self.cmd_rx.dequeue()
    }
    /// Sends telemetry without blocking; returns false if it was dropped
    /// (counted and reported later as [`Telemetry::Lost`]).
    pub fn send(&mut self, t: Telemetry<S>) -> bool {
        if self.lost > 0 {
            if self.tel_tx.enqueue(Telemetry::Lost(self.lost)).is_ok() {
                self.lost = 0;
            } else {
                self.lost = self.lost.saturating_add(1);
                return false;
            }
        }
        if self.tel_tx.enqueue(t).is_ok() {
            true
        } else {
            self.lost = self.lost.saturating_add(1);
            false
        }
    }
    /// Elements dropped and not yet reported.
    pub fn lost(&self) -> u32 {
        self.lost
    }
    /// The host link is known to be gone (set by the main loop).
    pub fn link_lost(&self) -> bool {
        self.link_lost.load(Ordering::Relaxed)
    }
    /// Tells the main loop whether the arm is at rest (once per tick).
    pub fn set_at_rest(&self, at_rest: bool) {
        self.at_rest.store(at_rest, Ordering::Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kernel::MotionTarget;

    fn motion(seq: u32) -> Command<f32> {
        Command::Motion {
            seq,
            dialect: crate::Dialect::Driver,
            target: MotionTarget { position: [0.0; 6], velocity: [0.0; 6], kind: kernel::MotionKind::Stream },
        }
    }

    #[test]
    fn queue_overflow_policy_reserves_control_slots() {
        let mut link: Link<f32, 8, 4> = Link::new();
        let (mut host, mut tick) = link.split();
        // capacity 7, reserve 2: 5 motion targets fit
        for s in 0..5 {
            assert!(host.send(motion(s)).is_ok());
        }
        assert_eq!(host.send(motion(5)), Err(QueueFull { command: motion(5), count: 1 }));
        assert!(host.send(Command::Home).is_ok());
        assert!(host.send(Command::Enable).is_ok());
        assert_eq!(host.send(Command::HomeJoint(2)), Err(QueueFull { command: Command::HomeJoint(2), count: 2 }));
        // FIFO order, whole elements
        let got: Vec<_> = core::iter::from_fn(|| tick.recv()).collect();
        assert_eq!(got.len(), 7);
        assert_eq!(got[0], motion(0));
        assert_eq!(got[5], Command::Home);
        assert_eq!(got[6], Command::Enable);
        assert_eq!(host.refused(), 2);
    }

    #[test]
    fn queue_telemetry_loss_is_reported() {
        let mut link: Link<f32, 8, 4> = Link::new();
        let (mut host, mut tick) = link.split();
        for _ in 0..3 {
            assert!(tick.send(Telemetry::Event(Event::Stopped)));
        }
        assert!(!tick.send(Telemetry::Event(Event::Ready)));
        assert!(!tick.send(Telemetry::Event(Event::Ready)));
        assert_eq!(tick.lost(), 2);
        assert_eq!(host.recv(), Some(Telemetry::Event(Event::Stopped)));
        // one slot free: the loss report goes first, the event is lost too
        assert!(!tick.send(Telemetry::Event(Event::Ready)));
        assert_eq!(tick.lost(), 1);
        assert_eq!(host.recv(), Some(Telemetry::Event(Event::Stopped)));
        assert_eq!(host.recv(), Some(Telemetry::Event(Event::Stopped)));
        assert_eq!(host.recv(), Some(Telemetry::Lost(2)));
        assert!(tick.send(Telemetry::Event(Event::Ready)));
        assert_eq!(host.recv(), Some(Telemetry::Lost(1)));
        assert_eq!(host.recv(), Some(Telemetry::Event(Event::Ready)));
        assert_eq!(host.recv(), None);
    }

    #[test]
    fn queue_threads_spsc_transfer_is_whole_and_ordered() {
        // Small enough for Miri: producer and consumer on two threads.
        let mut link: Link<f32, 4, 4> = Link::new();
        let (mut host, mut tick) = link.split();
        const N: u32 = 40;
        std::thread::scope(|s| {
            s.spawn(move || {
                let mut seq = 0;
                while seq < N {
                    let c = Command::Motion {
                        seq,
                        dialect: crate::Dialect::Driver,
                        target: MotionTarget {
                            position: [seq as f32; 6],
                            velocity: [-(seq as f32); 6],
                            kind: kernel::MotionKind::Stream,
                        },
                    };
                    if host.send(c).is_ok() {
                        seq += 1;
                    } else {
                        std::thread::yield_now();
                    }
                }
            });
            s.spawn(move || {
                let mut next = 0;
                while next < N {
                    match tick.recv() {
                        Some(Command::Motion { seq, target, .. }) => {
                            assert_eq!(seq, next);
                            assert!(target.position.iter().all(|p| *p == seq as f32));
                            assert!(target.velocity.iter().all(|v| *v == -(seq as f32)));
                            next += 1;
                        }
                        Some(other) => panic!("unexpected {other:?}"),
                        None => std::thread::yield_now(),
                    }
                }
            });
        });
    }
}
