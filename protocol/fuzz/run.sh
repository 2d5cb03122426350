#!/usr/bin/env bash
# Bounded fuzzing of the framer + parser (sampled evidence, not a proof).
# Usage: protocol/fuzz/run.sh [seconds]   (default 30)
# Installs what it needs: a nightly toolchain (minimal profile) and cargo-fuzz.
set -euo pipefail
SECS="${1:-30}"
cd "$(dirname "$0")"

. ../../ci/nightly.sh  # (the working directory is protocol/fuzz here)
if ! cargo +"$NIGHTLY" fuzz --version >/dev/null 2>&1; then
    cargo install cargo-fuzz --locked
fi

# The committed seeds live in corpus/framer_parser/seed_*; libFuzzer adds its
# own finds to the same directory (ignored by git).
cargo +"$NIGHTLY" fuzz run framer_parser corpus/framer_parser -- \
    -max_total_time="$SECS" -rss_limit_mb=512 -max_len=4096
