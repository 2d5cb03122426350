//! The stack guard: a no-access region of the Cortex-M7's MPU (ARMv7-M
//! PMSAv7) at the low end of the main stack, so a stack that grows into it
//! faults on the first access instead of running on.
//!
//! The image's only stack is the main stack (MSP): thread code runs on it
//! (cortex-m-rt never switches to the process stack) and so does every
//! exception handler (always MSP). imxrt-rt places it first in DTCM, from
//! [`STACK_BOTTOM`] (its `__estack`) up to `STACK_BOTTOM + 32 KiB`, with the
//! statics above it; it grows down, towards the start of DTCM.
//!
//! Layout of the stack's low end:
//!
//! | range | what |
//! |---|---|
//! | `STACK_BOTTOM .. + 1 KiB` | the fatal path's stack: the HardFault entry's frame and `fatal_stop` |
//! | `+ 1 KiB .. + 2 KiB` | the guard: no access (read, write, execute) while the MPU is on |
//! | `+ 2 KiB ..` | the stack proper (30 KiB) |
//!
//! An access into the guard is a MemManage fault; MemManage is not enabled
//! (`SHCSR[MEMFAULTENA] = 0`), so it escalates to HardFault at once, whose
//! handler runs the STEP-low fatal path. `MPU_CTRL[HFNMIENA] = 0` turns
//! the MPU off while the HardFault handler runs, so its exception frame and
//! its own calls may use the guard and the kilobyte below it (the frame is
//! pushed below the faulting stack pointer, which is at least at the
//! guard's bottom: the access that faulted was into the guard, and every
//! frame of the image is smaller than the guard, see
//! `firmware/tools/stack_analysis.py`). `PRIVDEFENA = 1` keeps the default
//! memory map everywhere else (the image runs privileged), so enabling the
//! MPU changes nothing but the guard.

/// The main stack's lowest address (imxrt-rt: the start of DTCM).
pub const STACK_BOTTOM: u32 = 0x2000_0000;
/// The main stack's size (imxrt-rt's default `stack_size`, 32 KiB).
pub const STACK_SIZE: u32 = 32 * 1024;
/// The guard's size: 2^10 = 1 KiB.
pub const GUARD_LOG2: u8 = 10;
/// Below the guard: the fatal path's stack (1 KiB).
pub const FATAL_RESERVE: u32 = 1024;
/// The guard's base address.
pub const GUARD_BASE: u32 = STACK_BOTTOM + FATAL_RESERVE;
/// The guard's size in bytes.
pub const GUARD_SIZE: u32 = 1 << GUARD_LOG2;
/// The stack left to the program above the guard.
pub const STACK_USABLE: u32 = STACK_SIZE - FATAL_RESERVE - GUARD_SIZE;
/// The MPU region number of the guard (the image uses no other).
pub const GUARD_REGION: u8 = 0;

/// `MPU_CTRL`: `ENABLE`.
pub const CTRL_ENABLE: u32 = 1 << 0;
/// `MPU_CTRL`: `HFNMIENA` (MPU on in HardFault and NMI handlers).
pub const CTRL_HFNMIENA: u32 = 1 << 1;
/// `MPU_CTRL`: `PRIVDEFENA` (the default map for privileged accesses
/// outside every region).
pub const CTRL_PRIVDEFENA: u32 = 1 << 2;
/// The image's `MPU_CTRL`: on, default map elsewhere, off in HardFault.
pub const GUARD_CTRL: u32 = CTRL_ENABLE | CTRL_PRIVDEFENA;

/// `MPU_RBAR[VALID]`: the region number is taken from the write.
pub const RBAR_VALID: u32 = 1 << 4;
/// `MPU_RASR[XN]`: no instruction fetch.
pub const RASR_XN: u32 = 1 << 28;
/// `MPU_RASR[ENABLE]`.
pub const RASR_ENABLE: u32 = 1;

/// An MPU region's register values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    /// `MPU_RBAR`: base address, `VALID`, region number.
    pub rbar: u32,
    /// `MPU_RASR`: `XN`, `AP`, size, `ENABLE`.
    pub rasr: u32,
}

