#!/usr/bin/env bash
# Run from the repository root: build the Serial1 image, then the twin's
# tests against it (evidence kind: emulated).
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
cd "$ROOT"
twin/setup.sh
twin/build-image.sh
cd twin
cargo fmt --check
cargo clippy --release --all-targets --locked -- -D warnings
cargo test --release --locked
