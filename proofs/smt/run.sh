#!/usr/bin/env bash
# SMT proofs of the kernel's generic per-axis code (see proofs/smt/README.md).
# Installs z3 if it is missing (Debian package, as root), then, in release
# mode: the semantics check of the symbolic scalars against f32 / I8F24, the
# product lemmas the abstracted proofs rest on (z3 and exhaustive) and
# the broken-function tests (cargo test), then every proof with its time and
# path count. Extra arguments go to the prover (e.g. --extended, a filter).
set -euo pipefail
cd "$(dirname "$0")/../.."

if ! command -v z3 >/dev/null 2>&1; then
    if [ "$(id -u)" != 0 ]; then
        echo "z3 is missing and we are not root: apt-get install -y z3" >&2
        exit 1
    fi
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq z3 >/dev/null
fi
z3 --version

T0=$(date +%s)
echo "--- semantics (symbolic vs concrete, bit for bit) and broken functions (must be refuted)"
log=$(mktemp)
status=0
cargo test -p smt --release --locked -- --include-ignored --nocapture --test-threads=2 >"$log" 2>&1 || status=$?
if [ "$status" != 0 ]; then
    cat "$log"
    exit "$status"
fi
grep -E '^(test |test result|f32:|I8F24:|trait comparisons|product lemmas)|square lemmas|factor lemma|integer product|[0-9]+ paths, ' "$log"
rm -f "$log"
echo "    ($(( $(date +%s) - T0 )) s)"

echo "--- proofs"
cargo run -p smt --release --locked --quiet -- "$@"
