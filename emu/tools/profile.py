#!/usr/bin/env python3
"""Per-function profile of a measured region (emu/plugin/count.c prof=FILE:NAME).

Usage: emu/tools/profile.py ELF PROF SAMPLES [TOP]
       emu/tools/profile.py --steps ELF PROF SAMPLES

PROF has one "ADDRESS COUNT" line per instruction executed in the region.
Each address is attributed to the innermost function it was inlined from
(llvm-symbolizer on the ELF's debug info), generic parameters and hashes
stripped, so the kernel's inlined steps (Interpolator::advance,
AlphaBeta::step, ...) show separately even though LTO inlined them into one
function. Prints instructions per sample (SAMPLES = number of region
executions) and the share of each function, largest first.

With --steps, each address is attributed instead to the innermost of the
kernel's named steps it was inlined into (`STEPS`: sense and estimate,
intake, the set-point generator, the control law, the checks...), so a
minimum inlined into the interpolator counts for the interpolator.
"""
import collections
import re
import subprocess
import sys


ESCAPES = {"$LT$": "<", "$GT$": ">", "$u20$": " ", "$C$": ",", "$RF$": "&", "$BP$": "*", "$u7b$": "{",
           "$u7d$": "}", "$u5b$": "[", "$u5d$": "]", "$u3b$": ";", "$u27$": "'", "..": "::"}


def short(name: str) -> str:
    """Legacy-mangled DWARF names unescaped, generic arguments dropped."""
    name = re.sub(r"::h[0-9a-f]{16}$", "", name)
    for k, v in ESCAPES.items():
        name = name.replace(k, v)
    # "_<impl kernel::kernel::Kernel<S>>::check" -> "kernel::kernel::Kernel<S>::check";
    # "<f32 as kernel::scalar::Scalar>::min" -> "kernel::scalar::Scalar[f32]::min".
    name = re.sub(r"_?<impl ((?:[^<>]|<[^<>]*(?:<[^<>]*>)?[^<>]*>)*)>", r"\1", name)
    name = re.sub(r"<([^<>\s]+) as ((?:[^<>]|<[^<>]*>)*)>", r"\2[\1]", name)
    # Drop generic arguments (nested <...>), keep the path.
    out, depth = [], 0
    for ch in name:
        if ch == "<":
            depth += 1
            if depth == 1 and out and out[-1] != ":":
                continue
            continue
        if ch == ">":
            depth -= 1
            continue
        if depth == 0:
            out.append(ch)
    s = "".join(out)
    return re.sub(r"^_+", "", s).replace(" as ", "::") or name


# The kernel's steps, in the order of the tick (`kernel/src/kernel.rs`), with
# what each one is.
STEPS = {
    "sense_and_estimate": "sense and estimate (unwrap, plausibility, observer)",
    "boot": "leaving Boot",
    "intake": "request intake (validation, continuity, timing)",
    "retarget": "accepting a target (`Interpolator::retarget`)",
    "retarget_from": "accepting a target (`Interpolator::retarget_from`)",
    "stop_point": "stopping point at acceptance (`Interpolator::stop_point`)",
    "supervise": "supervisor (mode, timeout; the rest of `supervise`)",
    "motion": "outputs of every mode, kept by mode (acceleration clamp; the rest of `Kernel::motion`)",
    "stop_output": "soft-stop output (`ramp::stop_output`, every mode)",
    "home_step": "homing sequencer",
    "advance": "set-point generator (`Interpolator::advance`, braking tests)",
    "control": "set-point step and control law (the rest of `Axis::control`)",
    "control_law": "control law",
    "following": "following-error check",
    "check": "supervisor checks (runaway, limits, outputs)",
    "latch": "fault latch",
}


def steps(elf: str, prof: str, samples: int) -> int:
    counts = {}
    with open(prof) as f:
        for line in f:
            a, c = line.split()
            counts[int(a, 16)] = int(c)
    if not counts:
        print("(no instructions in the region)")
        return 1
    addrs = sorted(counts)
    q = "".join(f"0x{a:x}\n" for a in addrs)
    res = subprocess.run(["llvm-symbolizer", "--obj", elf, "--inlining", "--demangle"],
                         input=q, capture_output=True, text=True, check=True).stdout
    blocks = res.strip("\n").split("\n\n")
    per = collections.Counter()
    for a, b in zip(addrs, blocks):
        names = [short(n).split("::")[-1] for n in b.splitlines()[0::2]]
        step = next((n for n in names if n in STEPS), None)
        per[STEPS[step] if step else "(the rest: tick entry, loops, event buffer)"] += counts[a]
    total = sum(counts.values())
    print(f"{total / samples:.0f} instructions per call over {samples} calls (innermost kernel step):")
    print()
    print("| step (innermost named step an instruction was inlined into) | instructions per call | share |")
    print("|---|---:|---:|")
    for name, c in per.most_common():
        print(f"| {name} | {c / samples:.0f} | {100 * c / total:.1f} % |")
    return 0


def main() -> int:
    if sys.argv[1] == "--steps":
        return steps(sys.argv[2], sys.argv[3], int(sys.argv[4]))
    elf, prof, samples = sys.argv[1], sys.argv[2], int(sys.argv[3])
    top = int(sys.argv[4]) if len(sys.argv) > 4 else 25
    counts = {}
    with open(prof) as f:
        for line in f:
            a, c = line.split()
            counts[int(a, 16)] = int(c)
    if not counts:
        print("(no instructions in the region)")
        return 1
    addrs = sorted(counts)
    q = "".join(f"0x{a:x}\n" for a in addrs)
    res = subprocess.run(["llvm-symbolizer", "--obj", elf, "--inlining", "--demangle"],
                         input=q, capture_output=True, text=True, check=True).stdout
    blocks = res.strip("\n").split("\n\n")
    if len(blocks) != len(addrs):
        print(f"symbolizer returned {len(blocks)} entries for {len(addrs)} addresses", file=sys.stderr)
        return 1
    per_fn = collections.Counter()
    for a, b in zip(addrs, blocks):
        lines = b.splitlines()
        inner = short(lines[0]) if lines else "?"
        per_fn[inner] += counts[a]
    total = sum(counts.values())
    print(f"{total / samples:.0f} instructions per call over {samples} calls (innermost inlined function):")
    print()
    print("| function (innermost, inlined or not) | instructions per call | share |")
    print("|---|---:|---:|")
    rest = 0
    for i, (fn, c) in enumerate(per_fn.most_common()):
        if i < top:
            print(f"| `{fn}` | {c / samples:.0f} | {100 * c / total:.1f} % |")
        else:
            rest += c
    if rest:
        print(f"| (the other {len(per_fn) - top} functions) | {rest / samples:.0f} | {100 * rest / total:.1f} % |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
