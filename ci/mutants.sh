#!/usr/bin/env bash
# Mutation testing of the kernel with cargo-mutants (SAFETY.md 7a,
# docs/MUTANTS.md). Not part of ci/test.sh: every file of kernel/src
# (`all`, 1,291 mutants) takes about 1 h 40 min on two cores shared with
# other work, two mutants at a time, about 14 s build and 3 s test each,
# and a second stage for the undecided ones (docs/MUTANTS.md); the logic
# files alone (the default, 547 mutants) about an hour. Installs the
# pinned cargo-mutants if missing.
#
#   ci/mutants.sh [FILE...]     mutants of FILE (default: every logic file,
#                               below), tested by the kernel's own tests
#   ci/mutants.sh all           mutants of every file of kernel/src
#   ci/mutants.sh summary       per-file counts of the last run's outcomes
#
# The run tests one commit, not the working tree: the commit is exported
# (git archive) to a scratch directory, so uncommitted work in the checkout
# is neither mutated nor tested, and the files of one run are all mutated at
# that commit. Results go to $MUTANTS_OUT/mutants.out (default
# /tmp/mutants): outcomes.json (every mutant's verdict, written as the run
# goes), caught.txt, missed.txt, timeout.txt, unviable.txt, diff/ (each
# mutant as a patch), log/ (each mutant's build and test output).
#
# What makes a mutant cheap (the measured figures: docs/MUTANTS.md):
# - every mutant rebuilds the kernel's tests, and a test binary compiles the
#   whole generic kernel for both scalars again; `kernel/tests/*.rs` are 16
#   binaries, so the scratch copy builds them as one (`tests/all.rs`: each
#   file a module, `autotests = false`): the same tests, one compilation;
# - the profile below (no debug info, opt-level 1 for the kernel, the
#   monitor and `fixed`): opt-level 0 builds faster still but runs the
#   tests 15 times slower. It is written into the scratch copy's
#   .cargo/config.toml, so no other build sees it;
# - two mutants at a time (`--jobs 2`, each in its own copy of the scratch
#   tree) under `nice`: the compiler's serial front end leaves a core idle.
#
# Environment: MUTANTS_OUT (output root), MUTANTS_TIMEOUT (test timeout per
# mutant in seconds, default 20: the kernel's tests take about 5 s, the
# mutants that break the homing sequencing never end a homing run and are
# counted as timeouts after it), MUTANTS_JOBS (default 2), MUTANTS_SHARD
# (k/n: only that shard, for splitting one run across invocations: the k-th
# of n consecutive slices of the mutant list, cargo-mutants' default
# sharding; give every shard the same MUTANTS_REV, files and arguments, and
# its own MUTANTS_OUT), MUTANTS_SRC (scratch directory, default a fresh mktemp -d),
# MUTANTS_REV (the commit to mutate, default HEAD), MUTANTS_TEST_PACKAGES
# (the packages whose tests judge each mutant, default `kernel`; the number
# types and the configuration, `scalar.rs`, `config.rs`, `types.rs`, are
# also exercised by `protocol`'s tests: the decimal text of every report,
# the parser's numbers, so their second stage uses "kernel protocol";
# `config.rs`'s adds `monitor`, which reads the configuration's derived
# values), MUTANTS_ARGS (further
# cargo-mutants arguments, e.g. `--re PATTERN` or `--iterate`). A file the
# commit does not have is skipped.
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

# Per-file counts from outcomes.json (one or more output directories).
summary() {
    local dirs=("$@")
    [ "${#dirs[@]}" -gt 0 ] || dirs=("$OUT")
    local files=()
    for d in "${dirs[@]}"; do files+=("$d/mutants.out/outcomes.json"); done
    jq -rs '
      [ .[].outcomes[] | select(.scenario | type == "object")
        | { file: .scenario.Mutant.file, s: .summary } ]
      | group_by(.file)
      | map({ file: .[0].file,
              c: map(select(.s == "CaughtMutant")) | length,
              m: map(select(.s == "MissedMutant")) | length,
              u: map(select(.s == "Unviable")) | length,
              t: map(select(.s == "Timeout")) | length })
      | (map([.file, .c, .m, .u, .t]) + [["total", (map(.c) | add), (map(.m) | add), (map(.u) | add), (map(.t) | add)]])[]
      | @tsv' "${files[@]}" |
        awk -F'\t' 'BEGIN { printf "%-34s %6s %6s %6s %8s %7s %7s\n", "file", "tested", "caught", "missed", "unviable", "timeout", "score" }
            { s = ($2 + $3) ? sprintf("%.1f%%", 100 * $2 / ($2 + $3)) : "-"
              printf "%-34s %6d %6d %6d %8d %7d %7s\n", $1, $2 + $3 + $4 + $5, $2, $3, $4, $5, s }'
    echo "score = caught / (caught + missed); timeouts and unviable mutants excluded"
}

