//! Line framer: bytes in, complete lines out, from a fixed buffer.
//!
//! - `\n`, `\r` and `\r\n` each end a line; the `\n` of a `\r\n` pair is
//!   swallowed, so a pair never produces a second (empty) line.
//! - Empty lines (two terminators in a row) carry nothing and are skipped;
//!   they are counted in [`FramerCounters::empty`].
//! - A line longer than `N` bytes is discarded up to the next terminator and
//!   reported as [`LineError::TooLong`] when that terminator arrives.
//! - A line containing any byte outside printable ASCII (0x20..=0x7E), NUL
//!   included, is rejected whole as [`LineError::NonPrintable`]. Binary noise
//!   therefore costs at most the line it is in: the next line starts with an
//!   empty buffer after the next terminator.

/// Why a line was rejected by the framer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineError {
    /// The line had more than the buffer's capacity; `len` bytes (saturating)
    /// were discarded.
    TooLong {
        /// Length of the discarded line.
        len: u32,
    },
    /// The line contained a byte outside 0x20..=0x7E (the first such byte
    /// and its position are reported).
    NonPrintable {
        /// The first offending byte.
        byte: u8,
        /// Its position in the line.
        at: u32,
    },
}

/// Running totals, saturating.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FramerCounters {
    /// Non-empty lines completed (accepted or rejected).
    pub lines: u32,
    /// Lines rejected as too long.
    pub too_long: u32,
    /// Lines rejected for non-printable bytes.
    pub non_printable: u32,
    /// Empty lines skipped.
    pub empty: u32,
}

/// A line framer with an `N`-byte buffer.
#[derive(Debug)]
pub struct Framer<const N: usize> {
    buf: [u8; N],
    len: usize,
    /// Length of the current line including discarded bytes (saturating).
    total: u32,
    overflow: bool,
    bad: Option<(u8, u32)>,
    after_cr: bool,
    counters: FramerCounters,
}

impl<const N: usize> Default for Framer<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Framer<N> {
    /// An empty framer.
    pub const fn new() -> Self {
        Framer {
            buf: [0; N],
            len: 0,
            total: 0,
            overflow: false,
            bad: None,
            after_cr: false,
            counters: FramerCounters { lines: 0, too_long: 0, non_printable: 0, empty: 0 },
        }
    }

    /// Running totals.
    pub fn counters(&self) -> FramerCounters {
        self.counters
    }

    /// Feeds one byte. Returns `Some` when a non-empty line ends: the line's
    /// bytes (without terminator), or why it was rejected. The returned
    /// slice is valid until the next call.
    pub fn push(&mut self, byte: u8) -> Option<Result<&[u8], LineError>> {
        let after_cr = core::mem::replace(&mut self.after_cr, byte == b'\r');
        match byte {
            b'\n' if after_cr => None,
            b'\n' | b'\r' => self.finish(),
            _ => {
                if self.bad.is_none() && !(0x20..=0x7E).contains(&byte) {
                    self.bad = Some((byte, self.total));
                }
                match self.buf.get_mut(self.len) {
                    Some(slot) if !self.overflow => {
                        *slot = byte;
                        self.len = self.len.saturating_add(1);
                    }
                    _ => self.overflow = true,
                }
                self.total = self.total.saturating_add(1);
                None
            }
        }
    }

    fn finish(&mut self) -> Option<Result<&[u8], LineError>> {
        let len = core::mem::replace(&mut self.len, 0);
        let total = core::mem::replace(&mut self.total, 0);
        let overflow = core::mem::replace(&mut self.overflow, false);
        let bad = self.bad.take();
        let c = &mut self.counters;
        if total == 0 {
            c.empty = c.empty.saturating_add(1);
            return None;
        }
        c.lines = c.lines.saturating_add(1);
        if overflow {
            c.too_long = c.too_long.saturating_add(1);
            return Some(Err(LineError::TooLong { len: total }));
        }
        if let Some((byte, at)) = bad {
            c.non_printable = c.non_printable.saturating_add(1);
            return Some(Err(LineError::NonPrintable { byte, at }));
        }
        Some(Ok(self.buf.get(..len).unwrap_or(&[])))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(input: &[u8]) -> Vec<Result<Vec<u8>, LineError>> {
        let mut f = Framer::<16>::new();
        let mut out = Vec::new();
        for &b in input {
            if let Some(r) = f.push(b) {
                out.push(r.map(|l| l.to_vec()));
            }
        }
        out
    }

    #[test]
    fn all_terminators_end_a_line_and_crlf_is_one() {
        let got = lines(b"a\nb\rc\r\nd\n\re\r\r\n\nf\n");
        let want: Vec<Result<Vec<u8>, LineError>> =
            ["a", "b", "c", "d", "e", "f"].iter().map(|s| Ok(s.as_bytes().to_vec())).collect();
        assert_eq!(got, want);
    }

    #[test]
    fn over_long_line_is_discarded_to_the_terminator_and_reported() {
        let got = lines(b"0123456789abcdefXYZ\n<HOME>\n");
        assert_eq!(got[0], Err(LineError::TooLong { len: 19 }));
        assert_eq!(got[1], Ok(b"<HOME>".to_vec()));
        // exactly the capacity is fine
        assert_eq!(lines(b"0123456789abcdef\n"), vec![Ok(b"0123456789abcdef".to_vec())]);
    }

    #[test]
    fn binary_noise_rejects_its_line_only() {
        let got = lines(b"<HO\0ME>\n\xff\xfe\n<HOME>\n");
        assert_eq!(got[0], Err(LineError::NonPrintable { byte: 0, at: 3 }));
        assert_eq!(got[1], Err(LineError::NonPrintable { byte: 0xff, at: 0 }));
        assert_eq!(got[2], Ok(b"<HOME>".to_vec()));
        assert_eq!(got.len(), 3);
    }

    #[test]
    fn counters_count() {
        let mut f = Framer::<4>::new();
        for &b in b"\n\nabcdef\nab\x01\nok\n" {
            let _ = f.push(b);
        }
        let c = f.counters();
        assert_eq!(c, FramerCounters { lines: 3, too_long: 1, non_printable: 1, empty: 2 });
    }
}
