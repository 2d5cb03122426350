#!/usr/bin/env bash
# Re-records the scenario (emu/data/scenario_{f32,fx}.bin) on the host:
# the kernel against emu-host's simple plant. Commit the result.
set -euo pipefail
EMU="$(cd "$(dirname "$0")" && pwd)"
cd "$EMU"
export CARGO_TARGET_DIR="${EMU_TARGET_DIR:-/work/target-emu}"
cargo build --release --locked -q -p emu-host
"$CARGO_TARGET_DIR/release/emu-host" record "$EMU/data"
