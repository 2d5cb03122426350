#!/usr/bin/env bash
# Regenerates docs/BENCHMARKS.md: instructions executed per kernel
# tick and per parsed driver frame on the emulated Cortex-M7, counted by the
# project's QEMU TCG plugin (emu/plugin/count.c), plus code size, RAM, stack,
# and the host criterion figures. Slow (several minutes); not part of the
# test command (that is emu/test.sh).
#
# Usage: emu/bench.sh            (writes docs/BENCHMARKS.md)
# Env:   EMU_TARGET_DIR          cargo target dir (default /work/target-emu)
#        EMU_SKIP_CRITERION=1    skip the host criterion run
set -euo pipefail
EMU="$(cd "$(dirname "$0")" && pwd)"
ROOT="$(cd "$EMU/.." && pwd)"
cd "$EMU"
export CARGO_TARGET_DIR="${EMU_TARGET_DIR:-/work/target-emu}"
OUT="$CARGO_TARGET_DIR/bench-out"
mkdir -p "$OUT"
DOC="$ROOT/docs/BENCHMARKS.md"

SUDO=""
[ "$(id -u)" = 0 ] || SUDO="sudo"
need=()
command -v qemu-system-arm >/dev/null || need+=(qemu-system-arm)
command -v gcc >/dev/null || need+=(gcc libc6-dev)
command -v llvm-objdump >/dev/null || need+=(llvm)
if [ ${#need[@]} -gt 0 ]; then
    $SUDO apt-get update -qq >/dev/null || true
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${need[@]}" >/dev/null
fi
rustup target add thumbv7em-none-eabihf >/dev/null 2>&1 || true

echo "==> plugin"
gcc -O2 -Wall -Wextra -Werror -std=gnu11 -shared -fPIC -fvisibility=hidden \
    -o "$OUT/libcount.so" "$EMU/plugin/count.c"

echo "==> host tool"
cargo build --release --locked -q -p emu-host
HOST="$CARGO_TARGET_DIR/release/emu-host"

declare -A TABLE STDERR SIZES PROFILE STEPS
for flavor in cm7 generic; do
    case $flavor in
        generic) flags="" ;;
        cm7) flags="-C target-cpu=cortex-m7" ;;
    esac
    echo "==> target ($flavor)"
    tdir="$CARGO_TARGET_DIR/$flavor"
    CARGO_TARGET_DIR="$tdir" CARGO_TARGET_THUMBV7EM_NONE_EABIHF_RUSTFLAGS="$flags" \
        cargo build --release --locked -q -p emu-target --target thumbv7em-none-eabihf
    elf="$tdir/thumbv7em-none-eabihf/release/emu-target"
    args=""
    for c in cal tick_f32 parse_f32 tick_fx parse_fx; do
        s=$(llvm-nm "$elf" | awk -v n="emu_${c}_start" '$3==n{print $1}')
        t=$(llvm-nm "$elf" | awk -v n="emu_${c}_stop" '$3==n{print $1}')
        args="$args,mark=$c:$s:$t"
    done
    qemu-system-arm -machine mps2-an500 -cpu cortex-m7 -nographic -monitor none -serial none \
        -semihosting-config enable=on,target=native \
        -plugin "$OUT/libcount.so,out=$OUT/counts_$flavor.txt$args" -d plugin \
        -kernel "$elf" >"$OUT/trace_$flavor.txt" 2>"$OUT/stderr_$flavor.txt"
    if [ $flavor = generic ]; then
        # Per-function profile of the streamed trajectory's ticks.
        read -r from to < <("$HOST" stream-range "$EMU/data")
        for var in f32 fx; do
            qemu-system-arm -machine mps2-an500 -cpu cortex-m7 -nographic -monitor none -serial none \
                -semihosting-config enable=on,target=native \
                -plugin "$OUT/libcount.so,out=$OUT/counts_prof.txt,prof=$OUT/prof_$var.txt:tick_$var:$from:$to$args" \
                -d plugin -kernel "$elf" >/dev/null 2>&1
            PROFILE[$var]="$(python3 "$EMU/tools/profile.py" "$elf" "$OUT/prof_$var.txt" $((to - from)) 25)"
            STEPS[$var]="$(python3 "$EMU/tools/profile.py" --steps "$elf" "$OUT/prof_$var.txt" $((to - from)))"
        done
    fi
    "$HOST" replay "$EMU/data" >"$OUT/host_trace.txt"
    if cmp -s "$OUT/host_trace.txt" "$OUT/trace_$flavor.txt"; then
        eq="bit-identical to the host"
    else
        eq="DIFFERENT from the host"
    fi
    TABLE[$flavor]="$("$HOST" analyze "$EMU/data" "$OUT/counts_$flavor.txt")"
    STDERR[$flavor]="$(cat "$OUT/stderr_$flavor.txt")
