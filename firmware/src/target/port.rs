//! The two byte ports: USB CDC (imxrt-usbd + usbd-serial, polled from the
//! main loop, no USB interrupt) and Serial1 (the thin HAL's LPUART6). One
//! carries the protocol, the other the defmt log (selected by the `serial1`
//! feature in `mod.rs`). Each has a fixed transmit ring: a line that does not
//! fit is dropped whole and counted, the main loop never blocks.

use heapless::Deque;
use teensy4_bsp::ral;
use teensy4_bsp::usbd::{BusAdapter, EndpointMemory, EndpointState, Instances, Speed};
use usb_device::bus::UsbBusAllocator;
use usb_device::device::{StringDescriptors, UsbDevice, UsbDeviceBuilder, UsbDeviceState, UsbVidPid};
use usb_device::LangID;
use usbd_serial::SerialPort;

use hal_imxrt::periph::uart::Serial1;

const TX_CAP: usize = 2048;

/// A byte port.
pub trait Port {
    /// Service the hardware (USB enumeration / transfers).
    fn poll(&mut self);
    /// A host is listening (USB: configured and DTR set; UART: always).
    fn is_open(&self) -> bool;
    /// One received byte.
    fn read(&mut self) -> Option<u8>;
    /// Queue a whole line, or drop it whole (counted) if it does not fit.
    fn write_line(&mut self, line: &[u8]);
    /// Queue raw bytes as far as they fit (log frames; the decoder resyncs).
    fn write_raw(&mut self, bytes: &[u8]);
    /// Move queued bytes to the hardware as far as it accepts them.
    fn flush(&mut self);
}

fn enqueue_line(q: &mut Deque<u8, TX_CAP>, dropped: &mut u32, line: &[u8]) {
    if q.capacity() - q.len() < line.len() {
        *dropped = dropped.wrapping_add(1);
        return;
    }
    for &b in line {
        let _ = q.push_back(b);
    }
}

/// USB CDC-ACM (full speed, 64-byte packets).
pub struct Usb {
    dev: UsbDevice<'static, BusAdapter>,
    serial: SerialPort<'static, BusAdapter>,
    tx: Deque<u8, TX_CAP>,
    dropped: u32,
}

static EP_MEMORY: EndpointMemory<2048> = EndpointMemory::new();
static EP_STATE: EndpointState = EndpointState::max_endpoints();
static mut BUS: Option<UsbBusAllocator<BusAdapter>> = None;

/// pid.codes test VID/PID (0x1209/0x0001); replace before any release.
const VID_PID: UsbVidPid = UsbVidPid(0x1209, 0x0001);

impl Usb {
    /// Take USB1 and start the device stack.
    pub fn new(usb: ral::usb::USB1, usbphy: ral::usbphy::USBPHY1, usbnc: ral::usbnc::USBNC1) -> Self {
        let bus = BusAdapter::with_speed(Instances { usb, usbphy, usbnc }, &EP_MEMORY, &EP_STATE, Speed::LowFull);
        // SAFETY: called once from `main` (it owns USB1, which cannot be
        // taken twice); the allocator then lives for the rest of the program.
        let alloc: &'static UsbBusAllocator<BusAdapter> =
            unsafe { (*core::ptr::addr_of_mut!(BUS)).insert(UsbBusAllocator::new(bus)) };
        let serial = SerialPort::new(alloc);
        let builder = UsbDeviceBuilder::new(alloc, VID_PID).device_class(usbd_serial::USB_CLASS_CDC);
        let builder = match builder.strings(&[StringDescriptors::new(LangID::EN_US)
            .manufacturer("PAROL6")
            .product("PAROL6 controller")
            .serial_number("0")])
        {
            Ok(b) => b,
            Err(_) => super::halt(),
        };
        let dev = builder.build();
        Self { dev, serial, tx: Deque::new(), dropped: 0 }
    }
}

impl Port for Usb {
    fn poll(&mut self) {
        self.dev.poll(&mut [&mut self.serial]);
        if self.dev.state() != UsbDeviceState::Configured {
            self.tx.clear();
        }
    }
    fn is_open(&self) -> bool {
        self.dev.state() == UsbDeviceState::Configured && self.serial.dtr()
    }
    fn read(&mut self) -> Option<u8> {
        let mut b = [0u8; 1];
        match self.serial.read(&mut b) {
            Ok(1) => Some(b[0]),
            _ => None,
        }
    }
    fn write_line(&mut self, line: &[u8]) {
        if self.is_open() {
            enqueue_line(&mut self.tx, &mut self.dropped, line);
        }
    }
    fn write_raw(&mut self, bytes: &[u8]) {
        if self.is_open() {
            for &b in bytes {
                if self.tx.push_back(b).is_err() {
                    break;
                }
            }
        }
    }
    fn flush(&mut self) {
        while !self.tx.is_empty() {
            let (a, _) = self.tx.as_slices();
            let n = match self.serial.write(a) {
                Ok(n) if n > 0 => n,
                _ => break,
            };
            for _ in 0..n {
                let _ = self.tx.pop_front();
            }
        }
        let _ = self.serial.flush();
    }
}

/// Serial1 (LPUART6, pins 0/1), polled.
pub struct Uart {
    hw: Serial1,
    tx: Deque<u8, TX_CAP>,
    dropped: u32,
}

impl Uart {
    /// Wrap the configured port.
    pub fn new(hw: Serial1) -> Self {
        Self { hw, tx: Deque::new(), dropped: 0 }
    }
}

impl Port for Uart {
    fn poll(&mut self) {}
    fn is_open(&self) -> bool {
        true
    }
    fn read(&mut self) -> Option<u8> {
        // Line errors and overruns drop the byte; the framer rejects the
        // damaged line.
        loop {
            match self.hw.try_read()? {
                Ok(b) => return Some(b),
                Err(_) => continue,
            }
        }
    }
    fn write_line(&mut self, line: &[u8]) {
        enqueue_line(&mut self.tx, &mut self.dropped, line);
    }
    fn write_raw(&mut self, bytes: &[u8]) {
        for &b in bytes {
            if self.tx.push_back(b).is_err() {
                break;
            }
        }
    }
    fn flush(&mut self) {
        while let Some(&b) = self.tx.front() {
            if !self.hw.try_write(b) {
                break;
            }
            let _ = self.tx.pop_front();
        }
    }
}
