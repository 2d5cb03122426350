//! The image's own integrity check at boot: a CRC-32 of the flash image,
//! stamped into the image by `firmware/build.sh` after the link
//! (`firmware/tools/stamp_crc.py`) and recomputed by the image before its
//! tick starts. A mismatch means a corrupt or half-written image; it refuses
//! to run.
//!
//! The stamp ([`Stamp`]) is a static the image places in flash (`.xip`, its
//! load address is its run address). The CRC covers the flash image from its
//! first byte to `len` (the end of the last loaded section, gaps between
//! sections read as erased flash, 0xFF) with the stamp's `len` and `crc`
//! words read as zero, so stamping does not change what it covers.
//!
//! CRC-32/ISO-HDLC (the `crc` crate's table-driven implementation, 1 KiB
//! table built at compile time; the same CRC as Python's `zlib.crc32`,
//! which the stamping tool uses): every burst error up to 32 bits and every
//! odd number of bit errors is detected, any other corruption with
//! probability 1 - 2^-32.

use crc::{Crc, CRC_32_ISO_HDLC};

/// The stamp's magic word ("P6CK").
pub const STAMP_MAGIC: u32 = u32::from_le_bytes(*b"P6CK");

/// Largest image the check accepts (the linked flash region, 1984 KiB).
pub const IMAGE_MAX: usize = 1984 * 1024;

/// The CRC the stamp holds.
pub const CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

/// The stamp: `magic` is in the image as built; `len` and `crc` are 0 as
/// built and written by the stamping tool.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct Stamp {
    /// [`STAMP_MAGIC`].
    pub magic: u32,
    /// Bytes of the flash image the CRC covers, from its first byte.
    pub len: u32,
    /// CRC-32 of those bytes with `len` and `crc` read as zero.
    pub crc: u32,
}

impl Stamp {
    /// The stamp as compiled, before the stamping tool writes it.
    pub const UNSTAMPED: Stamp = Stamp { magic: STAMP_MAGIC, len: 0, crc: 0 };
}

/// Why the image check failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFault {
    /// The stamp's magic word is wrong (the stamp itself is corrupt).
    Magic,
    /// `len` is 0 (never stamped), beyond [`IMAGE_MAX`], or does not cover
    /// the stamp.
    Length,
    /// The computed CRC differs from the stamped one.
    Crc {
        /// Stamped.
        expected: u32,
        /// Computed.
        computed: u32,
    },
}

/// Checks the stamp's fields against the image (`len` within bounds and
/// covering the stamp at `stamp_offset`); returns the covered length.
pub fn covered_len(stamp: &Stamp, stamp_offset: usize) -> Result<usize, ImageFault> {
    if stamp.magic != STAMP_MAGIC {
        return Err(ImageFault::Magic);
    }
    let len = stamp.len as usize;
    let stamp_end = stamp_offset.checked_add(core::mem::size_of::<Stamp>()).ok_or(ImageFault::Length)?;
    if len == 0 || len > IMAGE_MAX || stamp_end > len {
        return Err(ImageFault::Length);
    }
    Ok(len)
}

/// The CRC of `image` (the covered bytes, from the image's first byte) with
/// the stamp's `len` and `crc` words (8 bytes from `stamp_offset + 4`) read
/// as zero. `None` if the stamp does not lie inside `image`.
pub fn image_crc(image: &[u8], stamp_offset: usize) -> Option<u32> {
    let fields = stamp_offset.checked_add(4)?;
    let (head, rest) = image.split_at_checked(fields)?;
    let tail = rest.get(8..)?;
    let mut d = CRC32.digest();
    d.update(head);
    d.update(&[0u8; 8]);
    d.update(tail);
    Some(d.finalize())
}

/// The whole check: stamp fields, then the CRC over `image`, which must be
/// at least the covered length (the flash from its first byte).
pub fn check(image: &[u8], stamp: &Stamp, stamp_offset: usize) -> Result<(), ImageFault> {
    let len = covered_len(stamp, stamp_offset)?;
    let covered = image.get(..len).ok_or(ImageFault::Length)?;
    let computed = image_crc(covered, stamp_offset).ok_or(ImageFault::Length)?;
    if computed == stamp.crc {
        Ok(())
    } else {
        Err(ImageFault::Crc { expected: stamp.crc, computed })
    }
}

#[cfg(test)]
#[allow(clippy::arithmetic_side_effects)]
mod tests {
    use super::*;

    /// An image with a stamp at `off`, stamped the way the tool does it.
    fn stamped(len: usize, off: usize) -> (Vec<u8>, Stamp) {
        let mut img: Vec<u8> = (0..len).map(|i| (i * 7 + 3) as u8).collect();
        img[off..off + 4].copy_from_slice(&STAMP_MAGIC.to_le_bytes());
        img[off + 4..off + 12].fill(0);
        // the tool's computation: zlib.crc32 of the image with the fields zero
        let crc = CRC32.checksum(&img);
        let stamp = Stamp { magic: STAMP_MAGIC, len: len as u32, crc };
        img[off + 4..off + 8].copy_from_slice(&stamp.len.to_le_bytes());
        img[off + 8..off + 12].copy_from_slice(&crc.to_le_bytes());
        (img, stamp)
    }

    #[test]
    fn the_crc_is_zlibs() {
        // CRC-32/ISO-HDLC check value (the catalogue's, = zlib.crc32(b"123456789"))
        assert_eq!(CRC32.checksum(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn a_stamped_image_passes_and_every_single_bit_flip_fails() {
        let (img, stamp) = stamped(600, 200);
        assert_eq!(check(&img, &stamp, 200), Ok(()));
        // every bit of the covered image, the stamp's own fields included
        // (flipping `len` or `crc` in flash changes the stamp the image reads)
        for bit in 0..img.len() * 8 {
            let mut bad = img.clone();
            bad[bit / 8] ^= 1 << (bit % 8);
            let s = Stamp {
                magic: u32::from_le_bytes(bad[200..204].try_into().unwrap()),
                len: u32::from_le_bytes(bad[204..208].try_into().unwrap()),
                crc: u32::from_le_bytes(bad[208..212].try_into().unwrap()),
            };
            assert!(check(&bad, &s, 200).is_err(), "bit {bit} flipped accepted");
        }
    }

    #[test]
    fn bad_stamps_are_refused() {
        let (img, stamp) = stamped(600, 200);
        assert_eq!(check(&img, &Stamp::UNSTAMPED, 200), Err(ImageFault::Length));
        assert_eq!(check(&img, &Stamp { magic: 0, ..stamp }, 200), Err(ImageFault::Magic));
        assert_eq!(check(&img, &Stamp { len: 100, ..stamp }, 200), Err(ImageFault::Length));
        assert_eq!(check(&img, &Stamp { len: 601, ..stamp }, 200), Err(ImageFault::Length));
        assert_eq!(check(&img, &Stamp { len: IMAGE_MAX as u32 + 1, ..stamp }, 200), Err(ImageFault::Length));
        assert!(matches!(check(&img, &Stamp { crc: stamp.crc ^ 1, ..stamp }, 200), Err(ImageFault::Crc { .. })));
    }
}
