//! March C- memory test, word-oriented, over any [`Memory`]: the image runs
//! it at boot on the RAM the tick's state will occupy (still uninitialised
//! then), the host tests run it on a simulated memory with injected faults.
//!
//! March C- (van de Goor): `{ ⇕(w0); ⇑(r0,w1); ⇑(r1,w0); ⇓(r0,w1); ⇓(r1,w0); ⇕(r0) }`,
//! 10 operations per word. With `0` the all-zero word and `1` its complement
//! it detects every stuck-at, transition and address-decoder fault and every
//! coupling fault (inversion, idempotent, state) between two cells in
//! different words at the same bit position; run once per data background
//! of [`BACKGROUNDS`], it also sees coupling between neighbouring bits of
//! one word (`0x5555_5555` puts every even bit opposite its neighbours).
//!
//! Written here rather than taken from a crate: no `no_std` crate on the
//! registry offers March tests over a caller-provided accessor, and the
//! algorithm is twenty lines.

/// Word-addressed memory under test.
pub trait Memory {
    /// Number of 32-bit words.
    fn words(&self) -> usize;
    /// Read word `i` (`i < words()`).
    fn read(&mut self, i: usize) -> u32;
    /// Write word `i` (`i < words()`).
    fn write(&mut self, i: usize, v: u32);
}

/// The data backgrounds: each runs the whole March C- with `0` = the
/// background and `1` = its complement.
pub const BACKGROUNDS: [u32; 2] = [0x0000_0000, 0x5555_5555];

/// Operations (reads + writes) per word of one March C- pass.
pub const OPS_PER_WORD: u32 = 10;

/// The first mismatch found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MarchFailure {
    /// Word index.
    pub word: usize,
    /// The value the March element expected.
    pub expected: u32,
    /// The value read.
    pub read: u32,
}

fn check<M: Memory + ?Sized>(m: &mut M, i: usize, expected: u32) -> Result<(), MarchFailure> {
    let read = m.read(i);
    if read == expected {
        Ok(())
    } else {
        Err(MarchFailure { word: i, expected, read })
    }
}

/// The direction of a March element.
#[derive(Clone, Copy)]
enum Order {
    Up,
    Down,
}

/// One March element over every word in `order`: read and compare with
/// `expect` (if any), then write `write` (if any). Not inlined: the six
/// elements of a pass share one copy of the loop (inlined and unrolled per
/// element, the image's test took 10 KB of flash).
#[inline(never)]
fn element<M: Memory + ?Sized>(
    m: &mut M,
    order: Order,
    expect: Option<u32>,
    write: Option<u32>,
) -> Result<(), MarchFailure> {
    let n = m.words();
    for k in 0..n {
        // k < n: the descending index n - 1 - k cannot wrap
        let i = match order {
            Order::Up => k,
            Order::Down => n.wrapping_sub(k).wrapping_sub(1),
        };
        if let Some(e) = expect {
            check(m, i, e)?;
        }
        if let Some(w) = write {
            m.write(i, w);
        }
    }
    Ok(())
}

/// One March C- pass with data background `bg`. Leaves every word at `bg`
/// when it passes.
pub fn march_c_minus<M: Memory + ?Sized>(m: &mut M, bg: u32) -> Result<(), MarchFailure> {
    let (zero, one) = (bg, !bg);
    element(m, Order::Up, None, Some(zero))?; // M0: ⇕(w0)
    element(m, Order::Up, Some(zero), Some(one))?; // M1: ⇑(r0,w1)
    element(m, Order::Up, Some(one), Some(zero))?; // M2: ⇑(r1,w0)
    element(m, Order::Down, Some(zero), Some(one))?; // M3: ⇓(r0,w1)
    element(m, Order::Down, Some(one), Some(zero))?; // M4: ⇓(r1,w0)
    element(m, Order::Up, Some(zero), None) // M5: ⇕(r0)
}

