//! Helpers shared by the twin's image tests: run the image to a time and read
//! the complete lines it has written on Serial1.

use twin::{Twin, MS};

/// Runs the image until `until_ms` of emulated time; a stopped image fails
/// the test with the reason.
pub fn run(t: &mut Twin, until_ms: u64) {
    if let Err(f) = t.run_until(until_ms * MS) {
        panic!("image stopped: {f}");
    }
}

/// Every complete line written on Serial1 so far (a line still being
/// written is left out).
pub fn lines(t: &Twin) -> Vec<String> {
    let text = t.board().serial_text();
    let done = text.rfind('\n').map_or("", |i| &text[..i]);
    done.lines().map(str::to_owned).collect()
}
