//! RAM faults injected through Unicorn memory hooks: a cell (one bit of a
//! RAM word) stuck at 0 or 1. Before every read that touches the word, the
//! hook forces the bit in the stored word, so whatever was written, the
//! read returns the stuck value, as a cell whose storage node is shorted
//! would. The fault is hardware: it survives a chip reset.

use unicorn_engine::{HookType, MemType, Unicorn};

use crate::board::Board;
use crate::machine::Twin;

impl Twin {
    /// Bit `bit` (0..32) of the RAM word at `addr` (rounded down to a word)
    /// reads `value` from now on.
    pub fn stuck_bit(&mut self, addr: u32, bit: u32, value: bool) -> Result<(), String> {
        if bit >= 32 {
            return Err(format!("bit {bit} out of range"));
        }
        let word = u64::from(addr & !3);
        let mask = 1u32 << bit;
        let force = move |uc: &mut Unicorn<'_, Board>, _: MemType, a: u64, size: usize, _: i64| -> bool {
            // the access [a, a + size) overlaps the word
            if a < word + 4 && a + size as u64 > word {
                let mut b = [0u8; 4];
                if uc.mem_read(word, &mut b).is_ok() {
                    let v = u32::from_le_bytes(b);
                    let f = if value { v | mask } else { v & !mask };
                    if f != v {
                        let _ = uc.mem_write(word, &f.to_le_bytes());
                    }
                }
            }
            true
        };
        // accesses that start up to 60 bytes below the word (LDM/LDRD/VLDM
        // spanning it) are seen too
        self.uc
            .add_mem_hook(HookType::MEM_READ, word.saturating_sub(60), word + 3, force)
            .map_err(|e| format!("unicorn: {e:?}"))?;
        // A cell that fails while the image runs: code translated before
        // the hook, and its cached address translations, would not see it;
        // both caches are dropped so every later read goes through the hook.
        self.uc.ctl_flush_tb().map_err(|e| format!("unicorn: {e:?}"))?;
        self.uc.ctl_flush_tlb().map_err(|e| format!("unicorn: {e:?}"))
    }

    /// The address of the image's static whose symbol contains `name`
    /// (Rust statics are mangled: `_ZN...8TICK_CTX17h...E`).
    pub fn static_addr(&self, name: &str) -> Option<u32> {
        let mut hits = self.image.symbols.iter().filter(|(k, _)| k.contains(name));
        let (_, &a) = hits.next()?;
        Some(a)
    }

    /// The value of a linker-script symbol of the image (`__sbss`,
    /// `__estack`, `__svector_table`, ...).
    pub fn linker_symbol(&self, name: &str) -> Option<u32> {
        self.image.linker_symbols.get(name).copied()
    }
}
