#!/usr/bin/env bash
# Statement (line) and branch coverage of the safety kernel and the code
# around it: kernel, protocol, monitor, firmware's composition root
# (firmware/src/root.rs) and hal-imxrt's pure part (hal-imxrt/src/pure).
#
#   ci/coverage.sh            both runs; prints the figures docs/COVERAGE.md gives
#   ci/coverage.sh --write    the same, and rewrites docs/COVERAGE.md's generated part
#
# Two figures:
#   requirements  the requirement-based tests only: every integration test
#                 (tests/) of kernel, protocol, hal-imxrt and sim (the
#                 simulator's scenarios and root tests drive firmware::root),
#                 and the Kani harnesses of proofs/ under the shim; no unit
#                 test written against a function's internals
#   everything    every test of kernel, protocol, monitor, hal-imxrt,
#                 firmware, proofs, proptests and sim (the other tests added
#                 to the requirement-based run's counters)
#
# Branch coverage needs rustc's -Zcoverage-options=branch: the pinned
# nightly of ci/nightly.sh. cargo-llvm-cov is installed at a pinned version.
set -euo pipefail
cd "$(dirname "$0")/.."

LLVM_COV_VERSION=0.9.1
# shellcheck source=ci/nightly.sh
. ci/nightly.sh
rustup component add llvm-tools --toolchain "$NIGHTLY" >/dev/null
if ! cargo llvm-cov --version 2>/dev/null | grep -qx "cargo-llvm-cov $LLVM_COV_VERSION"; then
    cargo install cargo-llvm-cov --version "$LLVM_COV_VERSION" --locked
fi

# The crates' own sources only (not tests, not the test plant, not the
# shim); the per-crate split is done by ci/coverage.py.
IGNORE='(/tests/|/\.cargo/|/rustc/|monitor/src/(tests|plant)\.rs|proofs/|proptests/|sim/|protocol/fuzz/|twin/|emu/)'
OUT=target/coverage
mkdir -p "$OUT"
cov() { cargo "+$NIGHTLY" llvm-cov "$@"; }

export KANI_SHIM_SAMPLES="${KANI_SHIM_SAMPLES:-2000}"
export PROPTEST_CASES="${PROPTEST_CASES:-64}"

# Runs the test selections given as the remaining arguments ("-p kernel
# --test *", ...: each one cargo invocation, split into words without glob
# expansion), adding to the counters, and exports them as JSON.
run() {
    local name=$1
    shift
    local sel
    for sel in "$@"; do
        local words
        read -r -a words <<<"$sel"
        cov --no-report --branch --locked "${words[@]}"
    done
    cov report --branch --json --ignore-filename-regex "$IGNORE" --output-path "$OUT/$name.json"
}

# The kernel unit test skipped below compares the bit patterns of NaN
# results of f32::min/max, which Rust does not specify: under the nightly
# with coverage instrumentation the payload differs. It runs in the test
# command on the pinned stable toolchain.
#
# One package per invocation, as `cargo test -p` builds it (no feature
# unification across the selection). `everything` adds the remaining tests
# to the requirement-based run's counters: its figures are those of all the
# tests together.
T0=$(date +%s)
cov clean --workspace
run requirements \
    "-p kernel --test *" \
    "-p protocol --test *" \
    "-p hal-imxrt --test *" \
    "-p sim --test *" \
    "-p proofs --lib"
T1=$(date +%s)
run everything \
    "-p kernel --lib -- --skip f32_min_max_are_min_num_max_num_with_self_on_ties" \
    "-p protocol --lib" \
    "-p monitor --all-features" \
    "-p hal-imxrt --lib" \
    "-p firmware" \
    "-p proofs --test *" \
    "-p proptests" \
    "-p sim --lib"
T2=$(date +%s)
echo "coverage runs: requirements $((T1 - T0)) s, the other tests $((T2 - T1)) s"

python3 ci/coverage.py "$OUT/requirements.json" "$OUT/everything.json" "$@"
