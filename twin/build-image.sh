#!/usr/bin/env bash
# Build the Serial1 release image the twin runs and copy it to
# target/twin/parol6-serial1.elf (firmware/build.sh always writes
# target/firmware/parol6.elf whatever the features, so the twin keeps its own
# copy; a later USB build cannot replace it by accident).
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
cd "$ROOT"
# build.sh exits non-zero when its panic-path or reproducibility checks fail;
# the twin runs whatever image was built, so only a missing ELF is fatal.
FEATURES=serial1 SKIP_REPRO=1 firmware/build.sh || echo "(firmware/build.sh reported a check failure; the image was still built)"
mkdir -p target/twin
ELF="${CARGO_TARGET_DIR:-$ROOT/target/fw-build}/thumbv7em-none-eabihf/release/parol6"
[ -f "$ELF" ] || ELF="$ROOT/target/firmware/parol6.elf"
cp "$ELF" target/twin/parol6-serial1.elf
echo "twin image: target/twin/parol6-serial1.elf"
# The same image with the drivers' enable output (firmware feature
# `driver-enable`) for twin/tests/driver_enable.rs; the tick's stack is
# measured on the image above (SKIP_STACK: no second nightly build).
FEATURES="serial1 driver-enable" SKIP_REPRO=1 SKIP_STACK=1 firmware/build.sh >target/twin/driver-enable-build.log 2>&1 \
  || { tail -n 20 target/twin/driver-enable-build.log; echo "(firmware/build.sh reported a check failure for the driver-enable image)"; }
cp "$ELF" target/twin/parol6-serial1-driver-enable.elf
echo "twin image: target/twin/parol6-serial1-driver-enable.elf"
# The same image with the TMC5160 link (firmware feature `tmc5160-spi`) for
# twin/tests/driver_spi.rs; likewise without a second stack build.
FEATURES="serial1 tmc5160-spi" SKIP_REPRO=1 SKIP_STACK=1 firmware/build.sh >target/twin/tmc5160-build.log 2>&1 \
  || { tail -n 20 target/twin/tmc5160-build.log; echo "(firmware/build.sh reported a check failure for the tmc5160-spi image)"; }
cp "$ELF" target/twin/parol6-serial1-tmc5160.elf
echo "twin image: target/twin/parol6-serial1-tmc5160.elf"
