#!/usr/bin/env bash
# Runs the SPSC queue tests (heapless::spsc under the protocol's Link) under
# Miri, which checks for undefined behaviour and data races in the executions
# it runs (sampled evidence: Miri explores one interleaving per run, with its
# own scheduler; it is not a model checker).
# Usage: protocol/miri.sh
set -euo pipefail
cd "$(dirname "$0")/.."

# The nightly is pinned (the same build every run): nightly-2026-05-20 is
# rustc 1.97.0-nightly (e50aa6fba 2026-05-19). An installed `nightly` of
# exactly that build is used as is; otherwise the dated toolchain is
# installed.
NIGHTLY_PIN=nightly-2026-05-20
NIGHTLY_BUILD="e50aa6fba 2026-05-19"
if rustup run "$NIGHTLY_PIN" rustc --version >/dev/null 2>&1; then
    NIGHTLY="$NIGHTLY_PIN"
elif rustc +nightly --version 2>/dev/null | grep -q "($NIGHTLY_BUILD)"; then
    NIGHTLY=nightly
else
    rustup toolchain install "$NIGHTLY_PIN" --profile minimal
    NIGHTLY="$NIGHTLY_PIN"
fi
if ! rustup +"$NIGHTLY" component list --installed | grep -q '^miri'; then
    rustup +"$NIGHTLY" component add miri rust-src
fi

export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-target/miri}"
# Several seeds so the two-thread test sees different interleavings.
for seed in 0 1 2 3; do
    MIRIFLAGS="-Zmiri-seed=$seed" cargo +"$NIGHTLY" miri test -p protocol queue
done