/// March C- once per background of [`BACKGROUNDS`]; the first failure.
/// Leaves the memory at `BACKGROUNDS[last]` when it passes.
pub fn test<M: Memory + ?Sized>(m: &mut M) -> Result<(), MarchFailure> {
    for bg in BACKGROUNDS {
        march_c_minus(m, bg)?;
    }
    Ok(())
}

#[cfg(test)]
#[allow(clippy::arithmetic_side_effects, clippy::indexing_slicing)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    /// A cell is (word, bit).
    type Cell = (usize, u32);

    #[derive(Clone, Copy, Debug)]
    enum Fault {
        /// The cell always reads (and holds) this value.
        StuckAt(Cell, bool),
        /// The cell cannot make this transition (false: 0 -> 1 fails).
        Transition(Cell, bool),
        /// A transition of the aggressor (rising if true) inverts the victim.
        Inversion { aggressor: Cell, rising: bool, victim: Cell },
        /// A transition of the aggressor (rising if `rising`) forces the
        /// victim to `value`.
        Idempotent { aggressor: Cell, rising: bool, victim: Cell, value: bool },
        /// While the aggressor holds `state`, the victim is forced to `value`.
        State { aggressor: Cell, state: bool, victim: Cell, value: bool },
        /// Word `a`'s address also selects word `b` (writes to `a` go to
        /// both; reads of `a` return `b`'s cells).
        Decoder { a: usize, b: usize },
    }

    struct SimMemory {
        cells: Vec<u32>,
        fault: Option<Fault>,
    }

    fn bit(v: u32, b: u32) -> bool {
        v >> b & 1 == 1
    }
    fn set(v: u32, b: u32, x: bool) -> u32 {
        if x {
            v | 1 << b
        } else {
            v & !(1 << b)
        }
    }

    impl SimMemory {
        fn new(words: usize, fault: Option<Fault>) -> Self {
            // arbitrary power-on content
            let cells = (0..words).map(|i| (i as u32).wrapping_mul(0x9E37_79B9)).collect();
            let mut m = SimMemory { cells, fault };
            m.settle();
            m
        }
        fn get(&self, (w, b): Cell) -> bool {
            bit(self.cells[w], b)
        }
        fn put(&mut self, (w, b): Cell, x: bool) {
            self.cells[w] = set(self.cells[w], b, x);
        }
        /// Apply the static faults (stuck-at, state coupling).
        fn settle(&mut self) {
            match self.fault {
                Some(Fault::StuckAt(c, x)) => self.put(c, x),
                Some(Fault::State { aggressor, state, victim, value }) if self.get(aggressor) == state => {
                    self.put(victim, value)
                }
                _ => {}
            }
        }
        fn store(&mut self, w: usize, v: u32) {
            let old = self.cells[w];
            let mut new = v;
            if let Some(Fault::Transition((fw, fb), up)) = self.fault {
                if fw == w && bit(old, fb) != up && bit(v, fb) == up {
                    new = set(new, fb, !up);
                }
            }
            self.cells[w] = new;
            let edge = |ab: u32, rising: bool| bit(old, ab) != rising && bit(new, ab) == rising;
            match self.fault {
                Some(Fault::Inversion { aggressor: (aw, ab), rising, victim }) if aw == w && edge(ab, rising) => {
                    let x = self.get(victim);
                    self.put(victim, !x);
                }
                Some(Fault::Idempotent { aggressor: (aw, ab), rising, victim, value })
                    if aw == w && edge(ab, rising) =>
                {
                    self.put(victim, value);
                }
                _ => {}
            }
        }
    }

    impl Memory for SimMemory {
        fn words(&self) -> usize {
            self.cells.len()
        }
        fn read(&mut self, i: usize) -> u32 {
            match self.fault {
                Some(Fault::Decoder { a, b }) if i == a => self.cells[b],
                _ => self.cells[i],
            }
        }
        fn write(&mut self, i: usize, v: u32) {
            self.store(i, v);
            if let Some(Fault::Decoder { a, b }) = self.fault {
                if i == a {
                    self.store(b, v);
                }
            }
            self.settle();
        }
    }

    const N: usize = 16;

    fn detected(f: Fault) -> bool {
        let mut m = SimMemory::new(N, Some(f));
        test(&mut m).is_err()
    }

    fn cells() -> impl Iterator<Item = Cell> {
        [0usize, 1, 7, N - 1].into_iter().flat_map(|w| [0u32, 1, 14, 31].into_iter().map(move |b| (w, b)))
    }

    #[test]
    fn a_fault_free_memory_passes_and_is_left_at_the_last_background() {
        let mut m = SimMemory::new(N, None);
        assert_eq!(test(&mut m), Ok(()));
        assert!(m.cells.iter().all(|&c| c == BACKGROUNDS[BACKGROUNDS.len() - 1]));
        let mut empty = SimMemory::new(0, None);
        assert_eq!(test(&mut empty), Ok(()));
    }

    #[test]
    fn every_stuck_at_cell_is_found_with_its_word() {
        for c in cells() {
            for x in [false, true] {
                let mut m = SimMemory::new(N, Some(Fault::StuckAt(c, x)));
                let e = test(&mut m).expect_err("stuck-at not detected");
                assert_eq!(e.word, c.0, "{c:?} stuck at {x}");
                assert_eq!(e.expected ^ e.read, 1 << c.1, "{c:?}: only the stuck bit differs");
            }
        }
    }

    #[test]
    fn every_transition_fault_is_found() {
        for c in cells() {
            for up in [false, true] {
                assert!(detected(Fault::Transition(c, up)), "{c:?} up={up}");
            }
        }
    }

    #[test]
    fn coupling_between_words_is_found_both_ways() {
        for a in cells() {
            for v in cells() {
                if a.0 == v.0 {
                    continue; // other words only here; same word below
                }
                // March C-'s guarantee is for aggressor and victim at the
                // same bit position (the backgrounds write whole words)
                let v = (v.0, a.1);
                for rising in [false, true] {
                    assert!(detected(Fault::Inversion { aggressor: a, rising, victim: v }), "CFin {a:?}->{v:?}");
                    for value in [false, true] {
                        assert!(
                            detected(Fault::Idempotent { aggressor: a, rising, victim: v, value }),
                            "CFid {a:?}->{v:?} rising={rising} value={value}"
                        );
                    }
                }
                for state in [false, true] {
                    for value in [false, true] {
                        assert!(
                            detected(Fault::State { aggressor: a, state, victim: v, value }),
                            "CFst {a:?}={state} -> {v:?}={value}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn coupling_between_neighbouring_bits_of_a_word_is_found() {
        // the 0x5555_5555 background puts a bit and its neighbours at
        // opposite values, so state coupling to the opposite value shows
        for w in [0usize, 5, N - 1] {
            for b in [1u32, 14, 30] {
                for (a, v) in [((w, b), (w, b + 1)), ((w, b + 1), (w, b))] {
                    for state in [false, true] {
                        let f = Fault::State { aggressor: a, state, victim: v, value: state };
                        // with aggressor and victim opposite in one background
                        // (0x5555_5555 or its complement) and the same in the
                        // other (all 0 or all 1), a victim forced equal to the
                        // aggressor shows in the first
                        assert!(detected(f), "{a:?}={state} -> {v:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn address_decoder_faults_are_found() {
        for a in [0usize, 3, N - 1] {
            for b in [0usize, 4, N - 2] {
                if a != b {
                    assert!(detected(Fault::Decoder { a, b }), "{a} -> {b}");
                }
            }
        }
    }

    #[test]
    fn operations_are_ten_per_word_per_background() {
        struct Count(SimMemory, u32);
        impl Memory for Count {
            fn words(&self) -> usize {
                self.0.words()
            }
            fn read(&mut self, i: usize) -> u32 {
                self.1 += 1;
                self.0.read(i)
            }
            fn write(&mut self, i: usize, v: u32) {
                self.1 += 1;
                self.0.write(i, v)
            }
        }
        let mut m = Count(SimMemory::new(N, None), 0);
        test(&mut m).unwrap();
        assert_eq!(m.1, OPS_PER_WORD * N as u32 * BACKGROUNDS.len() as u32);
    }
}