/// Why a region cannot be encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MpuError {
    /// Region number outside 0..=15 (the i.MXRT1062's M7 has 16).
    Region,
    /// Size outside 32 B ..= 4 GiB (`size_log2` 5..=32).
    Size,
    /// Base not aligned to the region's size.
    Alignment,
}

/// A no-access region (`AP = 0b000`: no read or write at any privilege,
/// `XN`: no fetch) of `2^size_log2` bytes at `base`, as region `region`.
pub const fn no_access(region: u8, base: u32, size_log2: u8) -> Result<Region, MpuError> {
    if region > 15 {
        return Err(MpuError::Region);
    }
    if size_log2 < 5 || size_log2 > 32 {
        return Err(MpuError::Size);
    }
    // size_log2 is 5..=32: the 64-bit mask neither overflows nor wraps
    let mask = (1u64 << size_log2).wrapping_sub(1);
    if (base as u64) & mask != 0 {
        return Err(MpuError::Alignment);
    }
    let size_field = (size_log2 as u32).wrapping_sub(1) << 1;
    Ok(Region { rbar: base | RBAR_VALID | region as u32, rasr: RASR_XN | size_field | RASR_ENABLE })
}

/// The image's stack guard.
pub const GUARD: Region = match no_access(GUARD_REGION, GUARD_BASE, GUARD_LOG2) {
    Ok(r) => r,
    Err(_) => panic!("stack guard: not an MPU region"),
};

const _: () = assert!(GUARD_BASE >= STACK_BOTTOM + FATAL_RESERVE);
const _: () = assert!(GUARD_BASE + GUARD_SIZE < STACK_BOTTOM + STACK_SIZE);

/// The guard's address range `[start, end)` from a region's registers, if
/// the region is enabled: what the twin checks the image wrote.
pub const fn range(r: Region) -> Option<(u32, u64)> {
    if r.rasr & RASR_ENABLE == 0 {
        return None;
    }
    // SIZE is 5 bits: size_log2 = SIZE + 1 is 1..=32
    let size_log2 = ((r.rasr >> 1) & 0x1F).wrapping_add(1);
    if size_log2 < 5 {
        return None;
    }
    let size = 1u64 << size_log2;
    let base = (r.rbar as u64) & !size.wrapping_sub(1);
    Some((base as u32, base.wrapping_add(size)))
}

// Test code is built with overflow checks on: an overflow fails the test.
#[cfg(test)]
#[allow(clippy::arithmetic_side_effects)]
mod tests {
    use super::*;

    #[test]
    fn the_guard_is_one_kib_of_no_access_above_the_fatal_reserve() {
        assert_eq!(GUARD.rbar, 0x2000_0400 | 0x10);
        // XN, AP = 000, SIZE = 9 (2^10), ENABLE
        assert_eq!(GUARD.rasr, 0x1000_0013);
        assert_eq!(GUARD.rasr & (7 << 24), 0, "AP must be no access");
        assert_eq!(range(GUARD), Some((0x2000_0400, 0x2000_0800)));
        assert_eq!(STACK_USABLE, 30 * 1024);
        assert_eq!(GUARD_CTRL, 0b101);
    }

    #[test]
    fn bad_regions_are_refused() {
        assert_eq!(no_access(16, 0x2000_0000, 10), Err(MpuError::Region));
        assert_eq!(no_access(0, 0x2000_0000, 4), Err(MpuError::Size));
        assert_eq!(no_access(0, 0x2000_0000, 33), Err(MpuError::Size));
        assert_eq!(no_access(0, 0x2000_0200, 10), Err(MpuError::Alignment));
        assert_eq!(no_access(0, 0x2000_0020, 5).map(|r| r.rasr & 0x3E), Ok(4 << 1));
        assert_eq!(no_access(0, 0, 32).map(range), Ok(Some((0, 1u64 << 32))));
    }

    #[test]
    fn a_disabled_region_has_no_range() {
        let r = Region { rbar: GUARD.rbar, rasr: GUARD.rasr & !RASR_ENABLE };
        assert_eq!(range(r), None);
    }
}
