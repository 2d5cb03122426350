#!/usr/bin/env python3
"""Call-graph analysis of the tick handler in a linked Cortex-M ELF.

Usage: tick_analysis.py <objdump> <elf> <root-symbol> [stack-sizes-elf]

1. Disassembles <elf> with llvm-objdump (-d -C) and builds a call graph from
   direct branches (bl / blx <sym> / b(.w) <sym> into another function =
   tail call). Indirect branches (blx rN, bx rN other than lr, ldr pc, tbb/tbh
   are intra-function) are listed: the analysis cannot follow them.
2. Panic check: FAILS (exit 1) if any function reachable from the root has a
   name containing a panic marker (core::panicking, rust_begin_unwind,
   panic_bounds_check, unwrap_failed, expect_failed, slice_*_fail, panic_fmt,
   the #[panic_handler] `panic`), or if an indirect call is reachable (unknown
   target: cannot be proved panic-free).
3. 64-bit division check: FAILS if a 64-bit (or 128-bit)
   division helper of compiler-builtins (`__aeabi_uldivmod`,
   `__aeabi_ldivmod`, `__udivmoddi4`, `__divmoddi4`, `__udivti3`, ...) is
   reachable from the root: the Cortex-M7 divides 32-bit numbers in
   hardware, wider ones in a software loop of hundreds of instructions.
   Prints every function reachable from the root.
4. Stack: if a second ELF built with `-Z emit-stack-sizes` is given, reads its
   .stack_sizes section (address -> frame bytes) and prints the worst path
   from the root in that ELF (same sources, nightly codegen: an estimate of
   the stable image, stated as such), plus the 104-byte exception frame
   (8 integer + 18 FP words with lazy FP stacking reserved). Recursion makes
   the bound infinite and is reported.
"""
import re, subprocess, sys

PANIC = ("core::panicking", "rust_begin_unwind", "panic_bounds_check", "unwrap_failed",
         "expect_failed", "slice_start_index_len_fail", "slice_end_index_len_fail",
         "slice_index_order_fail", "panic_fmt", "panic_const", "::panic")

WIDE_DIVISION = ("__aeabi_uldivmod", "__aeabi_ldivmod", "__udivmoddi4", "__divmoddi4", "__udivdi3",
                 "__divdi3", "__umoddi3", "__moddi3", "__udivti3", "__divti3", "__umodti3", "__modti3",
                 "__udivmodti4", "__divmodti4", "compiler_builtins::int::specialized_div_rem")

def disasm(objdump, elf):
    out = subprocess.run([objdump, "-d", "-C", "--no-show-raw-insn", elf],
                         check=True, capture_output=True, text=True).stdout
    funcs, addr_of, cur = {}, {}, None
    head = re.compile(r"^([0-9a-f]+) <(.+)>:$")
    for line in out.splitlines():
        m = head.match(line)
        if m:
            cur = m.group(2)
            addr_of[cur] = int(m.group(1), 16)
            funcs.setdefault(cur, {"calls": set(), "indirect": []})
            continue
        if cur is None or ":" not in line:
            continue
        ins = line.split(":", 1)[1].strip()
        parts = ins.split(None, 1)
        if not parts:
            continue
        op, rest = parts[0], (parts[1] if len(parts) > 1 else "")
        base = op.split(".")[0]
        # The target label may itself contain angle brackets (v0-mangled
        # generics, `<firmware::root::Controller>::step::<parol6::Teensy>`):
        # take everything from the first `<` to the last `>` before any
        # trailing `@ imm` comment.
        t = re.search(r"<(.+)>(?:\s*@.*)?$", rest)
        if base in ("bl", "blx", "b", "bne", "beq", "bhi", "bls", "bge", "blt", "bgt", "ble",
                    "bcs", "bcc", "bhs", "blo", "bmi", "bpl", "bvs", "bvc", "cbz", "cbnz"):
            if t:
                tgt = re.sub(r"\+0x[0-9a-f]+$", "", t.group(1))
                if tgt != cur:
                    funcs[cur]["calls"].add(tgt)
            elif base in ("blx",) or (base == "b" and rest.startswith("r")):
                funcs[cur]["indirect"].append(ins)
        elif base == "bx" and not rest.startswith("lr"):
            funcs[cur]["indirect"].append(ins)
        elif base in ("ldr", "pop", "ldm") and re.search(r"\bpc\b", rest) and base != "pop":
            if base == "ldr" and rest.startswith("pc"):
                funcs[cur]["indirect"].append(ins)
    return funcs, addr_of

