#!/usr/bin/env bash
# Mutation testing of the kernel's logic files with cargo-mutants (SAFETY.md
# 7a, docs/MUTANTS.md). Not part of ci/test.sh: it takes 2.5 to 3 hours
# on two cores shared with other work (498 mutants, about 20 s each). Installs the pinned
# cargo-mutants if missing.
#
#   ci/mutants.sh [FILE...]     mutants of FILE (default: every logic file,
#                               below), tested by the kernel's own tests
#   ci/mutants.sh summary       per-file counts of the last run's outcomes
#
# The run tests the committed HEAD, not the working tree: HEAD is exported
# (git archive) to a scratch directory and mutated in place there, one file
# after another, so the build directory is shared between the files and
# uncommitted work in the checkout is neither mutated nor tested. Results go
# to $MUTANTS_OUT/<file stem>/mutants.out (default /tmp/mutants): caught.txt,
# missed.txt, timeout.txt, unviable.txt, diff/ (each mutant as a patch).
#
# Environment: MUTANTS_OUT (output root), MUTANTS_TIMEOUT (test timeout per
# mutant in seconds, default 30: the kernel's tests take about 1.5 s),
# MUTANTS_SRC (scratch directory, default a fresh mktemp -d), MUTANTS_REV
# (the commit to mutate, default HEAD), MUTANTS_TESTS_REV (take the
# kernel's integration tests, kernel/tests/, from this commit instead: newer
# tests run against an older kernel), MUTANTS_ITERATE=1 (test only
# the mutants not caught in the previous run in $MUTANTS_OUT: cargo-mutants
# --iterate). A file the commit does not have is skipped.
set -euo pipefail
cd "$(dirname "$0")/.."

CARGO_MUTANTS_VERSION=27.1.0
OUT="${MUTANTS_OUT:-/tmp/mutants}"
FILES=(
    kernel/src/kernel/supervisor.rs
    kernel/src/kernel/axis.rs
    kernel/src/kernel/intake.rs
    kernel/src/interp.rs
    kernel/src/homing.rs
    kernel/src/kernel/homing_seq.rs
    kernel/src/kernel/invariant.rs
    kernel/src/ramp.rs
    kernel/src/kernel.rs
    kernel/src/kernel/params.rs
    kernel/src/observer.rs
    kernel/src/control.rs
)

summary() {
    printf '%-32s %7s %7s %9s %8s %7s\n' file caught missed unviable timeout score
    local tc=0 tm=0 tu=0 tt=0
    for d in "$OUT"/*/mutants.out; do
        [ -d "$d" ] || continue
        local c m u t
        c=$(cat "$d/caught.txt" "$d/previously_caught.txt" 2>/dev/null | grep -c . || true)
        m=$(grep -c . "$d/missed.txt" || true)
        u=$(grep -c . "$d/unviable.txt" || true)
        t=$(grep -c . "$d/timeout.txt" || true)
        tc=$((tc + c)) tm=$((tm + m)) tu=$((tu + u)) tt=$((tt + t))
        printf '%-32s %7d %7d %9d %8d %6s%%\n' "$(basename "$(dirname "$d")")" "$c" "$m" "$u" "$t" \
            "$(awk -v c="$c" -v m="$m" 'BEGIN { if (c + m) printf "%.1f", 100 * c / (c + m); else print "-" }')"
    done
    printf '%-32s %7d %7d %9d %8d %6s%%\n' total "$tc" "$tm" "$tu" "$tt" \
        "$(awk -v c="$tc" -v m="$tm" 'BEGIN { if (c + m) printf "%.1f", 100 * c / (c + m); else print "-" }')"
    echo "score = caught / (caught + missed); timeouts and unviable mutants excluded"
}

if [ "${1:-}" = summary ]; then
    summary
    exit 0
fi

if [ "$(cargo mutants --version 2>/dev/null || true)" != "cargo-mutants $CARGO_MUTANTS_VERSION" ]; then
    cargo install cargo-mutants --version "$CARGO_MUTANTS_VERSION" --locked
fi

[ "$#" -gt 0 ] && FILES=("$@")
src="${MUTANTS_SRC:-$(mktemp -d)}"
mkdir -p "$src" "$OUT"
rev="${MUTANTS_REV:-HEAD}"
git archive "$rev" | tar -x -C "$src"
echo "ci/mutants.sh: $rev = $(git rev-parse --short "$rev") in $src, results in $OUT"
if [ -n "${MUTANTS_TESTS_REV:-}" ]; then
    rm -rf "$src/kernel/tests"
    git archive "$MUTANTS_TESTS_REV" kernel/tests | tar -x -C "$src"
    echo "ci/mutants.sh: with kernel/tests/ of $MUTANTS_TESTS_REV"
fi
iterate=()
[ "${MUTANTS_ITERATE:-0}" = 1 ] && iterate=(--iterate)

# Each mutant rebuilds the kernel and its ~12 test binaries; without debug
# info and at opt-level 1 that takes about 15-25 s instead of 30-40 s on
# this machine (the tests still run in under a second).
export CARGO_PROFILE_DEV_DEBUG="${CARGO_PROFILE_DEV_DEBUG:-0}"
export CARGO_PROFILE_DEV_PACKAGE_KERNEL_DEBUG="${CARGO_PROFILE_DEV_PACKAGE_KERNEL_DEBUG:-0}"
export CARGO_PROFILE_DEV_PACKAGE_KERNEL_OPT_LEVEL="${CARGO_PROFILE_DEV_PACKAGE_KERNEL_OPT_LEVEL:-1}"

baseline=()
for f in "${FILES[@]}"; do
    [ -f "$src/$f" ] || { echo "== $f: not in $rev, skipped"; continue; }
    name="$(basename "$f" .rs)"
    echo "== $f ($(date -u +%H:%M:%S))"
    # Exit status 2 means missed mutants, 3 timeouts: both are results.
    # --features proof-states: `Kernel::from_spec` (proof-only code in
    # invariant.rs) and its tests (kernel/tests/from_spec.rs).
    (cd "$src" && cargo mutants -p kernel --test-package kernel --features proof-states -f "$f" --in-place --no-shuffle \
        --timeout "${MUTANTS_TIMEOUT:-30}" --build-timeout 600 "${baseline[@]}" "${iterate[@]}" \
        --output "$OUT/$name") || { rc=$?; [ "$rc" -eq 2 ] || [ "$rc" -eq 3 ]; }
    baseline=(--baseline skip)
done
summary
