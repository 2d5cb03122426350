#!/usr/bin/env bash
# Bounded fuzzing of the framer + parser (sampled evidence, not a proof).
# Usage: protocol/fuzz/run.sh [seconds]   (default 30)
# Installs what it needs: a nightly toolchain (minimal profile) and cargo-fuzz.
set -euo pipefail
SECS="${1:-30}"
cd "$(dirname "$0")"

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
if ! cargo +"$NIGHTLY" fuzz --version >/dev/null 2>&1; then
    cargo install cargo-fuzz --locked
fi

# The committed seeds live in corpus/framer_parser/seed_*; libFuzzer adds its
# own finds to the same directory (ignored by git).
cargo +"$NIGHTLY" fuzz run framer_parser corpus/framer_parser -- \
    -max_total_time="$SECS" -rss_limit_mb=512 -max_len=4096