def resolve(objdump, elf, root, addr_of):
    """objdump labels one name per address; find the label at root's address."""
    if root in addr_of:
        return root
    nm = objdump.replace("llvm-objdump", "llvm-nm")
    out = subprocess.run([nm, elf], check=True, capture_output=True, text=True).stdout
    for line in out.splitlines():
        p = line.split()
        if len(p) == 3 and p[2] == root:
            a = int(p[0], 16) & ~1
            for f, fa in addr_of.items():
                if fa == a:
                    print(f"(`{root}` is labelled `{f}` in the disassembly)")
                    return f
    return root

PARENT = {}

def reach(funcs, root):
    seen, stack = set(), [(root, None)]
    while stack:
        f, parent = stack.pop()
        if f in seen or f not in funcs:
            continue
        seen.add(f)
        PARENT[f] = parent
        stack.extend((c, f) for c in funcs[f]["calls"])
    return seen

def chain(f):
    out = []
    while f is not None:
        out.append(f)
        f = PARENT.get(f)
    return " <- ".join(out)

def stack_sizes(elf):
    import struct
    data = open(elf, "rb").read()
    # minimal ELF32 section reader
    shoff = struct.unpack_from("<I", data, 0x20)[0]
    shentsize, shnum, shstrndx = struct.unpack_from("<HHH", data, 0x2E)
    secs = [struct.unpack_from("<IIIIIIIIII", data, shoff + i * shentsize) for i in range(shnum)]
    strtab = secs[shstrndx]
    def name(off):
        s = data[strtab[4] + off:]
        return s[:s.index(b"\0")].decode()
    sizes = {}
    for s in secs:
        if name(s[0]) == ".stack_sizes":
            buf = data[s[4]:s[4] + s[5]]
            i = 0
            while i + 4 <= len(buf):
                addr = struct.unpack_from("<I", buf, i)[0]; i += 4
                val, shift = 0, 0
                while True:
                    b = buf[i]; i += 1
                    val |= (b & 0x7F) << shift; shift += 7
                    if b < 0x80:
                        break
                sizes[addr & ~1] = val
    return sizes

def worst(funcs, addr_of, sizes, root):
    memo, unknown = {}, set()
    def go(f, path):
        if f in path:
            return float("inf"), [f + " (recursion)"]
        if f in memo:
            return memo[f]
        own = sizes.get(addr_of.get(f, -1) & ~1)
        if own is None:
            unknown.add(f); own = 0
        best, bp = 0, []
        for c in funcs.get(f, {"calls": ()})["calls"]:
            if c not in funcs:
                continue
            v, p = go(c, path | {f})
            if v > best:
                best, bp = v, p
        memo[f] = (own + best, [f"{f} ({own})"] + bp)
        return memo[f]
    total, path = go(root, frozenset())
    return total, path, unknown

def main():
    objdump, elf, root = sys.argv[1:4]
    funcs, addr_of = disasm(objdump, elf)
    root = resolve(objdump, elf, root, addr_of)
    if root not in funcs:
        print(f"root symbol {root} not found"); sys.exit(2)
    r = reach(funcs, root)
    print(f"tick handler `{root}`: {len(r)} reachable functions (direct calls)")
    bad = sorted(f for f in r if any(p in f for p in PANIC) or f == "panic" or f.startswith("rust_begin"))
    ind = [(f, i) for f in sorted(r) for i in funcs[f]["indirect"]]
    for f, i in ind:
        print(f"  indirect branch in {f}: {i}")
    for f in sorted(r):
        print(f"  reaches {f}")
    ok = True
    wide = sorted(f for f in r if any(d in f for d in WIDE_DIVISION))
    if wide:
        ok = False
        print("64-BIT DIVISION reachable from the tick handler:")
        for f in wide:
            print("   " + chain(f))
    else:
        print("64-bit division check: no 64/128-bit division helper reachable")
    if bad:
        ok = False
        print("PANIC PATH reachable from the tick handler:")
        for f in bad:
            print("   " + chain(f))
        print("  (names are the disassembler's labels; identical-code-folded panic helpers")
        print("   share one label, so the helper's name may not be the panic's cause)")
    if ind:
        ok = False
        print("indirect branches reachable: cannot prove the tick panic-free")
    if len(sys.argv) > 4:
        f2, a2 = disasm(objdump, sys.argv[4])
        root = resolve(objdump, sys.argv[4], sys.argv[3], a2)
        sizes = stack_sizes(sys.argv[4])
        if root in f2 and sizes:
            total, path, unknown = worst(f2, a2, sizes, root)
            print(f"worst-case tick stack (nightly -Z emit-stack-sizes build): {total} bytes"
                  f" + 104 exception frame = {total + 104} bytes")
            print("  path: " + " -> ".join(path))
            if unknown:
                print(f"  no .stack_sizes entry (counted 0): {sorted(unknown)}")
        else:
            print("stack: no .stack_sizes data (nightly build missing)")
    print("panic-path and division check:", "PASS" if ok else "FAIL")
    sys.exit(0 if ok else 1)

if __name__ == "__main__":
    main()
