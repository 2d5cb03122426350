#!/usr/bin/env bash
# Build the PAROL6 Teensy 4.1 image and check it.
#
#   firmware/build.sh            # release image + sizes + tick stack + panic check + main-stack bound + reproducibility
#   FEATURES=serial1 firmware/build.sh   # protocol on Serial1 (pins 0/1) instead of USB CDC
#   SKIP_REPRO=1 firmware/build.sh       # skip the determinism check (re-links, second directory; 0, the default, runs it)
#   REPRO_RELINKS=10 firmware/build.sh   # re-link the image 10 times instead of 5
#   SKIP_STACK=1 firmware/build.sh       # skip the nightly stack-size build (second image of one test run)
#
# Writes target/firmware/parol6.elf and parol6.hex (Intel HEX for
# `teensy_loader_cli --mcu=TEENSY41`). Exits non-zero if the build fails, if
# a panic path is reachable from the tick handler, if the ELF names a path of
# this machine, or if any re-link or the build in a second directory gives a
# different .elf or .hex.
set -euo pipefail
# The switches are 0 (the default) or 1; anything else is a usage error
# before anything is built (SKIP_REPRO=0 must not skip the check).
case "${SKIP_REPRO:-0}" in 0 | 1) ;; *) echo "build.sh: SKIP_REPRO must be 0 or 1, not '$SKIP_REPRO'" >&2; exit 2 ;; esac
case "${SKIP_STACK:-0}" in 0 | 1) ;; *) echo "build.sh: SKIP_STACK must be 0 or 1, not '$SKIP_STACK'" >&2; exit 2 ;; esac
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
cd "$ROOT"
TARGET=thumbv7em-none-eabihf
OUT="$ROOT/target/firmware"
FEATURES="${FEATURES:-}"
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$ROOT/target/fw-build}"
# defmt compiles out every log statement below DEFMT_LOG, and nothing at all
# when it is unset (twin defect 7, twin/README.md: with it unset `.defmt`
# is 3 bytes and the log port prints nothing). `info` keeps the image's one
# info statement, the boot line; the check after the build fails if no info
# statement made it in.
export DEFMT_LOG="${DEFMT_LOG:-info}"
mkdir -p "$OUT"

# --- tools (fresh machine): the pinned toolchain, its thumb target, llvm-tools;
# nightly + thumb target for the stack-size build (optional).
TC="$(sed -n 's/^channel *= *"\(.*\)"/\1/p' rust-toolchain.toml)"
rustup toolchain install "$TC" --profile minimal >/dev/null 2>&1 || true
rustup target add --toolchain "$TC" "$TARGET" >/dev/null
rustup component add --toolchain "$TC" llvm-tools >/dev/null
HOST="$(rustc +"$TC" -vV | sed -n 's/^host: //p')"
BIN="$(rustc +"$TC" --print sysroot)/lib/rustlib/$HOST/bin"
OBJCOPY="$BIN/llvm-objcopy"; SIZE="$BIN/llvm-size"; OBJDUMP="$BIN/llvm-objdump"
HAVE_NIGHTLY=0
NIGHTLY=""
# The nightly is the project's pinned one (ci/nightly.sh), so the stack
# figures come from the same compiler on every machine.
# shellcheck source=ci/nightly.sh
if . "$ROOT/ci/nightly.sh" >/dev/null 2>&1; then
  rustup target add --toolchain "$NIGHTLY" "$TARGET" >/dev/null 2>&1 && HAVE_NIGHTLY=1
fi

