//! USB OTG1 in device mode (the i.MXRT1062's ChipIdea-style controller) as
//! far as a host's control transfers on endpoint 0 need it, and the host
//! that sends them.
//!
//! The device side is what a driver programs: `USBCMD` (`RS`, `RST`
//! self-clearing, `SUTW`), `USBSTS` (write 1 to clear), `USBINTR`,
//! `DEVICEADDR`, `ENDPTLISTADDR` (the queue-head array in RAM, 64 bytes per
//! endpoint and direction, OUT first), `ENDPTSETUPSTAT` and `ENDPTCOMPLETE`
//! (write 1 to clear), `ENDPTPRIME` (reads 0 at once: the controller takes
//! a prime immediately), `ENDPTFLUSH`, `ENDPTSTAT` (primed endpoints) and
//! `ENDPTCTRL0..7` (the stall bits of endpoint 0 are what a refused request
//! sets). A SETUP packet is written into endpoint 0's queue head (offset
//! 0x28) and flagged in `ENDPTSETUPSTAT`; a data or status stage moves
//! bytes through the transfer descriptor the queue head's overlay points at
//! (`NEXT`, `TOKEN` with `TOTAL_BYTES` and `ACTIVE`, buffer pointer 0),
//! as the controller's DMA does, then sets `ENDPTCOMPLETE`, clears
//! `ENDPTSTAT` and raises `USBSTS[UI]` if the descriptor asked for it
//! (`IOC`). A bus reset raises `USBSTS[URI]`. The interrupt (IRQ 113) is
//! requested while `USBSTS & USBINTR` has `UI` or `URI`.
//!
//! Not modelled: the bulk and interrupt endpoints' traffic, the PHY,
//! suspend and resume, high speed, frame timing (each host step takes
//! [`HOST_STEP_CYCLES`]), descriptor chains longer than one descriptor,
//! transfers larger than one packet per descriptor, and the dTD's write-back
//! into the queue head's overlay (the driver reads its own descriptor).
//!
//! The host runs a queue of control transfers ([`Control`]) in order, one
//! stage at a time, each when the device is ready for it (endpoint primed,
//! the previous SETUP read), and records each outcome ([`Done`]).

use std::collections::VecDeque;

use unicorn_engine::Unicorn;

use crate::board::Board;

/// USB OTG1 interrupt number (i.MXRT1062).
pub const IRQ_USB_OTG1: u32 = 113;
/// USB1 (OTG1) register block.
pub const USB1: u32 = 0x402E_0000;

const USBCMD: u32 = 0x140;
const USBSTS: u32 = 0x144;
const USBINTR: u32 = 0x148;
const DEVICEADDR: u32 = 0x154;
const ENDPTLISTADDR: u32 = 0x158;
const ENDPTNAK: u32 = 0x178;
const PORTSC1: u32 = 0x184;
const ENDPTSETUPSTAT: u32 = 0x1AC;
const ENDPTPRIME: u32 = 0x1B0;
const ENDPTFLUSH: u32 = 0x1B4;
const ENDPTSTAT: u32 = 0x1B8;
const ENDPTCOMPLETE: u32 = 0x1BC;
const ENDPTCTRL0: u32 = 0x1C0;

/// `USBSTS[UI]`: a transfer completed or a SETUP arrived.
const UI: u32 = 1;
/// `USBSTS[URI]`: bus reset received.
const URI: u32 = 1 << 6;
/// `PORTSC1[PR]`: the port is in reset.
const PR: u32 = 1 << 8;
/// `USBCMD[RS]`: the device is attached (run).
const RS: u32 = 1;
/// Endpoint 0's largest packet size at full speed (the device may set a
/// smaller one in its queue heads, as usb-device's default of 8 does).
pub const EP0_PACKET: usize = 64;
/// Cycles between two host steps (a transaction at full speed is of the
/// order of 10-50 us; the value only spaces the stages).
pub const HOST_STEP_CYCLES: u64 = 12_000;
/// A stage the device does not get ready for within this many cycles
/// (50 ms) ends the transfer as timed out.
pub const STAGE_TIMEOUT_CYCLES: u64 = 30_000_000;

