//! The reboot into the bootloader over the USB serial port, on the Serial1
//! image (evidence kind: **emulated**). That image's log port is the USB
//! CDC serial port, which carries the request: a host sets its line to
//! 134 baud (`teensy_loader_cli -s`). The twin's USB OTG1 model
//! (`twin/src/usb.rs`) delivers the host's control transfers on endpoint 0
//! to the image's USB stack (imxrt-usbd, usb-device, usbd-serial) as the
//! controller would; the protocol runs on Serial1 as in every twin test.
//!
//! Each test that checks the decision fails on an image whose main loop
//! does not act on the request: no bootloader hand-over at rest, no
//! `BOOTLOADER_REFUSED MOVING` while moving.

mod common;

use common::{lines, run};
use twin::usb::{Control, Outcome};
use twin::{boot_twin, Twin, MS};

/// Runs `ms` more milliseconds.
fn run_for(t: &mut Twin, ms: u64) {
    let end = t.now() / MS + ms;
    run(t, end);
}

/// STEP pulses of every joint so far.
fn pulses(t: &Twin) -> [u64; 6] {
    t.board().step_pulses()
}

/// Runs until the host has finished `n` transfers (at most `limit_ms` more),
/// and requires each acknowledged.
fn until_done(t: &mut Twin, n: usize, limit_ms: u64) {
    let end = t.now() / MS + limit_ms;
    while t.usb_done().len() < n && t.now() / MS < end && t.board().bkpt_halt.is_none() {
        let next = t.now() / MS + 1;
        run(t, next);
    }
    let done = t.usb_done();
    assert!(done.len() >= n, "{} of {n} transfers finished in {limit_ms} ms: {done:?}", done.len());
    for d in done {
        assert_eq!(d.outcome, Outcome::Acked, "{:02x?}", d.control.setup);
    }
}

/// The image enumerates on the modelled bus: it takes the bus reset, the
/// address, the configuration and the CDC class requests, and its device
/// descriptor names the Teensy USB-serial pair 16C0:0483.
#[test]
fn usb_enumerates_with_the_teensy_serial_identity() {
    let mut t = boot_twin().unwrap();
    run(&mut t, 80);
    t.usb_enumerate_and_open(7, 115_200);
    until_done(&mut t, 5, 50);
    let desc = &t.usb_done()[1].data_in;
    eprintln!("device descriptor {desc:02x?}; address {}", t.board().usb.address());
    let disabled = &t.board().usb.disabled_primes;
    eprintln!(
        "primes of a disabled bulk/interrupt endpoint after configuration: {} (first {:x?})",
        disabled.len(),
        disabled.first()
    );
    assert_eq!(desc.len(), 18, "{desc:02x?}");
    assert_eq!((desc[0], desc[1]), (18, 1), "bLength, bDescriptorType");
    assert_eq!(u16::from_le_bytes([desc[8], desc[9]]), 0x16C0, "idVendor");
    assert_eq!(u16::from_le_bytes([desc[10], desc[11]]), 0x0483, "idProduct");
    assert_eq!(t.board().usb.address(), 7);
    assert!(t.stats.usb_calls > 0, "the USB interrupt woke the main loop");
    // nothing else happened: no hand-over, the tick runs
    let calls = t.stats.pit_calls;
    run_for(&mut t, 20);
    assert!(t.board().bkpt_halt.is_none());
    assert!(t.stats.pit_calls >= calls + 19, "{} -> {}", calls, t.stats.pit_calls);
}

/// At rest (booted, unhomed, nothing moving) the 134-baud line coding
/// makes the image hand over to the bootloader: every STEP pin low, then
/// `bkpt #251` (the core halts; the Teensy's bootloader chip takes it
/// from there), and no tick runs after it.
#[test]
fn usb_soft_reboot_at_rest_enters_the_bootloader() {
    let mut t = boot_twin().unwrap();
    run(&mut t, 80);
    t.usb_enumerate_and_open(7, 115_200);
    until_done(&mut t, 5, 50);
    assert!(t.board().bkpt_halt.is_none(), "no hand-over at 115200 baud");
    let asked = t.now();
    t.usb_send([Control::set_line_coding(0, 134)]);
    let end = t.now() / MS + 20;
    run(&mut t, end);
    let (imm, at) = t.board().bkpt_halt.expect("the image entered the bootloader path");
    eprintln!(
        "bkpt #{imm} {:.3} ms after the request; USB transfers {:?}",
        (at - asked) as f64 / MS as f64,
        t.usb_done().last()
    );
    assert_eq!(imm, 251);
    assert!(at - asked < 5 * MS, "{} cycles", at - asked);
    let levels: Vec<Option<bool>> = twin::pads::wiring().step.iter().map(|&p| t.board().gpio_out(p)).collect();
    assert!(levels.iter().all(|l| *l == Some(false)), "STEP pins {levels:?}");
    let (calls, steps) = (t.stats.pit_calls, pulses(&t));
    run(&mut t, end + 50);
    assert_eq!(t.stats.pit_calls, calls, "a tick ran after the hand-over");
    assert_eq!(pulses(&t), steps);
    assert!(!lines(&t).iter().any(|l| l.contains("BOOTLOADER_REFUSED")), "refused at rest");
}

