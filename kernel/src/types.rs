//! The kernel's public data: what goes into a tick and what comes out.

use core::sync::atomic::{AtomicU32, Ordering};

use crate::config::AXES;
use crate::homing::Phase;
use crate::scalar::Scalar;

/// One encoder reading as delivered by the HAL.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EncoderSample {
    /// A valid 12-bit count (0..=4095). Larger values are treated as lost.
    Count(u16),
    /// No valid reading this tick (no signal, duty out of range, ...).
    Lost,
}

/// A fault detected by the hardware layer and passed in with the sensors.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum HardwareFault {
    /// The previous tick was still running when this one became due.
    TickOverrun,
    /// A stepper driver reported a fault (axis index 0..=5).
    Driver {
        /// Axis index.
        axis: u8,
    },
    /// Start-up self-test failed (code defined by the firmware).
    SelfTest(u8),
    /// A stepper driver's own diagnostics, read over its SPI link, name a
    /// problem (axis index 0..=5). Distinct from [`HardwareFault::Driver`],
    /// which is a step rate the step generator refused.
    DriverDiagnostic {
        /// Axis index.
        axis: u8,
        /// What the driver reported.
        cause: DriverCause,
    },
}

/// What a stepper driver's diagnostics reported
/// ([`HardwareFault::DriverDiagnostic`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DriverCause {
    /// The driver does not answer on its link.
    Missing,
    /// The driver answers with another chip's version.
    WrongVersion,
    /// The driver reset (lost its supply) while running.
    Reset,
    /// The driver switched its bridges off (overtemperature or a short)
    /// and its status does not say which.
    DriverError,
    /// Charge pump undervoltage: the driver is disabled.
    ChargePump,
    /// Overtemperature shutdown.
    Overtemperature,
    /// A motor phase shorted to ground.
    ShortToGround,
    /// A motor phase shorted to the supply.
    ShortToSupply,
    /// A motor phase open (a coil not connected).
    OpenLoad,
}

/// Everything sensed in one tick.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sense {
    /// Encoder readings J1..J6.
    pub encoders: [EncoderSample; AXES],
    /// Debounced limit switches, bit `i` = J(i+1) pressed. Bits 6, 7 ignored.
    pub limits: u8,
    /// A hardware fault, if one was detected since the last tick.
    pub hardware_fault: Option<HardwareFault>,
    /// The host link is known to be gone (USB: port closed by the host,
    /// bus suspend or reset). While the arm moves this is a soft E-stop at
    /// once; a transport that cannot tell (a UART) always passes `false`.
    pub link_lost: bool,
}

/// How a motion target is to be followed (decided by the parser from the
/// frame's dialect, `docs/PROTOCOL.md` section 6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MotionKind {
    /// One sample of a stream (every driver frame; configurator frames with
    /// a nonzero velocity): interpolated over the typical sample interval,
    /// refused if it is farther from the set-point than a segment can
    /// travel ([`Reject::TargetJump`]), and cut by the command timeout.
    Stream,
    /// A point-to-point move (a configurator frame whose six velocities are
    /// all zero): an acceleration-limited move at the joints' speed limits
    /// that completes without further commands and then holds.
    GoTo,
}

/// A motion target in joint space (rad, rad/s), from the host.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionTarget<S> {
    /// Target joint positions J1..J6.
    pub position: [S; AXES],
    /// Host velocities J1..J6: validated (finite, within the joint's limit)
    /// but not used as feed-forward; see [`crate::interp`].
    pub velocity: [S; AXES],
    /// Stream sample or point-to-point move.
    pub kind: MotionKind,
}

/// The identity of one kernel instance, drawn from a global counter by
/// [`crate::Kernel::new`] (and [`crate::Kernel::fork`]). It ties an
/// [`Authority`] and its [`EnableCapability`] tokens to the kernel that
/// minted them. It identifies, it does not describe: it takes no part in the
/// kernel's `Hash` (the model check) and no decision but the capability
/// check reads it. A clone of a kernel keeps its identity (it is a snapshot
/// of the same kernel). The counter wraps after 2^32 kernels, far beyond any
/// process that makes one kernel per arm.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct KernelId(u32);

