//! PAROL6 controller image for the Teensy 4.1. See `firmware/README.md`.
//!
//! Built for `thumbv7em-none-eabihf` by `firmware/build.sh`; on the host this
//! file compiles to a stub so that `cargo test/clippy --workspace` work.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod target;

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "parol6 {}: this is the Teensy 4.1 image; build it with firmware/build.sh \
         (thumbv7em-none-eabihf). The host build is only a stub; the pure logic is \
         tested with `cargo test -p firmware`.",
        firmware::VERSION
    );
    std::process::exit(2);
}