# Image-only profile settings (image size): code that runs only in
# the main loop or at boot -- the USB stack and every other dependency from
# outside the workspace, and the protocol crate's line formatting -- is
# optimised for size; the crates the tick's code is generated in (firmware:
# the PIT handler, the root and the kernel's monomorphised tick; hal-imxrt:
# encoder decode, capture, step conversion; kernel) stay at the release
# profile's opt-level 3. Passed on the command line, not in Cargo.toml, so the
# host's release builds (the simulator) are unchanged.
#
# OFF by default (IMAGE_SIZE_OPT=1 turns it on). It moves the boot timing
# (slower code before the first tick), which once decided whether a
# 9.5 %-fast MT6816 on the twin was mis-read before its decoder knew the
# frame period; that no longer depends on timing: the decoder reports no
# count it cannot trust before the period is known and the root calibrates
# every encoder's period at boot (hal_imxrt::pure::frame,
# firmware::root::CALIBRATION_MS; twin/tests/defects.rs defect6 at eight
# boot phases). It stays off until an image built with it is reproducible
# across build directories (the check below).
IMAGE_PROFILE=()
if [ "${IMAGE_SIZE_OPT:-0}" = 1 ]; then
  IMAGE_PROFILE=(--config 'profile.release.package."*".opt-level="z"'
                 --config 'profile.release.package.protocol.opt-level="z"')
fi

# Paths of this machine that the compiler would otherwise write into the
# ELF's debug information (the .hex has none): the workspace, the cargo home
# (every registry crate's sources, 71 paths) and the toolchain (its std
# sources are already /rustc/<commit>/ in the shipped rlibs; remapped in case
# a build uses rust-src). The release image then is the same file on any
# machine with the pinned toolchain, whoever builds it and wherever.
SYSROOT="$(rustc +"$TC" --print sysroot)"
CARGO_HOME_DIR="$(cd "${CARGO_HOME:-$HOME/.cargo}" && pwd -P)"
build() { # $1 = workspace root, $2 = target dir
  # CARGO_ENCODED_RUSTFLAGS (0x1f-separated): a path with a space stays one flag.
  local sep=$'\x1f'
  (cd "$1" && CARGO_TARGET_DIR="$2" \
     CARGO_ENCODED_RUSTFLAGS="--remap-path-prefix=$1=/parol6$sep--remap-path-prefix=$CARGO_HOME_DIR=/cargo$sep--remap-path-prefix=$SYSROOT=/rust" \
     cargo +"$TC" build --locked --release "${IMAGE_PROFILE[@]}" -p firmware --bin parol6 --target "$TARGET" \
       ${FEATURES:+--features "$FEATURES"})
  stamp_crc "$2/$TARGET/release/parol6"
}

# --- image CRC stamp (firmware::image): every build's ELF gets the CRC-32
# of its flash image, which the image checks at boot before its tick
# starts. Stamping is deterministic and idempotent (the stamped words are
# zero in the computation), so both builds of the reproducibility check
# are stamped alike.
stamp_crc() { # $1 = ELF, stamped in place
  python3 "$ROOT/firmware/tools/stamp_crc.py" "$1"
}
# --- end of the image CRC stamp

echo "== build (rustc $TC, release, $TARGET${FEATURES:+, features=$FEATURES})"
build "$ROOT" "$CARGO_TARGET_DIR"
ELF="$CARGO_TARGET_DIR/$TARGET/release/parol6"
cp "$ELF" "$OUT/parol6.elf"
"$OBJCOPY" -O ihex "$OUT/parol6.elf" "$OUT/parol6.hex"
echo "wrote $OUT/parol6.elf and $OUT/parol6.hex"

echo "== defmt log compiled in (DEFMT_LOG=$DEFMT_LOG)"
NM="$BIN/llvm-nm"
# defmt places each compiled-in statement's interned string in .defmt between
# the __DEFMT_MARKER_<LEVEL>_START/_END symbols (one byte each).
NLOG="$("$NM" "$OUT/parol6.elf" | python3 -c '
import re, sys
n = 0
for line in sys.stdin:
    m = re.match(r"([0-9a-fA-F]+) \w __DEFMT_MARKER_[A-Z]+_(START|END)$", line.strip())
    if m:
        n += int(m.group(1), 16) * (1 if m.group(2) == "END" else -1)
print(n)')"
DEFMT_BYTES="$("$SIZE" -A -d "$OUT/parol6.elf" | awk '$1 == ".defmt" { print $2 }')"
echo "log statements: ${NLOG:-0}; .defmt: ${DEFMT_BYTES:-0} B"
if [ "${NLOG:-0}" -lt 1 ]; then
  echo "FAIL: no defmt log statement compiled in (DEFMT_LOG=$DEFMT_LOG)"; exit 1