/// One control transfer the host sends: the SETUP packet and, for a
/// host-to-device request with a data stage, its bytes (`wLength` of them).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Control {
    /// bmRequestType, bRequest, wValue, wIndex, wLength (little-endian).
    pub setup: [u8; 8],
    /// The OUT data stage.
    pub data: Vec<u8>,
}

impl Control {
    /// A request from its fields.
    pub fn new(request_type: u8, request: u8, value: u16, index: u16, length: u16, data: &[u8]) -> Self {
        let [v0, v1] = value.to_le_bytes();
        let [i0, i1] = index.to_le_bytes();
        let [l0, l1] = length.to_le_bytes();
        Control { setup: [request_type, request, v0, v1, i0, i1, l0, l1], data: data.to_vec() }
    }
    /// Standard SET_ADDRESS.
    pub fn set_address(addr: u8) -> Self {
        Self::new(0x00, 5, u16::from(addr), 0, 0, &[])
    }
    /// Standard GET_DESCRIPTOR (device descriptor, 18 bytes).
    pub fn get_device_descriptor() -> Self {
        Self::new(0x80, 6, 0x0100, 0, 18, &[])
    }
    /// Standard SET_CONFIGURATION.
    pub fn set_configuration(value: u8) -> Self {
        Self::new(0x00, 9, u16::from(value), 0, 0, &[])
    }
    /// CDC SET_LINE_CODING (class request 0x20 to interface `iface`): the
    /// 7-byte line coding (rate, one stop bit, no parity, 8 data bits),
    /// what a host's serial driver sends when a program sets the baud rate
    /// (`teensy_loader_cli -s` sets 134).
    pub fn set_line_coding(iface: u16, baud: u32) -> Self {
        let mut d = baud.to_le_bytes().to_vec();
        d.extend_from_slice(&[0, 0, 8]);
        Self::new(0x21, 0x20, 0, iface, 7, &d)
    }
    /// CDC SET_CONTROL_LINE_STATE (class request 0x22): DTR and RTS.
    pub fn set_control_line_state(iface: u16, dtr: bool, rts: bool) -> Self {
        Self::new(0x21, 0x22, u16::from(dtr) | u16::from(rts) << 1, iface, 0, &[])
    }
    fn length(&self) -> usize {
        usize::from(u16::from_le_bytes([self.setup[6], self.setup[7]]))
    }
    fn device_to_host(&self) -> bool {
        self.setup[0] & 0x80 != 0
    }
}

/// How a control transfer ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Every stage completed (the status stage acknowledged).
    Acked,
    /// The device stalled endpoint 0 (refused the request).
    Stalled,
    /// A stage found the device not ready within [`STAGE_TIMEOUT_CYCLES`].
    TimedOut,
}

/// A finished control transfer.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Done {
    /// The request.
    pub control: Control,
    /// Bytes of an IN data stage.
    pub data_in: Vec<u8>,
    /// The outcome.
    pub outcome: Outcome,
    /// When it ended (cycles).
    pub at: u64,
}

#[derive(Clone, Debug, PartialEq, Eq)]
enum Stage {
    Setup,
    DataOut { sent: usize },
    DataIn,
    StatusIn,
    StatusOut,
}

/// The host's side of the bus.
#[derive(Clone, Debug, Default)]
pub struct Host {
    /// Transfers not yet started.
    pub queue: VecDeque<Control>,
    /// A bus reset waits to be signalled before the next transfer.
    pub reset_pending: bool,
    cur: Option<(Control, Stage, Vec<u8>, u64)>,
    /// Finished transfers, in order.
    pub done: Vec<Done>,
    /// The next time the host acts (`u64::MAX`: when the device next
    /// writes a USB register, or at a stage's timeout).
    next_at: u64,
}

