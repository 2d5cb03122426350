#!/usr/bin/env bash
# Kani harnesses of proofs/ for CI (Kani cannot run on the development
# machines: see docs/spec/evidence.md section 2 and SAFETY.md).
#
#   ci/kani.sh list               harness names (every `#[kani::proof]` fn in proofs/src/*.rs)
#   ci/kani.sh run NAME...        cargo kani on each named harness, one at a time,
#                                 each under a wall-clock limit of $KANI_HARNESS_TIMEOUT
#                                 (default 30m); fails if any harness fails or times out,
#                                 or leaves a kani::cover! UNSATISFIABLE or UNREACHABLE
#   ci/kani.sh inventory [DIR]    `cargo kani list` output (the proof inventory) into DIR
#                                 (default kani-inventory/), plus this script's own list
#
# `run` and `inventory` need cargo-kani on PATH (the workflow gets it from
# model-checking/kani-github-action) and, as Kani's nightly rustc is older
# than the workspace's rust-version, KANI_MATCH_RUST_VERSION=1 on a scratch
# checkout (see match_rust_version); `list` needs only bash and awk.
set -euo pipefail
cd "$(dirname "$0")/.."

list() {
    # The first `fn` after each `#[kani::proof]`, skipping other attributes.
    awk '
        /^[[:space:]]*#\[kani::proof\]/ { want = 1; next }
        want && match($0, /fn[[:space:]]+[A-Za-z_][A-Za-z0-9_]*/) {
            s = substr($0, RSTART, RLENGTH); sub(/^fn[[:space:]]+/, "", s); print s; want = 0
        }
    ' proofs/src/*.rs | sort
}

# Non-vacuity: a cover Kani reports UNSATISFIABLE or UNREACHABLE must fail
# the harness (a harness whose assumptions exclude what it claims to reach
# proves nothing). Kani does that with `--fail-uncoverable`, an unstable
# option (Kani's cover-statement RFC), enabled by `-Z unstable-options`
# (Kani removed the older `--enable-unstable` spelling in 0.63; the
# workflow pins 0.67.0). Passed when this cargo-kani parses it;
# independently of the option, `run` fails a harness whose summary counts
# fewer satisfied covers than covers.
uncoverable_flags() {
    if cargo kani -Z unstable-options --fail-uncoverable --help >/dev/null 2>&1; then
        echo "-Z unstable-options --fail-uncoverable"
    fi
}

# Kani compiles with its own nightly toolchain, whose rustc is older than
# the workspace's `rust-version` (the pinned stable of rust-toolchain.toml),
# and cargo refuses to build a package that asks for a newer rustc;
# `cargo kani` has no `--ignore-rust-version`. With KANI_MATCH_RUST_VERSION=1
# (set by the workflow's Kani jobs, on a throw-away checkout) the
# workspace's `rust-version` is lowered to Kani's rustc before the build;
# without it the script stops and says so.
match_rust_version() {
    local want have rustc
    want=$(sed -nE 's/^rust-version = "([0-9.]+)"/\1/p' Cargo.toml)
    rustc=$(ls -d "${KANI_HOME:-$HOME/.kani}"/kani-*/toolchain/bin/rustc 2>/dev/null | tail -n 1 || true)
    if [ -z "$rustc" ]; then
        echo "ci/kani.sh: Kani's toolchain not found under ${KANI_HOME:-$HOME/.kani} (run cargo kani setup)" >&2
        exit 1
    fi
    have=$("$rustc" --version | sed -nE 's/^rustc ([0-9]+\.[0-9]+)\..*/\1/p')
    echo "rust-version: the workspace asks for $want, Kani's rustc is $have ($("$rustc" --version))"
    if [ "$(printf '%s\n%s\n' "$have" "$want" | sort -V | head -n 1)" = "$want" ]; then
        return
    fi
    if [ "${KANI_MATCH_RUST_VERSION:-0}" != 1 ]; then
        echo "ci/kani.sh: Kani's rustc $have is older than rust-version $want; rerun with KANI_MATCH_RUST_VERSION=1 on a scratch checkout (it edits Cargo.toml)" >&2
        exit 1
    fi
    sed -i -E "s/^rust-version = \"[0-9.]+\"/rust-version = \"$have\"/" Cargo.toml
    echo "rust-version lowered to $have in Cargo.toml for this run"
}

# The first "** N of M cover properties satisfied" line of a Kani log with
# N < M, if any.
uncovered() {
    grep -E '\*\* [0-9]+ of [0-9]+ cover propert(y|ies) satisfied' "$1" |
        awk '{ if ($2 != $4) { print; exit } }' || true
}

case "${1:-}" in
list)
    list
    ;;
run)
    shift
    [ "$#" -gt 0 ] || { echo "usage: ci/kani.sh run NAME..." >&2; exit 2; }
    known="$(list)"
    timeout_s="${KANI_HARNESS_TIMEOUT:-30m}"
    failed=()
    match_rust_version
    # shellcheck disable=SC2207 # the flags are words without spaces
    flags=($(uncoverable_flags))
    echo "non-vacuity: ${flags[*]:-no --fail-uncoverable in this cargo-kani; the cover summary is checked}"
    log=$(mktemp)
    for h in "$@"; do
        if ! grep -qx -- "$h" <<<"$known"; then
            echo "ci/kani.sh: no #[kani::proof] fn named $h in proofs/src" >&2
            failed+=("$h (unknown)")
            continue
        fi
        echo "::group::cargo kani --harness $h (limit $timeout_s)"
        start=$(date +%s)
        if timeout --signal=TERM --kill-after=60 "$timeout_s" cargo kani -p proofs "${flags[@]}" --harness "$h" --exact |
            tee "$log"; then
            status=ok
            if [ -n "$(uncovered "$log")" ]; then
                status="FAILED (a cover not satisfied: $(uncovered "$log"))"
                failed+=("$h: $status")
            fi
        else
            rc=$?
            if [ "$rc" -eq 124 ]; then status="TIMEOUT after $timeout_s"; else status="FAILED (exit $rc)"; fi
            failed+=("$h: $status")
        fi
        echo "::endgroup::"
        echo "$h: $status in $(( $(date +%s) - start )) s"
    done
    if [ "${#failed[@]}" -gt 0 ]; then
        printf 'failed: %s\n' "${failed[@]}" >&2
        exit 1
    fi
    ;;
inventory)
    dir="${2:-kani-inventory}"
    match_rust_version
    mkdir -p "$dir"
    list >"$dir/harnesses.txt"
    (cd proofs && cargo kani list --format pretty) | tee "$dir/cargo-kani-list.txt"
    (cd proofs && cargo kani list --format json && mv kani-list.json "../$dir/") || true
    ;;
*)
    echo "usage: ci/kani.sh list | run NAME... | inventory [DIR]" >&2
    exit 2
    ;;
esac