/// The next kernel identity. `fetch_add` on an `AtomicU32` is available on
/// the host and on `thumbv7em` (LDREX/STREX), needs no `unsafe`, and wraps
/// rather than panicking.
static NEXT_KERNEL_ID: AtomicU32 = AtomicU32::new(0);

impl KernelId {
    /// A kernel identity not handed out before (until the counter wraps).
    pub(crate) fn fresh() -> Self {
        KernelId(NEXT_KERNEL_ID.fetch_add(1, Ordering::Relaxed))
    }
}

/// Proof that trusted code authorised clearing a latched stop or fault.
///
/// It can only be made by [`Authority::enable`], and the only [`Authority`]
/// for a kernel is the one returned with it by [`crate::Kernel::new`]. Code
/// that only parses host input (the protocol crate) never holds it, so it
/// cannot clear a fault on its own; the composition root (firmware main loop
/// or simulator) decides to turn a host `<ENABLE>` into a capability.
///
/// The token carries the identity of the kernel whose [`Authority`] minted
/// it: any other kernel refuses it with [`Reject::ForeignCapability`] and
/// clears nothing, so a second `Kernel::new` elsewhere in the program yields
/// no power over the first.
///
/// It cannot be built outside the kernel crate (its field is private):
///
/// ```compile_fail,E0451
/// let cap = kernel::EnableCapability { kernel: unimplemented!() };
/// ```
///
/// ```compile_fail,E0599
/// let cap = kernel::EnableCapability::default();
/// ```
///
/// and it cannot be duplicated, so one token clears at most once:
///
/// ```compile_fail,E0599
/// use kernel::{config::{PAROL6, PAROL6_VALIDATED}, KernelF32};
/// let (_k, authority) = KernelF32::new(&PAROL6_VALIDATED);
/// let cap = authority.enable();
/// let again = cap.clone();
/// ```
///
/// ```compile_fail,E0382
/// use kernel::{config::{PAROL6, PAROL6_VALIDATED}, KernelF32, Request};
/// let (_k, authority) = KernelF32::new(&PAROL6_VALIDATED);
/// let cap = authority.enable();
/// let first: Request<f32> = Request::Enable(cap);
/// let second: Request<f32> = Request::Enable(cap); // moved: not `Copy`
/// ```
#[derive(Debug)]
pub struct EnableCapability {
    kernel: KernelId,
}

impl EnableCapability {
    /// The kernel whose [`Authority`] minted this token.
    pub(crate) fn kernel(&self) -> KernelId {
        self.kernel
    }
}

/// The right to mint [`EnableCapability`] tokens for one kernel. Not
/// `Clone`, not `Copy`, and not constructible outside the kernel crate:
///
/// ```compile_fail,E0451
/// let authority = kernel::Authority { kernel: unimplemented!() };
/// ```
///
/// ```compile_fail,E0599
/// let authority = kernel::Authority::default();
/// ```
///
/// ```compile_fail,E0599
/// use kernel::{config::{PAROL6, PAROL6_VALIDATED}, KernelF32};
/// let (_k, authority) = KernelF32::new(&PAROL6_VALIDATED);
/// let copy = authority.clone();
/// ```
///
/// ```compile_fail,E0382
/// use kernel::{config::{PAROL6, PAROL6_VALIDATED}, KernelF32};
/// let (_k, authority) = KernelF32::new(&PAROL6_VALIDATED);
/// let first = authority;
/// let second = authority; // moved: not `Copy`
/// ```
///
/// A second kernel's authority is no authority over the first:
///
/// ```
/// use kernel::{config::{PAROL6, PAROL6_VALIDATED}, EncoderSample, Event, HardwareFault, KernelF32, Reject, Request, Sense, State};
/// let (mut a, _authority_a) = KernelF32::new(&PAROL6_VALIDATED);
/// let (_b, authority_b) = KernelF32::new(&PAROL6_VALIDATED);
/// let ok = Sense { encoders: [EncoderSample::Count(1000); 6], limits: 0, hardware_fault: None, link_lost: false };
/// a.tick(&Sense { hardware_fault: Some(HardwareFault::TickOverrun), ..ok }, None);
/// assert_eq!(a.state(), State::Fault);
/// let out = a.tick(&ok, Some(Request::Enable(authority_b.enable())));
/// assert!(out.events.iter().any(|e| matches!(e, Event::Rejected { reason: Reject::ForeignCapability, .. })));
/// assert_eq!(a.state(), State::Fault); // still latched
/// ```
#[derive(Debug)]
pub struct Authority {
    kernel: KernelId,
}