/// The controller's registers and the host.
#[derive(Clone, Debug)]
pub struct Usb {
    usbcmd: u32,
    usbsts: u32,
    usbintr: u32,
    deviceaddr: u32,
    listaddr: u32,
    portsc1: u32,
    setupstat: u32,
    stat: u32,
    complete: u32,
    ctrl: [u32; 8],
    /// Other registers, as written.
    other: rustc_hash::FxHashMap<u32, u32>,
    /// Primes of an endpoint other than 0 whose `ENDPTCTRL` enable bit
    /// (`RXE`/`TXE`) was clear: (time, `ENDPTPRIME` bit). A driver enables
    /// its bulk endpoints once the host configured the device; what the
    /// controller does with such a prime is not modelled.
    pub disabled_primes: Vec<(u64, u32)>,
    /// The host.
    pub host: Host,
}

impl Default for Usb {
    fn default() -> Self {
        Usb {
            usbcmd: 0,
            usbsts: 0,
            usbintr: 0,
            deviceaddr: 0,
            listaddr: 0,
            portsc1: 0,
            setupstat: 0,
            stat: 0,
            complete: 0,
            // endpoint 0 is always enabled, as a control endpoint
            ctrl: [0x0080_0080, 0, 0, 0, 0, 0, 0, 0],
            other: Default::default(),
            disabled_primes: Vec::new(),
            host: Host { next_at: u64::MAX, ..Host::default() },
        }
    }
}

impl Usb {
    /// Chip reset: registers to reset, the host (outside the chip) kept.
    pub fn reset(&mut self) {
        let host = std::mem::take(&mut self.host);
        *self = Usb { host, ..Usb::default() };
    }

    /// The interrupt is requested (`USBSTS & USBINTR`: UI or URI).
    pub fn requesting(&self) -> bool {
        self.usbsts & self.usbintr & (UI | URI) != 0
    }

    /// The device address the driver set (`DEVICEADDR[USBADR]`).
    pub fn address(&self) -> u8 {
        (self.deviceaddr >> 25) as u8
    }

    /// When the host next acts, if it has something to do.
    pub fn next_event(&self) -> Option<u64> {
        (self.host.cur.is_some() || self.host.reset_pending || !self.host.queue.is_empty())
            .then_some(self.host.next_at)
            .filter(|&t| t != u64::MAX)
    }

    /// Register read (`off` from [`USB1`], 32-bit aligned).
    pub fn read(&self, off: u32) -> u32 {
        match off {
            USBCMD => self.usbcmd,
            USBSTS => self.usbsts,
            USBINTR => self.usbintr,
            DEVICEADDR => self.deviceaddr,
            ENDPTLISTADDR => self.listaddr,
            PORTSC1 => self.portsc1,
            ENDPTSETUPSTAT => self.setupstat,
            ENDPTPRIME | ENDPTFLUSH => 0,
            ENDPTSTAT => self.stat,
            ENDPTCOMPLETE => self.complete,
            o if (ENDPTCTRL0..ENDPTCTRL0 + 32).contains(&o) => self.ctrl[((o - ENDPTCTRL0) / 4) as usize],
            o => self.other.get(&o).copied().unwrap_or(0),
        }
    }

