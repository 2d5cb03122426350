//! `defmt` global logger into a RAM ring, drained by the main loop to the
//! port that does **not** carry the protocol (Serial1 by default; USB CDC
//! with the `serial1` feature). Decode on the host with `defmt-print -e
//! target/firmware/parol6.elf` reading that port.
//!
//! Only the main loop logs; the tick never does. Encoding runs inside a
//! critical section (interrupts masked for a few microseconds per log call,
//! a bounded delay of the tick that the overrun check would catch).

use core::cell::RefCell;
use core::sync::atomic::{AtomicBool, Ordering};
use critical_section::{Mutex, RestoreState};
use heapless::Deque;

const CAP: usize = 4096;

static RING: Mutex<RefCell<Deque<u8, CAP>>> = Mutex::new(RefCell::new(Deque::new()));
static TAKEN: AtomicBool = AtomicBool::new(false);
static mut RESTORE: RestoreState = RestoreState::invalid();
static mut ENCODER: defmt::Encoder = defmt::Encoder::new();

fn push(bytes: &[u8]) {
    critical_section::with(|cs| {
        let mut r = RING.borrow_ref_mut(cs);
        for &b in bytes {
            if r.push_back(b).is_err() {
                break; // full: the rest of the frame is lost, the decoder resyncs
            }
        }
    });
}

/// Move up to `buf.len()` logged bytes into `buf`.
pub fn drain(buf: &mut [u8]) -> usize {
    critical_section::with(|cs| {
        let mut r = RING.borrow_ref_mut(cs);
        let mut n = 0;
        for slot in buf.iter_mut() {
            match r.pop_front() {
                Some(b) => {
                    *slot = b;
                    n += 1;
                }
                None => break,
            }
        }
        n
    })
}

#[defmt::global_logger]
struct Logger;

// SAFETY: acquire/release bracket every frame inside a critical section
// (single core), so `ENCODER` and `RESTORE` are never accessed concurrently;
// a nested acquire (impossible: only the main loop logs) is refused by
// `TAKEN` by dropping the frame's bytes rather than corrupting state.
unsafe impl defmt::Logger for Logger {
    fn acquire() {
        // SAFETY: paired with `critical_section::release` in `release`.
        let restore = unsafe { critical_section::acquire() };
        if TAKEN.swap(true, Ordering::Relaxed) {
            // SAFETY: undo our own acquire.
            unsafe { critical_section::release(restore) };
            return;
        }
        // SAFETY: inside the critical section, not taken.
        unsafe {
            RESTORE = restore;
            (*core::ptr::addr_of_mut!(ENCODER)).start_frame(push);
        }
    }
    unsafe fn flush() {}
    unsafe fn release() {
        // SAFETY: called by defmt after a successful `acquire`.
        unsafe {
            (*core::ptr::addr_of_mut!(ENCODER)).end_frame(push);
            TAKEN.store(false, Ordering::Relaxed);
            critical_section::release(RESTORE);
        }
    }
    unsafe fn write(bytes: &[u8]) {
        // SAFETY: between acquire and release.
        unsafe { (*core::ptr::addr_of_mut!(ENCODER)).write(bytes, push) }
    }
}