if [ "${1:-}" = summary ]; then
    shift
    summary "$@"
    exit 0
fi

if [ "$(cargo mutants --version 2>/dev/null || true)" != "cargo-mutants $CARGO_MUTANTS_VERSION" ]; then
    cargo install cargo-mutants --version "$CARGO_MUTANTS_VERSION" --locked
fi

[ "$#" -gt 0 ] && FILES=("$@")
rev="${MUTANTS_REV:-HEAD}"
# `all`: every Rust file of kernel/src at that commit (the order of the
# files does not change the mutant list, nor so a shard's slice of it).
if [ "${FILES[*]}" = all ]; then
    mapfile -t FILES < <(git ls-tree -r --name-only "$rev" kernel/src | grep '\.rs$')
fi
src="${MUTANTS_SRC:-$(mktemp -d)}"
mkdir -p "$src" "$OUT"
git archive "$rev" | tar -x -C "$src"
echo "ci/mutants.sh: $rev = $(git rev-parse --short "$rev") in $src, results in $OUT"

# The kernel's integration tests as one test binary (above).
(
    cd "$src/kernel"
    tests=(tests/*.rs)
    {
        echo "// Every kernel/tests file as a module of one test crate (ci/mutants.sh)."
        for t in "${tests[@]}"; do
            echo "#[path = \"$(basename "$t")\"]"
            echo "mod $(basename "$t" .rs);"
        done
    } >tests/all.rs
    sed -i '0,/^\[package\]$/s//[package]\nautotests = false/' Cargo.toml
    printf '\n[[test]]\nname = "all"\npath = "tests/all.rs"\n' >>Cargo.toml
)
mkdir -p "$src/.cargo"
cat >>"$src/.cargo/config.toml" <<'EOF'

# ci/mutants.sh: the mutation run's build profile.
[profile.dev]
debug = 0
[profile.dev.package.kernel]
opt-level = 1
debug = 0
[profile.dev.package.monitor]
opt-level = 1
[profile.dev.package.fixed]
opt-level = 1
[profile.dev.package.protocol]
opt-level = 1
EOF

args=()
for f in "${FILES[@]}"; do
    if [ -f "$src/$f" ]; then args+=(-f "$f"); else echo "== $f: not in $rev, skipped"; fi
done
[ -n "${MUTANTS_SHARD:-}" ] && args+=(--shard "$MUTANTS_SHARD")
# shellcheck disable=SC2206 # MUTANTS_ARGS is split on purpose
[ -n "${MUTANTS_ARGS:-}" ] && args+=(${MUTANTS_ARGS})

# Exit status 2 means missed mutants, 3 timeouts: both are results.
# --features proof-states: `Kernel::from_spec` (proof-only code in
# invariant.rs) and its tests (kernel/tests/from_spec.rs, boundaries.rs).
# The baseline (the unmutated tree builds and passes) runs first.
tests=$(echo "${MUTANTS_TEST_PACKAGES:-kernel}" | tr -s ' ' ',')
(cd "$src" && nice -n "${MUTANTS_NICE:-15}" cargo mutants -p kernel --test-package "$tests" --features proof-states \
    --no-shuffle --jobs "${MUTANTS_JOBS:-2}" --timeout "${MUTANTS_TIMEOUT:-20}" --build-timeout 600 \
    --output "$OUT" "${args[@]}") || { rc=$?; [ "$rc" -eq 2 ] || [ "$rc" -eq 3 ]; }
summary
