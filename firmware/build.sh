#!/usr/bin/env bash
# Build the PAROL6 Teensy 4.1 image and check it.
#
#   firmware/build.sh            # release image + sizes + tick stack + panic check + reproducibility
#   FEATURES=serial1 firmware/build.sh   # protocol on Serial1 (pins 0/1) instead of USB CDC
#   SKIP_REPRO=1 firmware/build.sh       # skip the second (reproducibility) build
#
# Writes target/firmware/parol6.elf and parol6.hex (Intel HEX for
# `teensy_loader_cli --mcu=TEENSY41`). Exits non-zero if the build fails, if
# a panic path is reachable from the tick handler, or if the two builds differ.
set -euo pipefail
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
if rustup run nightly rustc -V >/dev/null 2>&1 || rustup toolchain install nightly --profile minimal >/dev/null 2>&1; then
  rustup target add --toolchain nightly "$TARGET" >/dev/null 2>&1 && HAVE_NIGHTLY=1
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
# OFF by default (IMAGE_SIZE_OPT=1 turns it on): with it, boot runs slower
# code before the first tick, which moves the encoder frames' phase at the
# kernel's first reading; on the twin a 9.5 %-fast MT6816 (J4) was then
# read off by 246 counts before its decoder had measured the frame period
# (ENCODER_JUMP at boot, twin/tests/defects.rs defect6). It stays off until
# the decoder reports such readings as lost (SAFETY.md section 8) with an
# image that is still reproducible across build directories (the check
# below).
IMAGE_PROFILE=()
if [ "${IMAGE_SIZE_OPT:-0}" = 1 ]; then
  IMAGE_PROFILE=(--config 'profile.release.package."*".opt-level="z"'
                 --config 'profile.release.package.protocol.opt-level="z"')
fi

build() { # $1 = workspace root, $2 = target dir
  (cd "$1" && CARGO_TARGET_DIR="$2" RUSTFLAGS="--remap-path-prefix=$1=/parol6" \
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

echo "== flash bytes by crate (firmware/tools/size_by_crate.py)"
python3 "$ROOT/firmware/tools/size_by_crate.py" "$BIN/llvm-nm" "$OUT/parol6.elf" || echo "(size by crate failed)"

echo "== tick handler: panic paths and stack"
STACK_ELF=""
if [ "$HAVE_NIGHTLY" = 1 ]; then
  SDIR="$CARGO_TARGET_DIR/stack-sizes"
  if CARGO_TARGET_DIR="$SDIR" RUSTFLAGS="-Z emit-stack-sizes" \
       cargo +nightly build --release "${IMAGE_PROFILE[@]}" -p firmware --bin parol6 --target "$TARGET" \
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

REPRO_RC=0
if [ -z "${SKIP_REPRO:-}" ]; then
  echo "== reproducibility: second build in another directory"
  TMP="$(mktemp -d /tmp/parol6-repro.XXXXXX)"
  # (twin/target: the twin's own build, hundreds of MB, not part of the image)
  tar -C "$ROOT" --exclude=./target --exclude=./twin/target --exclude=.git -cf - . | tar -C "$TMP" -xf -
  build "$TMP" "$TMP/target" >/dev/null 2>"$OUT/repro-build.log" || { echo "second build failed (see $OUT/repro-build.log)"; REPRO_RC=1; }
  if [ "$REPRO_RC" = 0 ]; then
    "$OBJCOPY" -O ihex "$TMP/target/$TARGET/release/parol6" "$OUT/parol6.repro.hex"
    H1="$(sha256sum "$OUT/parol6.hex" | cut -d' ' -f1)"; H2="$(sha256sum "$OUT/parol6.repro.hex" | cut -d' ' -f1)"
    echo "sha256 $ROOT build: $H1"
    echo "sha256 $TMP build: $H2"
    if [ "$H1" = "$H2" ]; then echo "reproducible: yes"; else echo "reproducible: NO"; REPRO_RC=1; fi
  fi
  rm -rf "$TMP"
fi

if [ "$PANIC_RC" != 0 ]; then echo "FAIL: panic path reachable from the tick handler (see above)"; fi
[ "$PANIC_RC" = 0 ] && [ "$REPRO_RC" = 0 ]
