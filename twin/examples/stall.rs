use twin::{boot_twin, MS};
fn main() {
    let mut t = boot_twin().unwrap();
    t.run_until(60 * MS).unwrap();
    t.board_mut().nvic_en = [0; 8];
    let r = t.run_until(120 * MS);
    println!("{r:?}");
    let b = t.board();
    println!("resets {} main_at {:?} now {} srsr {:#x}", t.stats.watchdog_resets, b.main_at, b.now, b.srsr);
    println!("{}", b.serial_text());
    let trail: Vec<String> = (0..16).map(|k| b.trace[(b.trace_i + k) & 15]).map(|a| t.image.symbolize(a)).collect();
    println!("{}", trail.join("\n"));
}
