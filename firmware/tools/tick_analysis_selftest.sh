#!/usr/bin/env bash
# Seeded-defect self-test of tick_analysis.py (docs/safety/TOOLS.md): on a
# small thumbv7em ELF (firmware/tools/seeded/seeded.rs) it must FAIL for a
# root that reaches a panic path, FAIL for a root that reaches a 64-bit
# division, and pass for a root that reaches neither. Run from anywhere;
# needs the pinned toolchain's thumbv7em target and llvm-tools (installed by
# firmware/build.sh, which the test command runs first).
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/../.." && pwd)"
cd "$ROOT"
TARGET=thumbv7em-none-eabihf
TC="$(sed -n 's/^channel *= *"\(.*\)"/\1/p' rust-toolchain.toml)"
rustup target add --toolchain "$TC" "$TARGET" >/dev/null
rustup component add --toolchain "$TC" llvm-tools >/dev/null
HOST="$(rustc +"$TC" -vV | sed -n 's/^host: //p')"
OBJDUMP="$(rustc +"$TC" --print sysroot)/lib/rustlib/$HOST/bin/llvm-objdump"
OUT="$ROOT/target/tick-analysis-selftest"
mkdir -p "$OUT"
rustc +"$TC" --edition 2021 --target "$TARGET" -C opt-level=2 -C panic=abort \
  -C link-arg=--entry=seeded_entry -o "$OUT/seeded.elf" firmware/tools/seeded/seeded.rs

fail=0
expect() { # root, expected exit (0 or 1), text the report must contain
  local rc=0
  python3 firmware/tools/tick_analysis.py "$OBJDUMP" "$OUT/seeded.elf" "$1" >"$OUT/$1.txt" 2>&1 || rc=$?
  if [ "$rc" != "$2" ] || ! grep -q "$3" "$OUT/$1.txt"; then
    echo "tick_analysis self-test: $1: exit $rc (want $2), '$3' $(grep -c "$3" "$OUT/$1.txt") times"
    cat "$OUT/$1.txt"
    fail=1
  else
    echo "tick_analysis self-test: $1: exit $rc, reports '$3' (as it must)"
  fi
}
expect seeded_panic 1 "PANIC PATH reachable"
expect seeded_division 1 "64-BIT DIVISION reachable"
expect seeded_clean 0 "no 64/128-bit division helper reachable"
exit "$fail"
