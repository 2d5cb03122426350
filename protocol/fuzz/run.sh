#!/usr/bin/env bash
# Bounded fuzzing of the fuzz targets (sampled evidence, not a proof), within
# a total time budget. Prints executions per second per target. Fails on the
# first crash (libFuzzer writes the input to artifacts/<target>/).
#
# Usage: protocol/fuzz/run.sh [seconds]   (default 30; docs/FUZZING.md)
# Env:   FUZZ_TARGETS   targets to run (default: all three; the budget is
#                       split framer_parser 1/2, receive_path 1/4,
#                       kernel_ticks the rest; any other selection splits it
#                       equally; each gets at least 1 s)
#        FUZZ_JOBS      parallel fuzzing processes per target (default 1;
#                       above 1, libFuzzer's -fork=N over the cores)
#        FUZZ_MAX_LEN   longest input in bytes (default 4096)
# Installs what it needs: a nightly toolchain (minimal profile) and cargo-fuzz (pinned).
set -euo pipefail
SECS="${1:-30}"
cd "$(dirname "$0")"

. ../../ci/nightly.sh  # (the working directory is protocol/fuzz here)
CARGO_FUZZ_VERSION=0.13.2  # pinned: a fresh clone builds the same fuzz driver
if ! cargo +"$NIGHTLY" fuzz --version 2>/dev/null | grep -q " $CARGO_FUZZ_VERSION\$"; then
    cargo install cargo-fuzz --version "$CARGO_FUZZ_VERSION" --locked
fi

ALL="framer_parser receive_path kernel_ticks"
TARGETS="${FUZZ_TARGETS:-$ALL}"
JOBS="${FUZZ_JOBS:-1}"
MAX_LEN="${FUZZ_MAX_LEN:-4096}"
budget() { if [ "$1" -lt 1 ]; then echo 1; else echo "$1"; fi; }
declare -A TIME
if [ "$TARGETS" = "$ALL" ]; then
    half=$((SECS / 2)); quarter=$((SECS / 4))
    TIME=([framer_parser]=$(budget $half) [receive_path]=$(budget $quarter) [kernel_ticks]=$(budget $((SECS - half - quarter))))
else
    n=0
    for t in $TARGETS; do
        case " $ALL " in *" $t "*) n=$((n + 1)) ;; *) echo "run.sh: unknown fuzz target $t (targets: $ALL)" >&2; exit 2 ;; esac
    done
    for t in $TARGETS; do TIME[$t]=$(budget $((SECS / n))); done
fi
fork=()
[ "$JOBS" -gt 1 ] && fork=(-fork="$JOBS")

# Build once, outside the budget.
cargo +"$NIGHTLY" fuzz build

# The committed corpus (corpus/<target>, minimised) is read; new finds go to
# a scratch directory under target/ (ignored by git), so a run leaves the
# working tree clean. `-max_len=4096` (the default) covers a few dozen
# protocol lines.
summary=""
for t in $TARGETS; do
    work="target/corpus-work/$t"
    mkdir -p "$work" "corpus/$t"
    log="target/fuzz-$t.log"
    echo "== $t: ${TIME[$t]} s, $JOBS process(es), inputs up to $MAX_LEN bytes"
    set +e
    cargo +"$NIGHTLY" fuzz run "$t" "$work" "corpus/$t" -- \
        -max_total_time="${TIME[$t]}" -rss_limit_mb=1024 -max_len="$MAX_LEN" "${fork[@]}" \
        -print_final_stats=1 2>&1 \
        | tee "$log" | grep -E "INITED|DONE|ERROR|panicked|SUMMARY|number_of_executed_units"
    status=${PIPESTATUS[0]}  # cargo fuzz's status, not grep's
    set -e
    if [ "$status" -ne 0 ]; then
        tail -n 60 "$log"
        echo "fuzz target $t FAILED (exit $status); the input is in protocol/fuzz/artifacts/$t/" >&2
        exit "$status"
    fi
    # One process: "Done N runs in S second(s)"; -fork: the last status
    # line "#N: ... time: Ss" (the forked jobs' executions summed).
    runs=$(sed -n 's/^Done \([0-9]*\) runs in \([0-9]*\) second.*/\1/p' "$log" | tail -n 1)
    secs=$(sed -n 's/^Done \([0-9]*\) runs in \([0-9]*\) second.*/\2/p' "$log" | tail -n 1)
    if [ -z "$runs" ]; then
        runs=$(sed -n 's/^#\([0-9]*\):.* time: \([0-9]*\)s.*/\1/p' "$log" | tail -n 1)
        secs=$(sed -n 's/^#\([0-9]*\):.* time: \([0-9]*\)s.*/\2/p' "$log" | tail -n 1)
    fi
    rate=$(( ${runs:-0} / ( ${secs:-1} > 0 ? ${secs:-1} : 1 ) ))
    summary+=$(printf '%-14s %12s runs %6s s %10s exec/s' "$t" "${runs:-?}" "${secs:-?}" "$rate")$'\n'
done
echo "== fuzzing summary (no crash)"
printf '%s' "$summary"