impl Authority {
    /// The authority of the kernel with identity `kernel`; only
    /// [`crate::Kernel::new`] and [`crate::Kernel::fork`] call this.
    pub(crate) const fn new(kernel: KernelId) -> Self {
        Authority { kernel }
    }
    /// Mints one capability to clear a latched stop or fault of this
    /// authority's kernel (and of no other).
    pub fn enable(&self) -> EnableCapability {
        EnableCapability { kernel: self.kernel }
    }
}

/// A request to the kernel. At most one is handled per tick.
#[derive(Debug)]
pub enum Request<S> {
    /// New motion target.
    Motion(MotionTarget<S>),
    /// Home every axis in the arm's order (docs/spec/robot.md section 4).
    Home,
    /// Home one joint (index 0..=5 for J1..J6); allowed only when the
    /// joints it depends on are homed.
    HomeJoint(u8),
    /// Clear a latched soft E-stop or fault.
    Enable(EnableCapability),
}

/// The kind of a request, for reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RequestKind {
    /// [`Request::Motion`].
    Motion,
    /// [`Request::Home`].
    Home,
    /// [`Request::HomeJoint`].
    HomeJoint(u8),
    /// [`Request::Enable`].
    Enable,
}

impl<S> Request<S> {
    /// The kind of this request.
    pub fn kind(&self) -> RequestKind {
        match self {
            Request::Motion(_) => RequestKind::Motion,
            Request::Home => RequestKind::Home,
            Request::HomeJoint(j) => RequestKind::HomeJoint(*j),
            Request::Enable(_) => RequestKind::Enable,
        }
    }
}

/// Supervisor state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum State {
    /// Waiting for a first valid reading of every encoder. Outputs zero.
    Boot,
    /// Not (fully) homed. Outputs zero; motion refused.
    Unhomed,
    /// Homing in progress.
    Homing,
    /// Homed and following targets.
    Operational,
    /// Soft E-stop: decelerating every axis together to zero.
    Stopping,
    /// Soft E-stop: stopped, latched until enable.
    SoftEstop,
    /// Fault: outputs zero, latched until enable.
    Fault,
}

/// Homing status as the ROS 2 driver understands it (`H0`..`H3`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum HomingStatus {
    /// Never requested (or a per-joint run left some joints unhomed).
    NotRequested = 0,
    /// In progress.
    InProgress = 1,
    /// Every joint homed.
    Complete = 2,
    /// The last homing run failed.
    Failed = 3,
}

impl HomingStatus {
    /// The digit of the `H<d>` token.
    pub const fn as_u8(self) -> u8 {
        self as u8
    }
}