    /// Register write at `now`: every write lets a waiting host look again
    /// one step later.
    pub fn write(&mut self, off: u32, v: u32, now: u64) {
        match off {
            // RST self-clears (the reset is immediate)
            USBCMD => {
                self.usbcmd = v & !2;
                if v & 2 != 0 {
                    let host = std::mem::take(&mut self.host);
                    *self = Usb { host, ..Usb::default() };
                }
            }
            USBSTS => {
                self.usbsts &= !v;
                if v & URI != 0 {
                    self.portsc1 &= !PR;
                }
            }
            USBINTR => self.usbintr = v,
            DEVICEADDR => self.deviceaddr = v,
            ENDPTLISTADDR => self.listaddr = v & !0x7FF,
            PORTSC1 => self.portsc1 = (self.portsc1 & PR) | (v & !PR),
            ENDPTSETUPSTAT => self.setupstat &= !v,
            ENDPTPRIME => {
                for bit in (0..32).filter(|b| v & (1 << b) != 0 && b % 16 != 0) {
                    let (ep, enable) = if bit < 16 { (bit, 1 << 7) } else { (bit - 16, 1 << 23) };
                    if self.ctrl[(ep & 7) as usize] & enable == 0 && self.disabled_primes.len() < 1000 {
                        self.disabled_primes.push((now, 1 << bit));
                    }
                }
                self.stat |= v;
            }
            ENDPTFLUSH => self.stat &= !v,
            ENDPTSTAT => {}
            ENDPTCOMPLETE => self.complete &= !v,
            ENDPTNAK => {
                let old = self.other.get(&off).copied().unwrap_or(0);
                self.other.insert(off, old & !v);
            }
            o if (ENDPTCTRL0..ENDPTCTRL0 + 32).contains(&o) => {
                let i = ((o - ENDPTCTRL0) / 4) as usize;
                // endpoint 0's enables read 1 whatever is written
                self.ctrl[i] = if i == 0 { v | 0x0080_0080 } else { v };
            }
            o => {
                self.other.insert(o, v);
            }
        }
        self.host.next_at = self.host.next_at.min(now + HOST_STEP_CYCLES);
    }
}

/// Emulated memory as the controller's DMA sees it.
trait Mem {
    fn read32(&self, a: u32) -> Option<u32>;
    fn write32(&mut self, a: u32, v: u32) -> bool;
    fn read_bytes(&self, a: u32, n: usize) -> Option<Vec<u8>>;
    fn write_bytes(&mut self, a: u32, d: &[u8]) -> bool;
}

impl Mem for Unicorn<'_, Board> {
    fn read32(&self, a: u32) -> Option<u32> {
        let mut b = [0u8; 4];
        self.mem_read(u64::from(a), &mut b).ok().map(|()| u32::from_le_bytes(b))
    }
    fn write32(&mut self, a: u32, v: u32) -> bool {
        self.mem_write(u64::from(a), &v.to_le_bytes()).is_ok()
    }
    fn read_bytes(&self, a: u32, n: usize) -> Option<Vec<u8>> {
        let mut b = vec![0u8; n];
        self.mem_read(u64::from(a), &mut b).ok().map(|()| b)
    }
    fn write_bytes(&mut self, a: u32, d: &[u8]) -> bool {
        self.mem_write(u64::from(a), d).is_ok()
    }
}

/// Queue head of endpoint `ep`, direction IN (`true`) or OUT.
fn qh(usb: &Usb, ep: u32, dir_in: bool) -> u32 {
    usb.listaddr + (2 * ep + u32::from(dir_in)) * 64
}

/// `dTD.TOKEN` fields.
const TOKEN_ACTIVE: u32 = 1 << 7;
const TOKEN_IOC: u32 = 1 << 15;
const TOTAL_SHIFT: u32 = 16;
const TOTAL_MASK: u32 = 0x7FFF;

