//! The twin's CPU cost of two simulated seconds with a 100 Hz driver
//! stream arriving on Serial1, then of two idle seconds (CPU time of this
//! thread, whatever else the machine runs): `cargo run --release --example
//! stream_cost`.

use sim::client::driver_line;
fn cpu() -> f64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: writes one timespec into the live local.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}
fn main() {
    let mut t = twin::boot_twin().unwrap();
    t.run_until(100 * twin::MS).unwrap();
    let start = cpu();
    let p = twin::START_Q;
    for ms in 100..2100u64 {
        if ms % 10 == 0 {
            t.board_mut().serial_send(driver_line((ms / 10) as u32, &p, &[0.0; 6]).as_bytes());
        }
        t.run_until((ms + 1) * twin::MS).unwrap();
    }
    let stream = cpu() - start;
    let start = cpu();
    t.run_until(4100 * twin::MS).unwrap();
    let idle = cpu() - start;
    println!(
        "2 s with a 100 Hz stream: {stream:.2} s; 2 s idle: {idle:.2} s; uart calls {} wfi {}",
        t.stats.uart_calls,
        t.board().wfi_count
    );
}