/// Why the kernel faulted. The first reason is latched.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FaultReason {
    /// The encoder of `axis` gave no valid reading.
    EncoderLost {
        /// Axis index.
        axis: u8,
    },
    /// The encoder of `axis` moved more than is physically possible in a tick.
    EncoderJump {
        /// Axis index.
        axis: u8,
        /// The step seen, in counts.
        delta: i32,
    },
    /// The encoder of `axis` gave no valid reading within the boot timeout.
    EncoderNotReady {
        /// Axis index.
        axis: u8,
    },
    /// The measured speed of `axis` exceeded its runaway threshold.
    Runaway {
        /// Axis index.
        axis: u8,
    },
    /// The limit switch of `axis` was pressed outside homing.
    LimitSwitch {
        /// Axis index.
        axis: u8,
    },
    /// The estimated position of homed `axis` left its limits plus margin.
    PositionLimit {
        /// Axis index.
        axis: u8,
    },
    /// A non-finite or absurd value in the state or output of `axis`.
    Numeric {
        /// Axis index.
        axis: u8,
    },
    /// Homing of `axis` did not finish `phase` in time.
    HomingTimeout {
        /// Axis index.
        axis: u8,
        /// Phase that timed out.
        phase: Phase,
    },
    /// Homing of `axis` travelled farther in `phase` than it may (a dead
    /// switch or a reversed motor), before reaching the hard stop.
    HomingTravel {
        /// Axis index.
        axis: u8,
        /// Phase that travelled too far.
        phase: Phase,
    },
    /// The estimate of `axis` stayed farther from its commanded path than
    /// the following-error bound (or moved against the command) for longer
    /// than allowed: a stalled, reversed or step-losing motor.
    FollowingError {
        /// Axis index.
        axis: u8,
    },
    /// Reported by the hardware layer.
    Hardware(HardwareFault),
}

/// A latched fault: the first reason and the tick it happened.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fault {
    /// The first reason.
    pub reason: FaultReason,
    /// Kernel tick count when it was latched.
    pub tick: u32,
}

/// Why a request was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reject {
    /// Encoders not yet initialised.
    Booting,
    /// Motion while not homed.
    NotHomed,
    /// Motion or home while homing.
    Homing,
    /// A soft E-stop or fault is latched: enable first (motion, and
    /// `<HOME>` too: only `<ENABLE>` clears a latch).
    Latched,
    /// A stream sample farther from the set-point (and from the previous
    /// target) than one segment can travel at the joint's speed limit plus
    /// the tolerance: a stale or desynchronised host.
    TargetJump {
        /// Axis index.
        axis: u8,
    },
    /// An internal limit was hit (never expected for a checked
    /// configuration); nothing was applied.
    Internal,
    /// The soft E-stop ramp is still running.
    Stopping,
    /// A target position outside the joint's limits.
    PositionOutOfLimits {
        /// Axis index.
        axis: u8,
    },
    /// A velocity above the joint's limit.
    VelocityTooHigh {
        /// Axis index.
        axis: u8,
    },
    /// A NaN or infinite value.
    NonFinite {
        /// Axis index.
        axis: u8,
    },
    /// Joint index out of range.
    NoSuchJoint,
    /// Per-joint homing while a joint it depends on is not homed.
    DependencyNotHomed {
        /// Bitmask of the joints that must be homed first.
        needs: u8,
    },
    /// Enable while nothing is latched.
    NothingToClear,
    /// Enable while a fault condition is still present.
    CauseActive(FaultReason),
    /// Enable with a capability minted by another kernel's [`Authority`]:
    /// refused in every state, nothing is cleared.
    ForeignCapability,
}