/// Complete the transfer primed on endpoint 0 in direction `dir_in`:
/// for OUT, `data` is written into its buffer (at most the descriptor's
/// length); for IN, the bytes the descriptor holds are returned. The
/// descriptor's `TOTAL_BYTES` becomes what is left and `ACTIVE` clears;
/// `ENDPTCOMPLETE` is set, `ENDPTSTAT` cleared, and `UI` raised if the
/// descriptor asked for an interrupt. `None` if the descriptor cannot be
/// read (the transfer then stays primed).
fn complete(usb: &mut Usb, mem: &mut impl Mem, dir_in: bool, data: &[u8]) -> Option<Vec<u8>> {
    let bit = if dir_in { 1 << 16 } else { 1 };
    let next = mem.read32(qh(usb, 0, dir_in) + 8)?;
    if next & 1 != 0 {
        return None;
    }
    let td = next & !0x1F;
    let token = mem.read32(td + 4)?;
    let total = ((token >> TOTAL_SHIFT) & TOTAL_MASK) as usize;
    let buf = mem.read32(td + 8)?;
    let moved = if dir_in {
        mem.read_bytes(buf, total)?
    } else {
        let n = data.len().min(total);
        if n > 0 && !mem.write_bytes(buf, &data[..n]) {
            return None;
        }
        data[..n].to_vec()
    };
    let left = (total - moved.len()) as u32;
    let token = (token & !(TOTAL_MASK << TOTAL_SHIFT) & !TOKEN_ACTIVE) | (left << TOTAL_SHIFT);
    mem.write32(td + 4, token);
    usb.stat &= !bit;
    usb.complete |= bit;
    if token & TOKEN_IOC != 0 {
        usb.usbsts |= UI;
    }
    Some(moved)
}

/// The host's next step, if it is due: a bus reset, a SETUP, a data packet
/// or a status stage, each only when the device is ready for it. Called by
/// the harness between runs of the CPU (it needs the emulated memory).
pub fn service(uc: &mut Unicorn<'_, Board>) {
    let now = uc.get_data().now;
    if uc.get_data().usb.host.next_at > now {
        return;
    }
    let mut usb = std::mem::take(&mut uc.get_data_mut().usb);
    step(&mut usb, uc, now);
    uc.get_data_mut().usb = usb;
}

