#!/usr/bin/env python3
"""Stamp the image's CRC-32 into its ELF (firmware::image, read at boot).

Usage: stamp_crc.py ELF

The flash image is every loaded segment whose load address lies in the
FlexSPI flash (0x6000_0000), from the flash's first byte to the end of the
last one; gaps between segments read as erased flash (0xFF), which is what
the Teensy loader leaves there. The symbol PAROL6_IMAGE_STAMP (magic, len,
crc; in `.xip`, so its run address is its flash address) gets len = the
image's length and crc = CRC-32/ISO-HDLC (zlib.crc32) of the image with the
len and crc words zero. Stamping twice gives the same bytes.
"""
import struct
import sys
import zlib

FLASH = 0x6000_0000
IMAGE_MAX = 1984 * 1024
MAGIC = b"P6CK"
SYMBOL = b"PAROL6_IMAGE_STAMP"


def main(path):
    with open(path, "rb") as f:
        elf = bytearray(f.read())
    if elf[:4] != b"\x7fELF" or elf[4] != 1 or elf[5] != 1:
        sys.exit(f"{path}: not a little-endian ELF32 file")
    e_phoff, e_shoff = struct.unpack_from("<II", elf, 28)
    e_phentsize, e_phnum, e_shentsize, e_shnum = struct.unpack_from("<HHHH", elf, 42)
    segs = []
    for i in range(e_phnum):
        p_type, p_offset, _vaddr, p_paddr, p_filesz = struct.unpack_from("<IIIII", elf, e_phoff + i * e_phentsize)
        if p_type == 1 and p_filesz > 0 and FLASH <= p_paddr < FLASH + IMAGE_MAX:
            segs.append((p_paddr, p_offset, p_filesz))
    if not segs:
        sys.exit(f"{path}: no segment loads into flash")
    end = max(a + n for a, _, n in segs)
    if end - FLASH > IMAGE_MAX:
        sys.exit(f"{path}: image of {end - FLASH} B exceeds {IMAGE_MAX} B")
    # the stamp's address from the symbol table
    stamp = None
    for i in range(e_shnum):
        sh = struct.unpack_from("<IIIIIIIIII", elf, e_shoff + i * e_shentsize)
        if sh[1] != 2:  # SHT_SYMTAB
            continue
        strtab = struct.unpack_from("<IIIIIIIIII", elf, e_shoff + sh[6] * e_shentsize)
        for k in range(sh[5] // 16):
            st_name, st_value = struct.unpack_from("<II", elf, sh[4] + k * 16)
            s = strtab[4] + st_name
            if elf[s:s + len(SYMBOL) + 1] == SYMBOL + b"\0":
                stamp = st_value
    if stamp is None or not FLASH <= stamp < end - 12:
        sys.exit(f"{path}: no {SYMBOL.decode()} in the flash image")
    image = bytearray(b"\xff" * (end - FLASH))
    for a, off, n in segs:
        image[a - FLASH:a - FLASH + n] = elf[off:off + n]
    so = stamp - FLASH
    if image[so:so + 4] != MAGIC:
        sys.exit(f"{path}: {SYMBOL.decode()} does not start with {MAGIC!r}")
    image[so + 4:so + 12] = bytes(8)
    crc = zlib.crc32(bytes(image)) & 0xFFFF_FFFF
    fields = struct.pack("<II", end - FLASH, crc)
    for a, off, n in segs:
        if a <= stamp + 4 and stamp + 12 <= a + n:
            elf[off + stamp + 4 - a:off + stamp + 12 - a] = fields
            break
    else:
        sys.exit(f"{path}: the stamp is not inside one segment")
    with open(path, "wb") as f:
        f.write(elf)
    print(f"image CRC-32 {crc:#010x} over {end - FLASH} B stamped at {stamp:#x}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
