#!/usr/bin/env bash
# Runs the SPSC queue tests (heapless::spsc under the protocol's Link) under
# Miri, which checks for undefined behaviour and data races in the executions
# it runs (sampled evidence: Miri explores one interleaving per run, with its
# own scheduler; it is not a model checker).
# Usage: protocol/miri.sh
set -euo pipefail
cd "$(dirname "$0")/.."

. ci/nightly.sh  # (the working directory is the repository root here)
if ! rustup +"$NIGHTLY" component list --installed | grep -q '^miri'; then
    rustup +"$NIGHTLY" component add miri rust-src
fi

export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-target/miri}"
# Several seeds so the two-thread test sees different interleavings.
for seed in 0 1 2 3; do
    MIRIFLAGS="-Zmiri-seed=$seed" cargo +"$NIGHTLY" miri test -p protocol queue
done