/// While the arm moves (homing: J6 stepping) the request is refused on the
/// protocol port with `BOOTLOADER_REFUSED MOVING`, the image goes on
/// controlling the arm (ticks, J6 keeps stepping) and never hands over.
#[test]
fn usb_soft_reboot_refused_while_moving() {
    let mut t = boot_twin().unwrap();
    run(&mut t, 80);
    t.usb_enumerate_and_open(7, 115_200);
    until_done(&mut t, 5, 50);
    t.board_mut().serial_send(b"<HOME>\n");
    run_for(&mut t, 100);
    let before = pulses(&t);
    run_for(&mut t, 20);
    assert!(pulses(&t)[5] > before[5] + 10, "J6 is homing: {before:?} -> {:?}", pulses(&t));
    t.usb_send([Control::set_line_coding(0, 134)]);
    until_done(&mut t, 6, 20);
    let (calls, steps) = (t.stats.pit_calls, pulses(&t));
    run_for(&mut t, 30);
    let refused: Vec<String> = lines(&t).into_iter().filter(|l| l.contains("BOOTLOADER_REFUSED")).collect();
    eprintln!("{refused:?}; J6 pulses {} -> {} in 30 ms", steps[5], pulses(&t)[5]);
    assert_eq!(refused, ["BOOTLOADER_REFUSED MOVING"]);
    assert!(t.board().bkpt_halt.is_none(), "handed over while moving");
    assert!(t.stats.pit_calls >= calls + 29, "{} -> {}", calls, t.stats.pit_calls);
    assert!(pulses(&t)[5] > steps[5] + 10, "J6 stopped: {} -> {}", steps[5], pulses(&t)[5]);
}

/// Other baud rates are ordinary line codings: at rest, 9600, 1200 and
/// 57600 baud change nothing (no hand-over, no refusal, the tick runs).
#[test]
fn usb_soft_reboot_other_baud_rates_do_nothing() {
    let mut t = boot_twin().unwrap();
    run(&mut t, 80);
    t.usb_enumerate_and_open(7, 115_200);
    until_done(&mut t, 5, 50);
    t.usb_send([9600, 1200, 57_600].map(|b| Control::set_line_coding(0, b)));
    until_done(&mut t, 8, 30);
    let calls = t.stats.pit_calls;
    run_for(&mut t, 30);
    assert!(t.board().bkpt_halt.is_none());
    assert!(!lines(&t).iter().any(|l| l.contains("BOOTLOADER")), "{:?}", lines(&t));
    assert!(t.stats.pit_calls >= calls + 29);
}

/// Once the host configured the device, the CDC port's bulk OUT endpoint is
/// enabled (`ENDPTCTRLn[RXE]`) and primed for the host's bytes. imxrt-usbd
/// does this only when the firmware calls `BusAdapter::configure` after the
/// configuration; an image that never does leaves every data endpoint
/// disabled and unprimed (no byte would ever arrive on the USB port).
#[test]
fn usb_configured_port_enables_and_primes_its_bulk_out_endpoint() {
    let mut t = boot_twin().unwrap();
    run(&mut t, 80);
    t.usb_enumerate_and_open(7, 115_200);
    until_done(&mut t, 5, 50);
    run_for(&mut t, 2);
    let usb = &t.board().usb;
    let stat = usb.read(0x1B8);
    let ctrl: Vec<u32> = (1..8).map(|n| usb.read(0x1C0 + 4 * n)).collect();
    eprintln!("ENDPTSTAT {stat:#010x}, ENDPTCTRL1..7 {ctrl:08x?}");
    let ready: Vec<u32> = (1..8).filter(|&n| ctrl[n as usize - 1] & (1 << 7) != 0 && stat & (1 << n) != 0).collect();
    assert!(!ready.is_empty(), "no bulk OUT endpoint enabled and primed: ENDPTSTAT {stat:#x}, ENDPTCTRL {ctrl:x?}");
}