trace: $eq"
    # Code size of the out-of-line tick of each variant (the kernel inlined
    # into it) and of the parsers; the f32 one is the one with VFP arithmetic.
    sizes=""
    while read -r addr size name; do
        a=$((16#$addr)); n=$((16#$size))
        fp=$(llvm-objdump --mcpu=cortex-m7 -d --no-show-raw-insn --start-address=$a --stop-address=$((a + n)) "$elf" |
            grep -cE '\sv(add|sub|mul|div)\.f32' || true)
        kind=$([ "$fp" -gt 0 ] && echo f32 || echo fx)
        sizes="$sizes| \`emu_common::tick\` ($kind: Kernel::tick_into inlined) | $n |
"
    done < <(llvm-nm -S -C "$elf" | awk '$4 ~ /^emu_common::tick::/ {print $1, $2, $4}')
    SIZES[$flavor]="$sizes"
    llvm-size -A "$elf" >"$OUT/size_$flavor.txt"
done

crit="(skipped: EMU_SKIP_CRITERION=1)"
if [ "${EMU_SKIP_CRITERION:-0}" != 1 ]; then
    echo "==> host criterion (protocol/benches/parse.rs, emu/host/benches/tick.rs)"
    (cd "$ROOT" && CARGO_TARGET_DIR="$CARGO_TARGET_DIR/root" cargo bench --locked -q -p protocol --bench parse -- \
        --warm-up-time 1 --measurement-time 3 --noplot 2>/dev/null) >"$OUT/criterion_parse.txt" || true
    cargo bench --locked -q -p emu-host --bench tick -- --warm-up-time 1 --measurement-time 3 --noplot \
        >"$OUT/criterion_tick.txt" 2>/dev/null || true
    # Criterion's comparison with a previous run in the same directory (a
    # percentage change) says nothing about this revision: left out.
    crit="$(cat "$OUT/criterion_parse.txt" "$OUT/criterion_tick.txt" | grep -E 'time:|thrpt:|^[a-z_]+/[a-z0-9_]+ *$' |
        grep -v '%' | sed 's/^/    /' || true)"
    [ -n "$crit" ] || crit="(criterion produced no figures; see $OUT/criterion_*.txt)"
fi

# The image as flashed, the whole tick interrupt on the twin, the
# simulator's speed.
echo "==> release image (firmware/build.sh: the USB build as flashed)"
(cd "$ROOT" && SKIP_REPRO=1 firmware/build.sh) >"$OUT/firmware_build.txt" 2>&1 || true
IMAGE_TXT="$(sed -n '/^== memory use/,/^panic-path/p' "$OUT/firmware_build.txt")"
[ -n "$IMAGE_TXT" ] || IMAGE_TXT="(firmware/build.sh failed; see $OUT/firmware_build.txt)"
IMAGE_BYTES=$(grep -oE 'flash image \(loadable bytes\): [0-9]+' "$OUT/firmware_build.txt" | grep -oE '[0-9]+$' || echo "?")
TICK_STACK=$(grep -oE 'worst-case tick stack[^:]*: [0-9]+ bytes \+ [0-9]+ exception frame = [0-9]+' "$OUT/firmware_build.txt" | grep -oE '[0-9]+$' || echo "?")

TWIN_LINE="(skipped: EMU_SKIP_TWIN=1)"
if [ "${EMU_SKIP_TWIN:-0}" != 1 ]; then
    echo "==> whole tick interrupt on the register-level twin (twin/build-image.sh, twin run)"
    # The twin is its own workspace with its own target directory (the
    # binary run below), not this script's CARGO_TARGET_DIR.
    (cd "$ROOT" && twin/build-image.sh && cd twin && env -u CARGO_TARGET_DIR cargo build --release --locked -q &&
        ./target/release/twin run "$ROOT/sim/scenarios/configurator-jog-25hz.scn") >"$OUT/twin_run.txt" 2>&1 || true
    TWIN_LINE="$(sed -n '/^PIT handler (/,/^simulated/p' "$OUT/twin_run.txt" | grep -v '^simulated' || true)"
    [ -n "$TWIN_LINE" ] || TWIN_LINE="(twin run failed; see $OUT/twin_run.txt)"
fi

echo "==> simulator speed (sim: the built-in scenarios, one after another)"
(cd "$ROOT" && cargo run --release --locked -q -p sim -- --out "$OUT/sim-report") >"$OUT/sim_run.txt" 2>&1 || true
SIM_SPEED=$(grep -oE '\(([0-9.]+) s simulated in ([0-9.]+) s\)' "$OUT/sim_run.txt" |
    awk '{gsub(/[()]/, ""); sim += $1; wall += $5} END { if (wall > 0) printf("%.0f x real time (%.1f s simulated in %.2f s, reports written)", sim / wall, sim, wall); else print "?" }')

host_cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//')
{
cat <<EOF
# Benchmarks: the kernel tick and the parser on a Cortex-M7 (emulated)

Generated by \`emu/bench.sh\` on $(date -u +%Y-%m-%d) (UTC). Do not edit by hand.

- Toolchain: $(rustc --version) (pinned), target \`thumbv7em-none-eabihf\`, release profile
  (opt-level 3, fat LTO, codegen-units 1, panic abort), as the root workspace's.
- Emulator: $(qemu-system-arm --version | head -1), \`-machine mps2-an500 -cpu cortex-m7\`.
- Counter: the project's TCG plugin \`emu/plugin/count.c\`, $(gcc --version | head -1), built against the
  project's own declarations \`emu/plugin/qemu_plugin_min.h\` (plugin API version 1): Debian bookworm's
  QEMU 7.2 packages (qemu-system-arm, qemu-system-common, qemu-system-data) ship no \`qemu-plugin.h\`
  and Debian has no QEMU development package, so no upstream header is used.
- Workload: the recorded scenario \`emu/data/scenario_{f32,fx}.bin\` (boot, a refused
  motion frame, HOME with the real PAROL6 configuration until every joint is homed, a 1.5 s streamed
  trajectory on all six joints with one lost encoder sample and one malformed frame, the command-timeout
  soft stop, ENABLE, a held position, a hardware fault, ENABLE, idle), replayed open-loop.
- Host: ${host_cpu:-unknown CPU}, 2 cores (criterion figures only).

## Equivalence (checked by \`emu/test.sh\`, the project's test command)

The trace of every tick (state, homing status, limit and homed masks, timeout flag, tick count, the
six velocity commands and step rates, estimated positions and velocities, set-points, latched fault,
events, and for each host line the parser's result with the parsed target's bits) is printed with every
number as its bit pattern. Host (x86-64) and emulated Cortex-M7 traces are **byte-identical** for both
variants and both builds below. Fixed point (I8F24) is integer arithmetic and identical by construction;
this confirms it. **f32 is identical too, and is expected to be**: Rust never contracts \`a * b + c\`
into a fused multiply-add (no fast-math; LLVM fuses only for \`mul_add\` or \`contract\` flags, which
rustc does not emit); the target code has no \`vfma\`/\`vfms\`/\`vfnma\`/\`vfnms\` (test.sh checks the
disassembly) and uses \`vmla.f32\`, whose product is rounded before the addition (the chained, not
fused, VFP multiply-accumulate: the same result as separate IEEE operations); the FPU runs with the
reset FPSCR (round to nearest, no flush-to-zero, no default NaN) and the host uses SSE (no x87 extended
precision); \`as\` conversions saturate on both; a decimal number is converted with integer arithmetic
and, for f32, one IEEE division of two exact operands (\`Scalar::from_decimal\`) on both.
The kernel's \`f32\` minimum and maximum are written out as a compare and a select (IEEE minNum / maxNum,
\`self\` on ties, \`kernel/src/scalar.rs\`), not \`f32::min\`/\`max\`, so they are the same on every target,
the sign of \`min(+0.0, -0.0)\` included (Rust leaves that unspecified for \`f32::min\`).

## What is counted, and what is not

Instructions **executed** (not cycles) between two marker functions around each call, counted by QEMU
for every guest instruction; the constant marker overhead, measured on an empty region, is subtracted.
"Full six-axis tick" is one call of \`Kernel::tick_into\` (through the out-of-line wrapper
\`emu_common::tick\`; the firmware's call: outputs and events into caller-owned storage, the status
built only when telemetry is due, outside this region): sense, estimate, one request, supervise, act,
for all six axes. "Parse" is one
\`Parser::parse\` of one complete line (without the framer, sequence filter or queues).

**Estimate, not a measurement**: microseconds below are instructions / 600 MHz, i.e. assuming one
instruction per cycle on the i.MX RT1062's Cortex-M7 at 600 MHz. The real core can dual-issue (faster),
while \`vdiv.f32\` (14 cycles), 64-bit/128-bit multiply helpers, branch mispredictions and memory wait
states (code not in ITCM, data not in DTCM, cache misses) make it slower. Only a cycle counter (DWT
CYCCNT) on the real board gives cycles; these counts show the *work* and how constant it is.

EOF
for flavor in cm7 generic; do
    if [ $flavor = cm7 ]; then
        echo "## Build \`-C target-cpu=cortex-m7\` (FPv5-D16, as on the i.MX RT1062)"
    else
        echo "## Build generic \`thumbv7em-none-eabihf\` (no target-cpu: FPv4-SP, software fminf/fmaxf and f64)"
    fi
    echo
    echo "${TABLE[$flavor]}"
    echo
    echo "Estimated time at 600 MHz, one instruction per cycle (**estimate**):"
    echo
    echo "${TABLE[$flavor]}" | awk -F'|' '/^\| (full six-axis tick, whole scenario|parse one accepted driver motion frame) \|/ {
        gsub(/ /, "", $3); printf("- %s, %s: min %.1f us, median %.1f us, max %.1f us\n", $2, $3, $5/600, $6/600, $7/600) }' | sed 's/^- */- /; s/ ,/,/'
    echo
    echo "Code size (bytes):"
    echo
    echo "| function | bytes |"
    echo "|---|---:|"
    echo -n "${SIZES[$flavor]}"
    echo
    echo "(\`Parser::parse\` is inlined into the replay loop by LTO, so it has no separate size here.)"
    echo
    echo "Target program output (stderr; FPU, RAM, stack) and equivalence:"
    echo
    echo '```text'
    echo "${STDERR[$flavor]}"
    echo '```'
    echo
done
cat <<EOF
Notes on the figures:

- *RAM*: the kernel's whole state is \`size_of::<Kernel<S>>()\` above (static, no heap).
- *Stack*: "deepest use below the caller's stack pointer" is measured per tick by painting 8 KiB below
  the stack pointer before every tick and finding the lowest overwritten word after it, over every
  tick of the scenario: the tick's own frame and everything it calls (the outputs and events live in
  the caller's frame). It is measured over this scenario, not a static bound.
  "Whole program" includes the test program's 8 KiB output buffer and \`core::fmt\`.
- *Flash* of the test program (\`llvm-size -A\`, cm7 build) is dominated by the two embedded scenarios
  (~213 KB of .rodata) and \`core::fmt\`; the kernel's share is the code size of the tick above.

\`\`\`text
$(grep -E '^(section|\.vector_table|\.text|\.rodata|\.data|\.bss|\.uninit|Total)' "$OUT/size_cm7.txt")
\`\`\`

## Where the tick's instructions go (shipped build, the streamed trajectory)

Every instruction executed inside the measured tick during the streamed trajectory (ticks
\`emu-host stream-range\`), attributed to the innermost function it was inlined from (\`emu/plugin/count.c\` \`prof=\`, \`emu/tools/profile.py\`: QEMU's per-block counts
and the ELF's debug information); \`Scalar[f32]::min\` is the scalar's own minimum, wherever it
was inlined.

By the kernel's steps (\`emu/tools/profile.py --steps\`: every instruction counted for the innermost
named step it was inlined into, so a minimum inside the set-point generator counts for the
generator), f32:

$(echo "${STEPS[f32]}")

fixed point (I8F24):

$(echo "${STEPS[fx]}")

By the innermost function, f32:

$(echo "${PROFILE[f32]}")

fixed point (I8F24):

$(echo "${PROFILE[fx]}")

## The figures against their goals (this project's column)

The shipped image is the **generic** build (FPv4-SP: no \`vsel\`, \`vminnm\`/\`vmaxnm\` or hardware
f64); the cm7 build is what an FPv5 build would run. The whole-scenario rows include homing and
idle ticks; the streamed rows are the ticks "while following a stream".

| figure | generic (shipped) | cm7 | C++ -O2 (quoted) | goal |
|---|---:|---:|---:|---:|
$(for f in generic cm7; do echo "${TABLE[$f]}"; done | awk -F'|' '
  /^\| full six-axis tick, whole scenario \| f32/ { n++; mn[n]=$5; md[n]=$6; mx[n]=$7; r[n]=$8 }
  /^\| full six-axis tick, whole scenario \| fx/ { m++; fmn[m]=$5; fmd[m]=$6; fmx[m]=$7 }
  /^\| tick while following the stream[^|]*\| f32/ { t++; tmn[t]=$5; tmd[t]=$6; tmx[t]=$7 }
  /^\| tick while following the stream[^|]*\| fx/ { u++; umn[u]=$5; umd[u]=$6; umx[u]=$7 }
  /^\| f32 \| [0-9]+ \| [0-9]+\.\.[0-9]+ \|/ { p++; pb[p]=$6 }
  /^\| fx \| [0-9]+ \| [0-9]+\.\.[0-9]+ \|/ { q++; qb[q]=$6 }
  END {
    printf("| instructions per six-axis tick while following a 100 Hz stream, f32, min / median / max | %s / %s / %s | %s / %s / %s | 1410 / 1488 / 1512 | median <= 1,488, max <= 1,512 |\n", tmn[1], tmd[1], tmx[1], tmn[2], tmd[2], tmx[2]);
    printf("| the same, fixed point (I8F24), min / median / max | %s / %s / %s | %s / %s / %s | - | - |\n", umn[1], umd[1], umx[1], umn[2], umd[2], umx[2]);
    printf("| fixed point / f32, streamed tick, median; max | %.2f; %.2f | %.2f; %.2f | - | <= 1.2 |\n", umd[1] / tmd[1], umx[1] / tmx[1], umd[2] / tmd[2], umx[2] / tmx[2]);
    printf("| instructions per six-axis tick, whole scenario, f32, min / median / max | %s / %s / %s | %s / %s / %s | 1410 / 1476 / 1612 | - |\n", mn[1], md[1], mx[1], mn[2], md[2], mx[2]);
    printf("| max / min over the whole scenario, f32 | %s | %s | 1.14 | <= 1.15 |\n", r[1], r[2]);
    printf("| the same tick, fixed point, min / median / max | %s / %s / %s | %s / %s / %s | - | - |\n", fmn[1], fmd[1], fmx[1], fmn[2], fmd[2], fmx[2]);
    printf("| parse, instructions per byte of an accepted driver frame, f32 / fixed point | %s / %s | %s / %s | 56.5 | <= 17.6 / <= 19.5 |\n", pb[1], qb[1], pb[2], qb[2]);
  }' | sed 's/  */ /g')
| release image (flash bytes, USB build) | $IMAGE_BYTES | - | - | <= 65,536 |
| worst tick stack (bytes, static bound incl. the 104-byte exception frame) | $TICK_STACK | - | - | <= 512 |
| simulator, x real time (built-in scenarios) | $SIM_SPEED | - | - | >= 1,000 |

**C++ column: quoted, not re-measured by this script** (\`arm-none-eabi-g++\` and the C++ source are
not part of this repository). It is the tick interrupt of the C++ firmware this project replaces, its
own source compiled unchanged with \`arm-none-eabi-g++ -O2 -mcpu=cortex-m7 -mfpu=fpv5-d16
-mfloat-abi=hard\`, every safety feature on, counted by the same plugin (\`emu/plugin/count.c\`) on
the same emulated machine (QEMU \`mps2-an500\`, \`-cpu cortex-m7\`), with its encoder reads scripted
(the closest match to this tick, which also receives decoded counts), through a 100 Hz stream, a
command-timeout stop, an enable and a hold. Its host parser took 700-727 ns per driver frame on
the same 10,000 frames (this project's: the criterion figures below). The C++ tick does less than
this one: no acceleration-limited set-point, following error, position limits or plausibility
window, and it applies commands in its main loop, not in the tick.

The whole tick interrupt on the register-level twin (the Serial1 release image, every PIT handler
call of \`twin run sim/scenarios/configurator-jog-25hz.scn\`: encoder capture and decode, limit
debounce, the kernel tick, step conversion and programming, telemetry push, watchdog; one
instruction counted as one cycle, per translated block):

\`\`\`text
$TWIN_LINE
\`\`\`

## Goals not met: the figures and the reasons

**The streamed tick at or below the C++ one (median <= 1,488, max <= 1,512): not met** (the first
row). The per-step profile above explains it: sense and estimate, the supervisor's checks, the
following-error check and the control law, which every tick runs and the C++ tick does not have,
cost together about as much as the whole C++ tick before any set-point is generated; the set-point
generator (\`Interpolator::advance\`) is the largest single step. It tests up to three candidate
speeds (accelerate, cruise, decelerate: the fastest from which the set-point can still stop at its
target) with the braking test, and tests the chosen one once more with the rounding allowance (may
the step be clamped to the target?); its clamps are IEEE minNum / maxNum, a compare, a NaN test and
a select each on FPv4-SP (about 8 instructions), because the clamps rely on a NaN operand being
ignored (clamps whose bounds are always ordered skip \`clamp_between\`'s reordering). Skipping the
later braking tests once a candidate passes keeps every value, but the SMT step's proof of the
set-point guarantee's one-tick lemma takes several times longer on that form, so the generator
runs every test. One braking evaluation per tick
needs the fastest admissible speed in closed form (a square root: \`vsqrt.f32\` in f32, none in
I8F24) or one candidate fewer; both change the set-point profile's values, which the SMT lemma,
the Kani harnesses, the exhaustive slice, the model check and the recorded traces then have to
follow. The maximum is the tick that accepts a stream sample: the intake's validation and
continuity check, the stopping point and \`retarget\` for six joints on top of a streamed tick.

**Whole-scenario max/min <= 1.15: not met** (the fifth row; per state: "Tick cost by the state the
tick ends in" above). The tick computes the Operational path in every mode: every axis's set-point
step, control law, acceleration clamp and following-error check run on every tick and the mode
selects what is kept (\`Kernel::motion\`, \`Kernel::following\`; \`core::hint::black_box\` keeps the
compiler from moving the work under the conditions that keep it), so Boot, Unhomed, SoftEstop and
Fault ticks cost about what an Operational one costs in f32 (in fixed point the braking
tests' branches make the Operational tick vary more). What remains: homing adds its sequencer, the
soft stop its ramp (\`ramp::stop_output\`), and the tick that accepts a target the intake
(validation, continuity, stopping points and \`retarget\` for six joints): the maximum. Running the
intake's arithmetic on every tick as well (on the current targets, not kept) would raise every
other tick toward that maximum, at the cost of the intake's work on every tick and a tick stack
further above its goal (the intake's copy of a target and its per-axis results), so it is not done.
What the 1 kHz deadline needs is a bounded maximum: the whole tick interrupt on the twin (above) at
its maximum, divided by 600 MHz at one instruction per cycle (an estimate), is a small fraction of
the 1 ms period, and a tick that overruns latches \`TickOverrun\` (SR-21 in SAFETY.md).

**Tick stack of at most 512 bytes: not met** (the figure above: the static bound of the tick
interrupt's call chain, \`firmware/build.sh\`):

\`\`\`text
$(grep -E '^handler PIT:' "$OUT/firmware_build.txt" || echo "(no handler line; see $OUT/firmware_build.txt)")
\`\`\`

Most of it is the frame of \`Controller::kernel_step\`, into which the whole kernel tick is inlined:
the request (a motion target of twelve scalars), the six outputs and the events, and the spills of
the inlined per-axis steps.

**Release image of at most 64 KiB: not met** (the figure above; where the bytes go: the per-crate
table below). Fixed or nearly fixed parts: the Teensy boot header (\`.boot\`, 8 KiB), the USB device
stack (\`usb_device\`, \`imxrt_usbd\`, \`usbd_serial\`: about 8 KiB), the protocol's parsers and report
formatting for both dialects (about 20 KiB; about 10 KiB at opt-level "z"), the tick at opt-level 3 (the kernel's
tick inlined into \`firmware\`'s \`Controller::kernel_step\`, about 13 KiB, most of that crate's share),
and \`compiler_builtins\` (about 7 KiB: soft f64 for the parameters the kernel derives at boot,
\`memcpy\`). Alternatives measured by hand (not by this script): \`-C target-cpu=cortex-m7\`
(FPv5, hardware f64) gives a *larger* image (111,992 B against 107,520 B on the same source: more
unrolling at opt-level 3, though \`compiler_builtins\` shrinks from 6.9 to 4.2 KiB); opt-level "z"
for the crates outside the tick (\`firmware/build.sh\` \`IMAGE_SIZE_OPT=1\`) saves about a tenth
(96,572 B against 107,160 B) but moves the boot timing enough for the twin to mis-read a 9.5 %-fast
encoder, so it is off. Below 64 KiB would need dropping functions (one of the two protocol dialects'
formatting, the USB CDC port in favour of Serial1 only), which the drop-in requirement rules out.

**Fuzzing to 10^8 executions**: see docs/FUZZING.md (the long run and the nightly job).

## The release image (\`firmware/build.sh\`)

\`\`\`text
$IMAGE_TXT
\`\`\`

## Host criterion figures (for comparison; x86-64 host, not the target)

\`\`\`text
$crit
\`\`\`
EOF
} >"$DOC"
echo "wrote $DOC"
