#!/usr/bin/env bash
# The simulator's speed on the built-in scenarios, before and after: builds
# `sim` at a git revision (default HEAD) and from the working tree, runs both
# N times interleaved (same machine, same load) and prints, per build:
#
# - x real time as emu/bench.sh computes it (the sum of the simulated seconds
#   over the sum of the per-scenario wall times the simulator prints: run and
#   reports written), median and best run;
# - the same from each scenario's best wall time over the N runs (an
#   estimate for an unloaded machine: load only ever adds time);
# - the process CPU time (user + system), median.
#
#   sim/speed.sh [REV] [N]     e.g. sim/speed.sh 2d33be3 11
#
# Speed is printed, never asserted: the machine may be shared and loaded.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
REV="${1:-HEAD}"
N="${2:-9}"
TARGET="${CARGO_TARGET_DIR:-$ROOT/target}"
WORK="$TARGET/sim-speed"
mkdir -p "$WORK"
rev=$(git -C "$ROOT" rev-parse --short "$REV")
if [ ! -x "$WORK/sim-$rev" ]; then
    echo "==> building sim at $rev"
    rm -rf "$WORK/src-$rev" && mkdir -p "$WORK/src-$rev"
    git -C "$ROOT" archive "$rev" | tar -x -C "$WORK/src-$rev"
    (cd "$WORK/src-$rev" && CARGO_TARGET_DIR="$WORK/target-rev" cargo build --release --locked -q -p sim)
    cp "$WORK/target-rev/release/sim" "$WORK/sim-$rev"
fi
echo "==> building sim from the working tree"
(cd "$ROOT" && cargo build --release --locked -q -p sim)
cp "$TARGET/release/sim" "$WORK/sim-worktree"
python3 - "$N" "$WORK" "$WORK/sim-$rev" "$WORK/sim-worktree" <<'PY'
import re, resource, statistics as st, subprocess, sys
n, work, bins = int(sys.argv[1]), sys.argv[2], sys.argv[3:]
line = re.compile(r"\] (\S+) .*\(([0-9.]+) s simulated in ([0-9.]+) s\)")
runs = {b: [] for b in bins}
for _ in range(n):
    for b in bins:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        p = subprocess.run([b, "--out", f"{work}/out"], capture_output=True, text=True)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if p.returncode != 0:
            sys.exit(f"{b} failed:\n{p.stdout}{p.stderr}")
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        runs[b].append(({m[1]: (float(m[2]), float(m[3])) for m in line.finditer(p.stderr)}, cpu))
for b in bins:
    xs = []
    for scen, _ in runs[b]:
        sim, wall = sum(v[0] for v in scen.values()), sum(v[1] for v in scen.values())
        xs.append((sim / wall, sim, wall))
    names = runs[b][0][0].keys()
    best = sum(min(r[0][k][1] for r in runs[b]) for k in names)
    sim = xs[0][1]
    print(f"{b.rsplit('/', 1)[-1]}: {len(names)} scenarios, {sim:.1f} s simulated")
    print(f"  x real time (emu/bench.sh's figure): median {st.median(x[0] for x in xs):.0f}, best {max(x[0] for x in xs):.0f}"
          f" (sum of scenario walls: median {st.median(x[2] for x in xs):.3f} s)")
    print(f"  from each scenario's best wall: {sim / best:.0f} x real time ({best:.3f} s)")
    print(f"  process CPU time: median {st.median(r[1] for r in runs[b]):.3f} s")
PY
