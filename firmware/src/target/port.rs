//! The two byte ports: USB CDC (imxrt-usbd + usbd-serial, polled from the
//! main loop; its interrupt only wakes the core from WFI) and Serial1 (the
//! thin HAL's LPUART6, likewise), as
//! [`Port`]s of the shared composition root: they only move bytes; the
//! transmit ring, its policy and the loss reports are `firmware::tx`. The
//! port that does not carry the protocol carries the defmt log through a
//! [`LogPort`] (selected by the `serial1` feature in `mod.rs`).

use heapless::Deque;
use teensy4_bsp::ral;
use teensy4_bsp::usbd::{BusAdapter, EndpointMemory, EndpointState, Instances, Speed};
use usb_device::bus::UsbBusAllocator;
use usb_device::device::{StringDescriptors, UsbDevice, UsbDeviceBuilder, UsbDeviceState, UsbVidPid};
use usb_device::LangID;
use usbd_serial::SerialPort;

use firmware::board::Port;
use firmware::root::BootloaderBaud;
use hal_imxrt::periph::uart::Serial1;

/// Bytes of the log ring (defmt frames; the decoder resynchronises after a loss).
const LOG_CAP: usize = 1024;

/// USB CDC-ACM (full speed, 64-byte packets).
pub struct Usb {
    dev: UsbDevice<'static, BusAdapter>,
    serial: SerialPort<'static, BusAdapter>,
    busy: bool,
    baud: BootloaderBaud,
    /// The device was in the `Configured` state at the last poll.
    configured: bool,
}

static EP_MEMORY: EndpointMemory<2048> = EndpointMemory::new();
static EP_STATE: EndpointState = EndpointState::max_endpoints();
static mut BUS: Option<UsbBusAllocator<BusAdapter>> = None;

/// PJRC's pair for a Teensy running USB serial code (16C0:0483). Chosen
/// because the tools a Teensy user has key on it: `teensy_loader_cli -s`
/// opens exactly this pair to send its 134-baud reboot request (so the
/// image can be re-flashed without opening the robot), PJRC's udev rules
/// (`00-teensy.rules`) already grant users access to it and stop
/// ModemManager probing it, and the Arduino/Teensyduino tools list it as a
/// Teensy. The image runs only on a Teensy 4.1. An allocated pair (e.g.
/// from pid.codes) would mark the device as this firmware's own but would
/// lose `teensy_loader_cli -s` and need a udev rule of its own; the strings
/// below say which firmware and version answers.
const VID_PID: UsbVidPid = UsbVidPid(0x16C0, 0x0483);
/// USB strings: who made it, what it is, which version (the serial-number
/// string; one image per version, so the host sees which one runs).
const MANUFACTURER: &str = "PAROL6 firmware";
const PRODUCT: &str = "PAROL6 controller (Teensy 4.1)";
const SERIAL: &str = concat!("parol6-fw-", env!("CARGO_PKG_VERSION"));

impl Usb {
    /// Take USB1 and start the device stack.
    pub fn new(usb: ral::usb::USB1, usbphy: ral::usbphy::USBPHY1, usbnc: ral::usbnc::USBNC1) -> Self {
        let bus = BusAdapter::with_speed(Instances { usb, usbphy, usbnc }, &EP_MEMORY, &EP_STATE, Speed::LowFull);
        // Transfer-complete and bus-reset interrupts: they wake the main
        // loop from WFI (the handler in `mod.rs` masks the line again).
        bus.set_interrupts(true);
        // SAFETY: called once from `main` (it owns USB1, which cannot be
        // taken twice); the allocator then lives for the rest of the program.
        let alloc: &'static UsbBusAllocator<BusAdapter> =
            unsafe { (*core::ptr::addr_of_mut!(BUS)).insert(UsbBusAllocator::new(bus)) };
        let serial = SerialPort::new(alloc);
        let builder = UsbDeviceBuilder::new(alloc, VID_PID).device_class(usbd_serial::USB_CLASS_CDC);
        let builder = match builder.strings(&[StringDescriptors::new(LangID::EN_US)
            .manufacturer(MANUFACTURER)
            .product(PRODUCT)
            .serial_number(SERIAL)])
        {
            Ok(b) => b,
            Err(_) => super::halt(),
        };
        let dev = builder.build();
        Self { dev, serial, busy: false, baud: BootloaderBaud::new(), configured: false }
    }

    /// The host asked for the bootloader: it set the line to 134 baud
    /// (`firmware::root::BOOTLOADER_BAUD`, the CDC SET_LINE_CODING that
    /// `teensy_loader_cli -s` sends). True once per change to that rate.
    pub fn bootloader_requested(&mut self) -> bool {
        self.baud.request(self.serial.line_coding().data_rate())
    }
}