fi

echo "== memory use"
"$SIZE" -A -x "$OUT/parol6.elf" | grep -vE '^\.(debug|comment|ARM\.attributes|stack_sizes|symtab|strtab|shstrtab)' || true
python3 - "$SIZE" "$OUT/parol6.elf" <<'PY'
import subprocess, sys
rows = subprocess.run([sys.argv[1], "-A", "-d", sys.argv[2]], capture_output=True, text=True, check=True).stdout.split("\n")
sec = {}
for r in rows:
    p = r.split()
    if len(p) == 3 and p[0].startswith(".") and p[1].isdigit():
        sec[p[0]] = (int(p[1]), int(p[2]))
def s(n): return sec.get(n, (0, 0))[0]
# teensy4-bsp/imxrt-rt layout: boot header + vectors/text/rodata/data images
# in FlexSPI flash; text copied to ITCM, data/bss/stack/vectors in DTCM.
flash = sum(v[0] for k, v in sec.items() if k in (".boot", ".vector_table", ".text", ".rodata", ".data", ".xip", ".fcb", ".ivt", ".boot_data", ".dcd") or k.startswith(".boot"))
itcm = s(".text")
print(f"flash image (loadable bytes): {flash} of 8126464 (Teensy 4.1 = 8 MiB, 1984 KiB linked)")
print(f"ITCM code: {itcm} B   DTCM: .data {s('.data')} + .bss {s('.bss')} + stack {s('.stack')} + vectors {s('.vector_table')} B")
print(f"OCRAM: .rodata {s('.rodata')} (copied from flash) + .uninit {s('.uninit')} + heap {s('.heap')} (unused) B")
PY

echo "== boot RAM test coverage (firmware/src/target/ram_test.rs)"
# The boot RAM test covers .bss and .data by their linker bounds: every
# writable static must lie in one of them; the one exception is the panic
# marker in .uninit (it must survive a reset). Fails on any other.
RAM_RC=0
"$NM" -S "$OUT/parol6.elf" | python3 -c '
import sys
rows = [l.strip().split(None, 3) for l in sys.stdin]
sym = {r[-1]: int(r[0], 16) for r in rows if len(r) >= 3}
objs = [(int(r[0], 16), int(r[1], 16), r[3]) for r in rows if len(r) == 4 and r[2] in "bBdD" and int(r[1], 16) > 0]
tested = [(sym["__sbss"], sym["__ebss"]), (sym["__sdata"], sym["__edata"])]
uninit = (sym["__suninit"], sym["__euninit"])
bad, n, size = [], 0, 0
for a, sz, name in objs:
    if any(lo <= a and a + sz <= hi for lo, hi in tested):
        n += 1; size += sz
    elif not (uninit[0] <= a and a + sz <= uninit[1] and "PANIC_MARK" in name):
        bad.append(f"{name} at {a:#x}, {sz} B")
(bl, bh), (dl, dh) = tested
print(f"{n} writable statics, {size} B, in .bss {bh - bl} B + .data {dh - dl} B: tested at boot")
for b in bad:
    print(f"FAIL: writable static outside .bss/.data, not covered by the boot RAM test: {b}")
sys.exit(1 if bad else 0)' || RAM_RC=1

echo "== flash bytes by crate (firmware/tools/size_by_crate.py)"
python3 "$ROOT/firmware/tools/size_by_crate.py" "$BIN/llvm-nm" "$OUT/parol6.elf" || echo "(size by crate failed)"

echo "== tick handler: panic paths and stack"
STACK_ELF=""
if [ "${SKIP_STACK:-0}" = 1 ]; then
  echo "(SKIP_STACK: stack not measured)"
