#!/usr/bin/env python3
"""Flash bytes of the release image by crate (what each crate contributes
to the image).

Usage: size_by_crate.py LLVM_NM ELF

Counts every symbol in a loadable flash section (code and read-only data:
nm types t/T/r/R), grouped by the first path segment of its demangled name
(`<f32 as core::str::FromStr>::from_str` counts for `core`, the trait's
crate, since the code is core's). Anonymous constants (`.Lanon.*`: string
literals, tables) are one group. The Teensy boot header (`.boot`: FlexSPI
configuration, IVT, boot data) and the vector table are fixed costs and
listed apart. Symbols without a size are not counted. Inlined code counts for
the function it was inlined into (the kernel's tick is inlined into
`firmware::root::Controller::kernel_step`), so the figures show where bytes sit, not which source wrote them.
"""
import re
import subprocess
import sys
from collections import Counter

nm, elf = sys.argv[1], sys.argv[2]


def crate_of(name: str) -> str:
    if name.startswith(".Lanon") or name.startswith("anon."):
        return "(anonymous constants)"
    n = name.replace("_$LT$", "<").replace("$u20$", " ")
    # `<A as B>::f`: the code is B's trait impl; take the type's crate for
    # inherent impls (`<A>::f`) and the trait's for `as` impls.
    m = re.match(r"^<(.+?) as ([A-Za-z0-9_]+)", n)
    if m:
        first = m.group(1).lstrip("&*").split("::")[0]
        trait = m.group(2)
        # primitive types have no crate: the trait's crate holds the code
        return trait if first in ("f32", "f64", "u8", "u16", "u32", "i32", "str", "[T]") or "::" not in m.group(1) else first
    n = n.lstrip("<&*")
    seg = re.split(r"::|<| ", n, maxsplit=1)[0]
    if seg.startswith("__aeabi") or seg.startswith("__") and seg.endswith(("df3", "sf3", "di3", "si3")):
        return "compiler_builtins"
    if seg in ("PIT", "__cortex_m_rt_main", "main", "parol6"):
        return "parol6 (the image: PIT handler and main, with what they inline)"
    return seg or "(unnamed)"


out = subprocess.run([nm, "-S", "-C", "--size-sort", "--radix=d", elf], capture_output=True, text=True, check=True).stdout
by = Counter()
counted = 0
for line in out.splitlines():
    parts = line.split(None, 3)
    if len(parts) < 4:
        continue
    _, size, kind, name = parts
    if kind not in "tTrR":
        continue
    size = int(size)
    by[crate_of(name)] += size
    counted += size

heads = subprocess.run([nm.replace("llvm-nm", "llvm-size"), "-A", "-d", elf], capture_output=True, text=True, check=True).stdout
sections = {}
for line in heads.splitlines():
    p = line.split()
    if len(p) >= 3 and p[0].startswith("."):
        sections[p[0]] = int(p[1])
flash = sum(sections.get(s, 0) for s in (".boot", ".vector_table", ".text", ".rodata", ".data"))
print(f"flash image {flash} B: .boot {sections.get('.boot', 0)} (Teensy boot header, fixed), "
      f".vector_table {sections.get('.vector_table', 0)}, .text {sections.get('.text', 0)}, "
      f".rodata {sections.get('.rodata', 0)}, .data {sections.get('.data', 0)}")
print(f"sized symbols in flash sections: {counted} B. Code inlined into a caller counts for the caller")
print("(the kernel's tick is inlined into the firmware crate's Controller::kernel_step, the host's receive and formatting into main).\n")
print("| crate | bytes | share of the image |")
print("|---|---:|---:|")
for crate, size in by.most_common():
    if size < 200:
        continue
    print(f"| {crate} | {size} | {100.0 * size / flash:.1f} % |")
small = sum(s for s in by.values() if s < 200)
print(f"| (crates under 200 B each) | {small} | {100.0 * small / flash:.1f} % |")
