#!/usr/bin/env bash
# The project's whole test suite. Works on a fresh machine: it installs what
# it needs (the pinned toolchain, its components and the Cortex-M7 target).
# Usage: ci/test.sh            (everything)
set -euo pipefail
cd "$(dirname "$0")/.."

step() { printf '\n==> %s\n' "$*"; }

step "toolchain (pinned in rust-toolchain.toml)"
# rustup >= 1.28 no longer installs the pinned toolchain implicitly.
rustup toolchain install >/dev/null 2>&1 || rustup show >/dev/null
rustup component add rustfmt clippy >/dev/null
rustup target add thumbv7em-none-eabihf >/dev/null
rustc --version

step "format"
cargo fmt --all -- --check

step "clippy (host, warnings are errors)"
cargo clippy --workspace --all-targets --locked -- -D warnings

step "clippy (thumbv7em-none-eabihf, warnings are errors)"
cargo clippy -p kernel -p protocol -p hal-imxrt --target thumbv7em-none-eabihf --release --locked -- -D warnings

step "host tests"
cargo test --workspace --locked

step "kernel for the Cortex-M7"
cargo build -p kernel --target thumbv7em-none-eabihf --release --locked

printf '\nAll checks passed.\n'