fn step(usb: &mut Usb, mem: &mut impl Mem, now: u64) {
    usb.host.next_at = u64::MAX;
    if usb.usbcmd & RS == 0 {
        // not attached: nothing on the bus
        return;
    }
    if usb.host.cur.is_none() && std::mem::take(&mut usb.host.reset_pending) {
        usb.usbsts |= URI;
        usb.portsc1 |= PR;
        usb.deviceaddr = 0;
        usb.setupstat = 0;
        usb.complete = 0;
        usb.stat = 0;
        // the host waits for the reset to be taken before the next transfer
        usb.host.next_at = now + HOST_STEP_CYCLES;
        return;
    }
    if usb.portsc1 & PR != 0 {
        // the device has not yet acknowledged the reset (URI still set)
        usb.host.next_at = now + HOST_STEP_CYCLES;
        return;
    }
    let Some((control, stage, mut got, since)) = usb.host.cur.take().or_else(|| {
        let c = usb.host.queue.pop_front()?;
        Some((c, Stage::Setup, Vec::new(), now))
    }) else {
        return;
    };
    let stalled = usb.ctrl[0] & 0x0001_0001 != 0;
    // the packet size the device gave endpoint 0 (CAPABILITIES[26:16])
    let packet = match mem.read32(qh(usb, 0, true)).map(|c| (c >> 16 & 0x7FF) as usize) {
        Some(n) if (1..=EP0_PACKET).contains(&n) => n,
        _ => EP0_PACKET,
    };
    let before = stage.clone();
    let finish = |usb: &mut Usb, outcome: Outcome, got: Vec<u8>| {
        usb.host.done.push(Done { control: control.clone(), data_in: got, outcome, at: now });
        usb.host.next_at = now + HOST_STEP_CYCLES;
    };
    let next = match stage {
        Stage::Setup => {
            // a SETUP clears endpoint 0's stall (the controller does)
            usb.ctrl[0] &= !0x0001_0001;
            if !mem.write_bytes(qh(usb, 0, false) + 0x28, &control.setup) {
                return finish(usb, Outcome::TimedOut, got);
            }
            usb.setupstat |= 1;
            usb.usbsts |= UI;
            Some(if control.length() == 0 {
                Stage::StatusIn
            } else if control.device_to_host() {
                Stage::DataIn
            } else {
                Stage::DataOut { sent: 0 }
            })
        }
        _ if stalled => return finish(usb, Outcome::Stalled, got),
        // wait until the device has read the SETUP
        s if usb.setupstat & 1 != 0 => Some(s),
        Stage::DataOut { sent } if usb.stat & 1 != 0 => {
            let end = control.data.len().min(sent + packet);
            match complete(usb, mem, false, &control.data[sent..end]) {
                Some(d) if end < control.data.len() => Some(Stage::DataOut { sent: sent + d.len() }),
                Some(_) => Some(Stage::StatusIn),
                None => Some(Stage::DataOut { sent }),
            }
        }
        Stage::DataIn if usb.stat & (1 << 16) != 0 => match complete(usb, mem, true, &[]) {
            Some(d) => {
                let short = d.len() < packet;
                got.extend_from_slice(&d);
                Some(if short || got.len() >= control.length() { Stage::StatusOut } else { Stage::DataIn })
            }
            None => Some(Stage::DataIn),
        },
        Stage::StatusIn if usb.stat & (1 << 16) != 0 => match complete(usb, mem, true, &[]) {
            Some(_) => return finish(usb, Outcome::Acked, got),
            None => Some(Stage::StatusIn),
        },
        Stage::StatusOut if usb.stat & 1 != 0 => match complete(usb, mem, false, &[]) {
            Some(_) => return finish(usb, Outcome::Acked, got),
            None => Some(Stage::StatusOut),
        },
        s => Some(s),
    };
    let Some(next) = next else { return };
    let since = if next == before { since } else { now };
    if now.saturating_sub(since) > STAGE_TIMEOUT_CYCLES {
        return finish(usb, Outcome::TimedOut, got);
    }
    // act again after a step if the device is ready for the next stage now,
    // else when it next writes a USB register (or at the timeout)
    let ready = match next {
        _ if usb.setupstat & 1 != 0 => false,
        Stage::DataOut { .. } | Stage::StatusOut => usb.stat & 1 != 0,
        Stage::DataIn | Stage::StatusIn => usb.stat & (1 << 16) != 0,
        Stage::Setup => true,
    };
    usb.host.cur = Some((control, next, got, since));
    usb.host.next_at = if ready { now + HOST_STEP_CYCLES } else { since + STAGE_TIMEOUT_CYCLES + 1 };
}

impl crate::Twin {
    /// The host resets the bus (as when the board is plugged in), then
    /// sends its queued transfers.
    pub fn usb_bus_reset(&mut self) {
        let now = self.now();
        let h = &mut self.board_mut().usb.host;
        h.reset_pending = true;
        h.next_at = h.next_at.min(now);
    }

    /// Queue control transfers for the host to send, in order.
    pub fn usb_send(&mut self, transfers: impl IntoIterator<Item = Control>) {
        let now = self.now();
        let h = &mut self.board_mut().usb.host;
        h.queue.extend(transfers);
        h.next_at = h.next_at.min(now);
    }

    /// What a host does when the board is plugged in and a terminal opens
    /// its serial port at `baud`: bus reset, SET_ADDRESS, the device
    /// descriptor, SET_CONFIGURATION 1, DTR and RTS, the line coding
    /// (interface 0: the CDC communication interface).
    pub fn usb_enumerate_and_open(&mut self, address: u8, baud: u32) {
        self.usb_bus_reset();
        self.usb_send([
            Control::set_address(address),
            Control::get_device_descriptor(),
            Control::set_configuration(1),
            Control::set_control_line_state(0, true, true),
            Control::set_line_coding(0, baud),
        ]);
    }

    /// The host's finished transfers, in order.
    pub fn usb_done(&self) -> &[Done] {
        &self.board().usb.host.done
    }
}
