#!/usr/bin/env bash
# Bounded fuzzing of the framer + parser (sampled evidence, not a proof).
# Usage: protocol/fuzz/run.sh [seconds]   (default 30)
# Installs what it needs: a nightly toolchain (minimal profile) and cargo-fuzz.
set -euo pipefail
SECS="${1:-30}"
cd "$(dirname "$0")"

if ! rustup toolchain list | grep -q '^nightly'; then
    rustup toolchain install nightly --profile minimal
fi
if ! cargo +nightly fuzz --version >/dev/null 2>&1; then
    cargo install cargo-fuzz --locked
fi

# The committed seeds live in corpus/framer_parser/seed_*; libFuzzer adds its
# own finds to the same directory (ignored by git).
cargo +nightly fuzz run framer_parser corpus/framer_parser -- \
    -max_total_time="$SECS" -rss_limit_mb=512 -max_len=4096
