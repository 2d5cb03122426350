#!/usr/bin/env python3
"""Worst-case main-stack bound of the whole image, against the stack guard.

Usage: stack_analysis.py <objdump> <stack-sizes-elf>

The image has one stack, the main stack (MSP): thread code (reset, boot,
the main loop) and every handler run on it. Its low end is the stack guard
(hal_imxrt::pure::mpu): 1 KiB of no access 1 KiB above the bottom, so the
program may use STACK_USABLE = 32 KiB - 2 KiB = 30,720 bytes.

From a build with `-Z emit-stack-sizes` (frame bytes per function) and the
direct-call graph (tick_analysis.py's disassembly), this prints:

1. the worst direct-call path from `main` (the reset entry: boot, the root's
   construction, the main loop);
2. the worst path of each enabled handler (PIT; LPUART6 and USB_OTG1, which
   only mask themselves), each plus the 104-byte exception frame;
3. the bound: main + the deepest of the lower-priority handlers (LPUART6 /
   USB_OTG1 at priority 0x80) + PIT (priority 0, preempts them), and
   FAILS (exit 1) if it exceeds STACK_USABLE;
4. every frame larger than the guard: such a frame could step over the guard
   (its accesses landing below it, unseen). FAILS unless the function is
   called only from the top of the stack (`main` or `__cortex_m_rt_main`,
   whose depth the bound of 3 covers);
5. the fatal path's stack (HardFault and DefaultHandler, each plus the
   exception frame): an overflow faults with the stack pointer at the
   guard's bottom or above it (every frame below the top is smaller than
   the guard, 4), and the handler runs with the MPU off, so it has the
   guard's kilobyte and the one below; FAILS if it needs more than the
   kilobyte below (FATAL_RESERVE), the room it has in the worst case;
6. the RAM tests' own calls (the boot test and the run-time step): each
   tests the stack below the stack pointer it reads less STACK_MARGIN (read
   from ram_test.rs), so the frames of its callees must fit in that margin;
   FAILS otherwise.

Indirect calls (the USB stack's class dispatch) are listed, not followed:
the bound covers direct calls; what an indirect callee adds is caught by the
guard as long as its frames are smaller than the guard (check 4).
"""
import os
import re
import sys

sys.path.insert(0, os.path.dirname(__file__))
from tick_analysis import disasm, resolve, reach, stack_sizes, worst  # noqa: E402

STACK_SIZE = 32 * 1024
GUARD = 1024
FATAL_RESERVE = 1024
STACK_USABLE = STACK_SIZE - GUARD - FATAL_RESERVE
FRAME = 104  # exception frame with lazily stacked FP context
# `main` runs the boot RAM test and calls `start` (boot and the main loop):
# all three at the top of the stack.
TOP = ("main", "parol6::target::__cortex_m_rt_main", "parol6::target::start")
# The RAM tests (firmware/src/target/ram_test.rs) test the stack below the
# stack pointer they read less STACK_MARGIN; their callees must fit in that
# margin (check 6).
RAM_TEST = ("parol6::target::ram_test::run", "<parol6::target::ram_test::RunTimeTest>::step")
RAM_TEST_SRC = os.path.join(os.path.dirname(__file__), "..", "src", "target", "ram_test.rs")


def main():
    objdump, elf = sys.argv[1:3]
    funcs, addr_of = disasm(objdump, elf)
    sizes = stack_sizes(elf)
    if not sizes:
        print("stack: no .stack_sizes data"); sys.exit(2)
    ok = True
    root = resolve(objdump, elf, "main", addr_of)
    m, mpath, munknown = worst(funcs, addr_of, sizes, root)
    print(f"main (reset, boot, main loop), direct calls: {m} bytes")
    print("  path: " + " -> ".join(mpath))
    handlers = {}
    for h in ("PIT", "LPUART6", "USB_OTG1"):
        r = resolve(objdump, elf, h, addr_of)
        if r not in funcs:
            print(f"  handler {h}: not found"); ok = False; continue
        v, p, _ = worst(funcs, addr_of, sizes, r)
        handlers[h] = v + FRAME
        print(f"handler {h}: {v} + {FRAME} exception frame = {v + FRAME} bytes ({' -> '.join(p)})")
    low = max(handlers.get("LPUART6", 0), handlers.get("USB_OTG1", 0))
    total = m + low + handlers.get("PIT", 0)
    print(f"bound: main {m} + LPUART6/USB_OTG1 {low} + PIT {handlers.get('PIT', 0)} = {total} bytes"
          f" of {STACK_USABLE} usable above the guard ({STACK_USABLE - total} to spare)")
    if total > STACK_USABLE:
        ok = False
        print("FAIL: the bound exceeds the stack above the guard")
    if munknown:
        print(f"  no .stack_sizes entry (counted 0): {sorted(munknown)}")
    r = reach(funcs, root)
    ind = [(f, i) for f in sorted(r) for i in funcs[f]["indirect"]]
    print(f"indirect calls not followed (from main): {len(ind)}")
    for f, i in ind:
        print(f"  {f}: {i}")
    name_at = {a & ~1: n for n, a in addr_of.items()}
    callers = {}
    for f, d in funcs.items():
        for c in d["calls"]:
            callers.setdefault(c, set()).add(f)
    big = sorted(((s, name_at.get(a, hex(a))) for a, s in sizes.items() if s > GUARD), reverse=True)
    for s, f in big:
        cs = callers.get(f, set())
        top_only = f in TOP or (cs and all(c in TOP for c in cs))
        print(f"frame over the guard: {f} {s} bytes, called from {sorted(cs) or 'nothing direct'}:"
              f" {'top of the stack only' if top_only else 'FAIL: could step over the guard'}")
        ok &= bool(top_only)
    for h in ("HardFault", "DefaultHandler"):
        r = resolve(objdump, elf, h, addr_of)
        if r not in funcs:
            print(f"fatal path {h}: not found"); ok = False; continue
        v, p, _ = worst(funcs, addr_of, sizes, r)
        fits = v + FRAME <= FATAL_RESERVE
        print(f"fatal path {h}: {v} + {FRAME} exception frame = {v + FRAME} bytes of the {FATAL_RESERVE} below"
              f" the guard ({' -> '.join(p)}){'' if fits else ': FAIL'}")
        ok &= fits
    m_src = re.search(r"const STACK_MARGIN: u32 = (\d+);", open(RAM_TEST_SRC).read())
    for fn in RAM_TEST:
        if fn not in funcs or m_src is None:
            print(f"RAM test: {fn} or STACK_MARGIN not found: FAIL"); ok = False
            continue
        margin = int(m_src.group(1))
        v, p, unknown = worst(funcs, addr_of, sizes, fn)
        own = sizes.get(addr_of.get(fn, -1) & ~1, 0)
        fits = not unknown and v - own < margin
        print(f"RAM test {fn}: its callees use {v - own} bytes below the stack pointer it reads"
              f" ({' -> '.join(p)}), STACK_MARGIN {margin}{'' if fits else ': FAIL'}"
              f"{f' (no .stack_sizes entry: {sorted(unknown)})' if unknown else ''}")
        ok &= fits
    print("main-stack check:", "PASS" if ok else "FAIL")
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