elif [ "$HAVE_NIGHTLY" = 1 ]; then
  SDIR="$CARGO_TARGET_DIR/stack-sizes"
  if CARGO_TARGET_DIR="$SDIR" RUSTFLAGS="-Z emit-stack-sizes" \
       cargo +"$NIGHTLY" build --release "${IMAGE_PROFILE[@]}" -p firmware --bin parol6 --target "$TARGET" \
         ${FEATURES:+--features "$FEATURES"} >/dev/null 2>"$OUT/stack-build.log"; then
    STACK_ELF="$SDIR/$TARGET/release/parol6"
  else
    echo "(nightly stack-size build failed; see $OUT/stack-build.log)"
  fi
else
  echo "(no nightly toolchain: stack not measured)"
fi
PANIC_RC=0
python3 "$ROOT/firmware/tools/tick_analysis.py" "$OBJDUMP" "$OUT/parol6.elf" PIT $STACK_ELF || PANIC_RC=$?

echo "== main stack and its guard (firmware/tools/stack_analysis.py)"
# The stack guard (hal_imxrt::pure::mpu) assumes imxrt-rt's layout: the main
# stack is the first 32 KiB of DTCM (__estack = 0x20000000, _stack_start =
# 0x20008000). Checked on the image itself; then the worst-case bound of
# the whole stack (boot, main loop, handlers) against what lies above the
# guard, on the nightly stack-size build.
STACK_RC=0
"$NM" "$OUT/parol6.elf" | python3 -c '
import sys
sym = {p[2]: int(p[0], 16) for p in (l.split() for l in sys.stdin) if len(p) == 3}
lo, hi = sym.get("__estack"), sym.get("_stack_start")
ok = (lo, hi) == (0x20000000, 0x20008000)
print(f"main stack {lo:#x}..{hi:#x}: " + ("as the stack guard assumes" if ok else "FAIL: not the layout the stack guard assumes (0x20000000..0x20008000)"))
sys.exit(0 if ok else 1)' || STACK_RC=1
if [ -n "$STACK_ELF" ]; then
  python3 "$ROOT/firmware/tools/stack_analysis.py" "$OBJDUMP" "$STACK_ELF" || STACK_RC=1
else
  echo "(no stack-size build: main-stack bound not computed)"
fi

echo "== no path of this machine in the ELF"
# (grep -a rather than strings(1): binutils is not needed for the build)
RUSTUP_HOME_DIR="${RUSTUP_HOME:-$HOME/.rustup}"
LEAKS="$(grep -a -o -F -e "$ROOT/" -e "$CARGO_HOME_DIR/" -e "$RUSTUP_HOME_DIR/" -e "$SYSROOT/" "$OUT/parol6.elf" | sort | uniq -c || true)"
PATH_RC=0
if [ -n "$LEAKS" ]; then echo "FAIL: the ELF names paths of this machine:"; echo "$LEAKS"; PATH_RC=1; else echo "none ($ROOT, $CARGO_HOME_DIR, $RUSTUP_HOME_DIR remapped)"; fi

