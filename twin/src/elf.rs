//! Minimal ELF32 little-endian reader: loadable segments (by physical
//! address, which is where the Teensy image lives in FlexSPI flash) and the
//! symbol table (for diagnostics only).

use std::collections::HashMap;

/// One `PT_LOAD` segment's file bytes at its load (physical) address.
#[derive(Debug, Clone)]
pub struct Segment {
    /// Physical (load) address.
    pub paddr: u32,
    /// Virtual (run) address.
    pub vaddr: u32,
    /// File bytes (`p_filesz`).
    pub data: Vec<u8>,
}

/// The parsed image.
#[derive(Debug, Clone)]
pub struct Image {
    /// Loadable segments with file bytes.
    pub segments: Vec<Segment>,
    /// Function and object symbols: name -> address (thumb bit cleared).
    pub symbols: HashMap<String, u32>,
    /// Symbols without a type (the linker script's, e.g. imxrt-rt's
    /// `__estack` and `_stack_start`): name -> value.
    pub linker_symbols: HashMap<String, u32>,
    /// defmt's level markers (`__DEFMT_MARKER_*`): name -> value (an offset
    /// in `.defmt`, one byte per interned log string).
    pub defmt_markers: HashMap<String, u32>,
}

fn u16_at(b: &[u8], o: usize) -> Result<u16, String> {
    b.get(o..o + 2).map(|s| u16::from_le_bytes([s[0], s[1]])).ok_or_else(|| format!("ELF truncated at {o}"))
}
fn u32_at(b: &[u8], o: usize) -> Result<u32, String> {
    b.get(o..o + 4).map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]])).ok_or_else(|| format!("ELF truncated at {o}"))
}

impl Image {
    /// Parse an ELF32 ARM image.
    pub fn parse(b: &[u8]) -> Result<Self, String> {
        if b.get(0..4) != Some(b"\x7fELF") || b.get(4) != Some(&1) || b.get(5) != Some(&1) {
            return Err("not a 32-bit little-endian ELF".into());
        }
        let phoff = u32_at(b, 28)? as usize;
        let shoff = u32_at(b, 32)? as usize;
        let phentsize = u16_at(b, 42)? as usize;
        let phnum = u16_at(b, 44)? as usize;
        let shentsize = u16_at(b, 46)? as usize;
        let shnum = u16_at(b, 48)? as usize;
        let mut segments = Vec::new();
        for i in 0..phnum {
            let p = phoff + i * phentsize;
            let ptype = u32_at(b, p)?;
            let off = u32_at(b, p + 4)? as usize;
            let vaddr = u32_at(b, p + 8)?;
            let paddr = u32_at(b, p + 12)?;
            let filesz = u32_at(b, p + 16)? as usize;
            if ptype == 1 && filesz > 0 {
                let data = b.get(off..off + filesz).ok_or("segment beyond file")?.to_vec();
                segments.push(Segment { paddr, vaddr, data });
            }
        }
        let mut symbols = HashMap::new();
        let mut linker_symbols = HashMap::new();
        let mut defmt_markers = HashMap::new();
        for i in 0..shnum {
            let s = shoff + i * shentsize;
            if u32_at(b, s + 4)? != 2 {
                continue; // SHT_SYMTAB
            }
            let off = u32_at(b, s + 16)? as usize;
            let size = u32_at(b, s + 20)? as usize;
            let link = u32_at(b, s + 24)? as usize;
            let strs = shoff + link * shentsize;
            let stroff = u32_at(b, strs + 16)? as usize;
            for k in 0..size / 16 {
                let e = off + k * 16;
                let name_off = u32_at(b, e)? as usize;
                let value = u32_at(b, e + 4)?;
                let info = b.get(e + 12).copied().unwrap_or(0);
                let start = stroff + name_off;
                let end = b[start..].iter().position(|&c| c == 0).map(|n| start + n).unwrap_or(start);
                let name = String::from_utf8_lossy(&b[start..end]).into_owned();
                if name.starts_with("__DEFMT_MARKER_") {
                    defmt_markers.insert(name, value);
                    continue;
                }
                if info & 0xF == 0 && !name.is_empty() {
                    linker_symbols.entry(name).or_insert(value);
                    continue;
                }
                if !matches!(info & 0xF, 1 | 2) {
                    continue; // functions and objects only
                }
                if !name.is_empty() {
                    symbols.entry(name).or_insert(value & !1);
                }
            }
        }
        Ok(Image { segments, symbols, linker_symbols, defmt_markers })
    }

    /// defmt log statements compiled in, per level (`ERROR`, `WARN`,
    /// `INFO`, `DEBUG`, `TRACE`): `_END - _START` of each level's markers.
    pub fn defmt_log_statements(&self) -> Vec<(&'static str, u32)> {
        ["ERROR", "WARN", "INFO", "DEBUG", "TRACE"]
            .iter()
            .map(|l| {
                let m = |e: &str| self.defmt_markers.get(&format!("__DEFMT_MARKER_{l}_{e}")).copied().unwrap_or(0);
                (*l, m("END").saturating_sub(m("START")))
            })
            .collect()
    }

    /// Nearest symbol at or below `addr` (for diagnostics).
    pub fn symbolize(&self, addr: u32) -> String {
        let mut best: Option<(&str, u32)> = None;
        for (n, &a) in &self.symbols {
            if a <= addr && best.is_none_or(|(_, b)| a > b) && !n.starts_with('$') {
                best = Some((n, a));
            }
        }
        match best {
            Some((n, a)) => format!("{n}+{:#x}", addr - a),
            None => format!("{addr:#x}"),
        }
    }
}