impl Port for Usb {
    fn poll(&mut self) {
        // (What `poll` reports is not work for the main loop: a transfer
        // it completes wakes the core through the USB interrupt; bytes it
        // brings are read in this pass.)
        let _ = self.dev.poll(&mut [&mut self.serial]);
        // imxrt-usbd enables and primes the bulk and interrupt endpoints
        // only when told the host configured the device (`configure`, once
        // per configuration): without it the CDC data endpoints stay
        // disabled and no byte moves (the twin's USB model shows the OUT
        // endpoint primed after SET_CONFIGURATION, `twin/tests/usb.rs`).
        let configured = self.dev.state() == UsbDeviceState::Configured;
        if configured && !self.configured {
            self.dev.bus().configure();
        }
        self.configured = configured;
    }
    fn is_open(&self) -> bool {
        self.dev.state() == UsbDeviceState::Configured && self.serial.dtr()
    }
    fn read(&mut self) -> Option<u8> {
        let mut b = [0u8; 1];
        match self.serial.read(&mut b) {
            Ok(1) => {
                self.busy = true;
                Some(b[0])
            }
            _ => None,
        }
    }
    fn write(&mut self, bytes: &[u8]) -> usize {
        if !self.is_open() {
            return 0;
        }
        // WouldBlock (endpoint busy) and errors: nothing taken this pass.
        let n = self.serial.write(bytes).unwrap_or_default();
        let _ = self.serial.flush();
        self.busy |= n > 0;
        n
    }
}

impl Wake for Usb {
    fn take_busy(&mut self) -> bool {
        core::mem::take(&mut self.busy)
    }
}

/// What the main loop needs of a port to decide whether it may sleep.
pub trait Wake {
    /// The port moved a byte since the last call.
    fn take_busy(&mut self) -> bool;
}

/// Serial1 (LPUART6, pins 0/1), polled; its interrupt wakes the core on a
/// received byte, and on an empty transmit FIFO while bytes wait for room.
pub struct Uart {
    hw: Serial1,
    busy: bool,
}

impl Uart {
    /// Wrap the configured port.
    pub fn new(mut hw: Serial1) -> Self {
        hw.set_interrupts(true, false);
        Self { hw, busy: false }
    }
}

impl Wake for Uart {
    fn take_busy(&mut self) -> bool {
        core::mem::take(&mut self.busy)
    }
}

impl Port for Uart {
    fn is_open(&self) -> bool {
        true
    }
    fn read(&mut self) -> Option<u8> {
        // Line errors and overruns drop the byte; the framer rejects the
        // damaged line (counted and reported).
        loop {
            match self.hw.try_read()? {
                Ok(b) => {
                    self.busy = true;
                    return Some(b);
                }
                Err(_) => continue,
            }
        }
    }
    fn write(&mut self, bytes: &[u8]) -> usize {
        let mut n = 0;
        for &b in bytes {
            if !self.hw.try_write(b) {
                break;
            }
            n += 1;
        }
        self.busy |= n > 0;
        // Bytes left over wait for the FIFO to empty: wake on it.
        self.hw.set_interrupts(true, n < bytes.len());
        n
    }
}

/// The log port: a raw byte ring in front of a [`Port`] (defmt frames are
/// not lines; a frame that does not fit is cut, and the host decoder
/// resynchronises).
pub struct LogPort<P> {
    port: P,
    ring: Deque<u8, LOG_CAP>,
}

impl<P: Port> LogPort<P> {
    /// Wrap `port`.
    pub fn new(port: P) -> Self {
        Self { port, ring: Deque::new() }
    }
    /// Service the hardware.
    pub fn poll(&mut self) {
        self.port.poll();
    }
    /// The port itself (the USB port's bootloader request).
    #[cfg_attr(not(feature = "serial1"), allow(dead_code))]
    pub fn port_mut(&mut self) -> &mut P {
        &mut self.port
    }
    /// Queue raw bytes as far as they fit.
    pub fn write_raw(&mut self, bytes: &[u8]) {
        if !self.port.is_open() {
            return;
        }
        for &b in bytes {
            if self.ring.push_back(b).is_err() {
                break;
            }
        }
    }
    /// The wrapped port moved a byte since the last call.
    pub fn take_busy(&mut self) -> bool
    where
        P: Wake,
    {
        self.port.take_busy()
    }
    /// Move queued bytes to the hardware as far as it takes them.
    pub fn flush(&mut self) {
        while !self.ring.is_empty() {
            let (a, _) = self.ring.as_slices();
            let n = self.port.write(a);
            if n == 0 {
                break;
            }
            for _ in 0..n {
                let _ = self.ring.pop_front();
            }
        }
    }
}
