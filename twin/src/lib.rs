//! Register-level twin of the PAROL6 Teensy 4.1 board: the
//! shipped release image executed by Unicorn with i.MXRT1062 peripheral
//! models and a stepper plant. See `twin/README.md` for what is modelled.

pub mod board;
pub mod elf;
pub mod gpt;
pub mod lpspi;
pub mod lpuart;
pub mod machine;
pub mod mpu;
pub mod pads;
pub mod pit;
pub mod plant;
pub mod pty;
pub mod pwm;
pub mod qtimer;
pub mod ram_fault;
pub mod scenario;
pub mod tmc5160;
pub mod usb;
pub mod wdog;

pub use board::{Board, CPU_HZ};
pub use machine::{Fault, Twin};
pub use plant::Plant;

/// Cycles per millisecond.
pub const MS: u64 = CPU_HZ / 1000;

/// Path of the Serial1 image built by `twin/build-image.sh`, relative to the
/// repository root.
pub const IMAGE: &str = "target/twin/parol6-serial1.elf";

/// Load an image built by `twin/build-image.sh`: the file named by the
/// environment variable `env` if it is set, else `image` (relative to the
/// repository root).
fn load_from(env: &str, image: &str) -> Result<Vec<u8>, String> {
    let path = std::env::var(env).unwrap_or_else(|_| {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        root.join(image).to_string_lossy().into_owned()
    });
    std::fs::read(&path).map_err(|e| format!("{path}: {e} (build it with twin/build-image.sh)"))
}

/// Load the Serial1 image (env `TWIN_ELF` overrides the path).
pub fn load_image() -> Result<Vec<u8>, String> {
    load_from("TWIN_ELF", IMAGE)
}

/// Path of the Serial1 image with the drivers' enable output (firmware
/// feature `driver-enable`), also built by `twin/build-image.sh`.
pub const IMAGE_DRIVER_ENABLE: &str = "target/twin/parol6-serial1-driver-enable.elf";

/// Load the driver-enable image (env `TWIN_ELF_DRIVER_ENABLE` overrides the
/// path).
pub fn load_driver_enable_image() -> Result<Vec<u8>, String> {
    load_from("TWIN_ELF_DRIVER_ENABLE", IMAGE_DRIVER_ENABLE)
}

/// The Serial1 image built with the TMC5160 link (firmware feature
/// `tmc5160-spi`), also built by `twin/build-image.sh`.
pub const IMAGE_TMC5160: &str = "target/twin/parol6-serial1-tmc5160.elf";

/// Load [`IMAGE_TMC5160`] (env `TWIN_ELF_TMC5160` overrides the path).
pub fn load_tmc5160_image() -> Result<Vec<u8>, String> {
    load_from("TWIN_ELF_TMC5160", IMAGE_TMC5160)
}

/// Joint angles the tests and the CLI start from (rad): inside every
/// joint's limits, off every switch, each encoder at a distinct count.
pub const START_Q: [f64; 6] = [0.3, -0.2, 0.5, 1.0, -1.0, 2.0];

/// Load the Serial1 image into a fresh twin with the arm at [`START_Q`].
pub fn boot_twin() -> Result<Twin, String> {
    let elf = load_image()?;
    Twin::new(&elf, Plant::new(&kernel::config::PAROL6, START_Q))
}

/// One line summarising the instructions of each PIT handler call (the
/// whole tick interrupt), or `None` if there was none.
pub fn pit_instruction_summary(calls: &[u64]) -> Option<String> {
    let mut v = calls.to_vec();
    v.sort_unstable();
    let (min, max) = (*v.first()?, *v.last()?);
    let median = v[v.len() / 2];
    let mean = v.iter().sum::<u64>() as f64 / v.len() as f64;
    Some(format!(
        "PIT handler (whole tick interrupt), instructions per call over {} calls: min {min}, median {median}, max {max}, mean {mean:.0}, max/min {:.2}",
        v.len(),
        max as f64 / min.max(1) as f64
    ))
}