/// Something the host should be told about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Event {
    /// Every encoder read once; now unhomed.
    Ready,
    /// A request was refused.
    Rejected {
        /// What was refused.
        request: RequestKind,
        /// Why.
        reason: Reject,
    },
    /// `<HOME>` arrived while booting: homing starts as soon as every
    /// encoder has been read (the ROS 2 driver sends it only once).
    HomingQueued,
    /// Homing started for the joints in `mask`.
    HomingStarted {
        /// Joints being homed.
        mask: u8,
    },
    /// Homing finished for the joints in `mask`.
    HomingDone {
        /// Joints homed.
        mask: u8,
    },
    /// A fault was latched (homing failures included).
    Fault(FaultReason),
    /// The soft E-stop ramp started.
    SoftEstop {
        /// Why.
        cause: StopCause,
    },
    /// The command timeout expired with every joint at rest at its target:
    /// the arm holds, nothing is latched, the next command continues.
    Holding,
    /// `<HOME>` while the arm moved: a controlled stop first, then homing
    /// starts (reported by [`Event::HomingStarted`]).
    HomingAfterStop,
    /// The soft E-stop ramp reached zero.
    Stopped,
    /// A latched stop or fault was cleared; the new state.
    Enabled(State),
}

/// Why a soft E-stop started.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopCause {
    /// No motion command for longer than the timeout while moving.
    CommandTimeout {
        /// Time since the last accepted motion command (ms).
        since_command_ms: u32,
    },
    /// The transport reported the host link gone while moving.
    LinkLost,
}

/// Maximum events per tick: one per source (request, sensing/supervision
/// fault, homing, timeout or ramp), so the list cannot overflow; overflow is
/// still counted rather than lost silently.
pub const MAX_EVENTS: usize = 4;

/// The events of one tick.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Events {
    list: [Option<Event>; MAX_EVENTS],
    len: u8,
    dropped: u8,
}

impl Default for Events {
    fn default() -> Self {
        Events::new()
    }
}

impl Events {
    /// No events.
    pub const fn new() -> Self {
        Events { list: [None; MAX_EVENTS], len: 0, dropped: 0 }
    }
    /// Forgets every event (the start of a tick).
    pub fn clear(&mut self) {
        *self = Events::new();
    }
    pub(crate) fn push(&mut self, e: Event) {
        match self.list.get_mut(usize::from(self.len)) {
            Some(slot) => {
                *slot = Some(e);
                self.len = self.len.saturating_add(1);
            }
            None => self.dropped = self.dropped.saturating_add(1),
        }
    }
    /// The events, in the order they happened.
    pub fn iter(&self) -> impl Iterator<Item = &Event> + '_ {
        self.list.iter().flatten()
    }
    /// Events that did not fit (never expected; reported if it happens).
    pub fn dropped(&self) -> u8 {
        self.dropped
    }
    /// True if there are no events.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
    /// Number of events.
    pub fn len(&self) -> usize {
        usize::from(self.len)
    }
}

/// What to apply to the motors this tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Actuation<S> {
    /// Joint velocity commands (rad/s).
    pub velocity: [S; AXES],
    /// Signed step rates (steps/s), motor direction applied.
    pub step_rate: [i32; AXES],
}

impl<S: Scalar> Actuation<S> {
    /// Every axis at rest.
    pub fn zero() -> Self {
        Actuation { velocity: [S::ZERO; AXES], step_rate: [0; AXES] }
    }
}

/// What to report to the host.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Status<S> {
    /// Supervisor state.
    pub state: State,
    /// Homing status for the `H<d>` token.
    pub homing: HomingStatus,
    /// The latched fault, if any.
    pub fault: Option<Fault>,
    /// Estimated joint positions (rad).
    pub position: [S; AXES],
    /// Estimated joint velocities (rad/s).
    pub velocity: [S; AXES],
    /// Current set-points (rad).
    pub setpoint: [S; AXES],
    /// Limit switches pressed (bit per joint).
    pub limits: u8,
    /// Joints homed (bit per joint).
    pub homed: u8,
    /// The command timeout is armed.
    pub timeout_armed: bool,
    /// Ticks since the kernel started.
    pub tick: u32,
}

/// The result of one tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TickOutput<S> {
    /// Outputs, all checked before any is returned.
    pub act: Actuation<S>,
    /// Status to report.
    pub status: Status<S>,
    /// Events to report.
    pub events: Events,
}