# Determinism. The image must be the same file every time it is built from
# the same sources: re-linked in the same directory (this is where a
# run-to-run difference inside the compiler shows: each re-link recompiles
# the image crate, whose LLVM optimisation and fat LTO then run again), and
# built from scratch in a second directory of another path length under
# another umask. Every .elf and .hex must equal the first build's.
#
# A known cause, and how code avoids it: LLVM 22.1.2 (rustc 1.95.0), fully
# unrolling a loop with two exits -- a `zip` over an array moved into its
# by-value iterator (`cal.iter_mut().zip(snaps)` in a boot calibration of
# the encoder decoders) -- puts the incoming values of a loop-exit phi in
# an order that depends on heap addresses. Address-space randomisation and
# rustc's threads make those differ from run to run, so the image crate's
# code came out in one of two forms (init_root: two store pairs swapped),
# about half the time each. Found with -C save-temps (the image crate's
# unoptimised bitcode is always the same, its optimised bitcode is not) and
# -opt-bisect-limit on that bitcode: the toolchain's own
# `opt -passes='lto-pre-link<O3>'` gives two outputs (one with ASLR off),
# and the first pass whose result varies is loop-unroll-full on that loop.
# No stable rustc flag controls it (codegen-units is already 1, release
# builds are not incremental, the parallel front end and -Z threads are
# nightly-only, and ASLR off is not enough with rustc's threads: 4 and 4 of
# 8 re-links), so such a loop iterates the array by reference
# (`zip(snaps.iter())`: 10 re-links, one image); the repeated re-links
# below are what catch the next one (the by-value form fails them).
REPRO_RC=0
REPRO_RELINKS="${REPRO_RELINKS:-5}"
if [ "${SKIP_REPRO:-0}" = 0 ]; then
  ELF_REF="$(sha256sum <"$OUT/parol6.elf" | cut -c1-64)"
  HEX_REF="$(sha256sum <"$OUT/parol6.hex" | cut -c1-64)"
  echo "reference: elf ${ELF_REF:0:16} hex ${HEX_REF:0:16}"
  same() { # $1 = ELF, $2 = label: compare with the reference build
    local e h
    "$OBJCOPY" -O ihex "$1" "$OUT/parol6.repro.hex"
    e="$(sha256sum <"$1" | cut -c1-64)"; h="$(sha256sum <"$OUT/parol6.repro.hex" | cut -c1-64)"
    if [ "$e" = "$ELF_REF" ] && [ "$h" = "$HEX_REF" ]; then
      echo "$2: elf ${e:0:16} hex ${h:0:16} same"
    else
      echo "$2: elf ${e:0:16} hex ${h:0:16} DIFFERENT"; REPRO_RC=1
    fi
  }
  echo "== determinism: $REPRO_RELINKS re-links in $ROOT"
  for i in $(seq 1 "$REPRO_RELINKS"); do
    touch "$ROOT/firmware/src/main.rs"
    if build "$ROOT" "$CARGO_TARGET_DIR" >/dev/null 2>"$OUT/relink.log"; then
      same "$ELF" "re-link $i"
    else
      echo "re-link $i failed (see $OUT/relink.log)"; REPRO_RC=1; break
    fi
  done
  # the last re-link is what the target dir holds: it must equal $OUT's copy
  echo "== determinism: a build from scratch in another directory, another path length and umask"
  TMP="$(mktemp -d /tmp/parol6-repro.XXXXXX)"
  DIR="$TMP/w"
  while [ "${#DIR}" = "${#ROOT}" ]; do DIR="${DIR}x"; done
  mkdir -p "$DIR"
  if [ "$(umask)" = 0077 ]; then MASK=0022; else MASK=0077; fi
  # (twin/ and emu/ targets: their own builds, hundreds of MB, not part of the image)
  tar -C "$ROOT" --exclude=./target --exclude=./twin/target --exclude=./emu/target --exclude=.git -cf - . \
    | (umask "$MASK" && tar -C "$DIR" --no-same-permissions -xf -)
  if (umask "$MASK" && build "$DIR" "$DIR/target") >/dev/null 2>"$OUT/repro-build.log"; then
    same "$DIR/target/$TARGET/release/parol6" "$DIR (umask $MASK)"
  else
    echo "second build failed (see $OUT/repro-build.log)"; REPRO_RC=1
  fi
  rm -rf "$TMP"
  if [ "$REPRO_RC" = 0 ]; then echo "deterministic: yes (1 + $REPRO_RELINKS re-links + 1 other directory)"; else echo "deterministic: NO"; fi
fi

if [ "$PANIC_RC" != 0 ]; then echo "FAIL: panic path reachable from the tick handler (see above)"; fi
if [ "$STACK_RC" != 0 ]; then echo "FAIL: main stack layout or bound (see above)"; fi
if [ "$RAM_RC" != 0 ]; then echo "FAIL: a writable static the boot RAM test does not cover (see above)"; fi
[ "$PANIC_RC" = 0 ] && [ "$REPRO_RC" = 0 ] && [ "$PATH_RC" = 0 ] && [ "$STACK_RC" = 0 ] && [ "$RAM_RC" = 0 ]
