#!/usr/bin/env bash
# Mutation tests of the model check: the model must fail when the kernel
# ignores a limit switch (SR-10), an encoder loss (SR-11) or a hardware
# fault (SR-21). Each mutant: copy the workspace to a temporary directory,
# patch one kernel line (failing loudly if the line is not found, so a
# rewrite of the kernel cannot make this test pass vacuously), run the model
# on its small configuration and require a violation of the named property.
#
#   proofs/model/mutants.sh
#
# Builds go to target/model-mutants (shared by the mutants; a faster release
# profile than the shipped one: no LTO, 16 codegen units).
set -euo pipefail
cd "$(dirname "$0")/../.."
ROOT=$(pwd)
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
export CARGO_TARGET_DIR="$ROOT/target/model-mutants"
export CARGO_PROFILE_RELEASE_LTO=false CARGO_PROFILE_RELEASE_CODEGEN_UNITS=16 CARGO_PROFILE_RELEASE_DEBUG=0

failed=0
# mutant NAME FILE LINE REPLACEMENT PROPERTY: LINE (exact, whole line) in
# FILE becomes REPLACEMENT; the model must report PROPERTY violated.
mutant() {
    local name=$1 file=$2 line=$3 repl=$4 prop=$5
    local dir="$TMP/$name"
    mkdir -p "$dir"
    # The working tree (not only what is committed), without build outputs.
    tar -C "$ROOT" --exclude=./target --exclude=./.git -cf - . | tar -C "$dir" -xf -
    local n
    n=$(grep -cxF -- "$line" "$dir/$file" || true)
    if [ "$n" != 1 ]; then
        echo "mutants: $name: expected exactly one line '$line' in $file, found $n: update this script" >&2
        exit 1
    fi
    LINE="$line" REPL="$repl" perl -0pi -e 's/^\Q$ENV{LINE}\E$/$ENV{REPL}/m' "$dir/$file"
    if cmp -s "$ROOT/$file" "$dir/$file"; then
        echo "mutants: $name: the patch did not change $file" >&2
        exit 1
    fi
    local start
    start=$(date +%s)
    echo "==> mutant $name ($file), expecting a violation of $prop"
    if (cd "$dir" && cargo run -q -p model --release --locked -- --variant fx --config small --expect-violation "$prop"); then
        echo "mutant $name: killed by the model ($prop violated) in $(( $(date +%s) - start )) s"
    else
        echo "mutant $name: SURVIVED (no violation of $prop) in $(( $(date +%s) - start )) s" >&2
        failed=1
    fi
    rm -rf "$dir"
}

mutant ignore-limit-switch kernel/src/kernel/supervisor.rs \
    '            let pressed = limits & bit(i) != 0;' \
    '            let pressed = limits & bit(i) != 0 && i > AXES;' \
    SR-10
mutant ignore-encoder-loss kernel/src/kernel/axis.rs \
    '                    if self.invalid > k.invalid_limit {' \
    '                    if self.invalid > k.invalid_limit && axis > 5 {' \
    SR-11
mutant ignore-hardware-fault kernel/src/kernel.rs \
    '        let mut fault: Option<FaultReason> = sense.hardware_fault.map(FaultReason::Hardware);' \
    '        let mut fault: Option<FaultReason> = sense.hardware_fault.map(FaultReason::Hardware).filter(|_| false);' \
    SR-21

exit "$failed"
