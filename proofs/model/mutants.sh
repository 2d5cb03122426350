#!/usr/bin/env bash
# Mutation tests of the model check: for every requirement SAFETY.md calls
# model-checked, a kernel that breaks that requirement makes the model fail
# the property its row names. Each mutant: copy the workspace to a temporary
# directory, patch one kernel line (failing loudly if the line is not found,
# so a rewrite of the kernel cannot make this test pass vacuously), run the
# model on a configuration that finishes (small, or homing for the per-joint
# runs and arrival orders) and require a violation of the named property
# (`--expect-violation`: the run stops at the first one). The test
# `every_model_checked_row_has_a_property_and_a_mutant` (proofs/model)
# checks that each such row names its property and has a mutant here.
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
# mutant NAME FILE LINE REPLACEMENT CONFIG PROPERTY: LINE (exact, whole
# line) in FILE becomes REPLACEMENT; the model on CONFIG must report
# PROPERTY violated.
mutant() {
    local name=$1 file=$2 line=$3 repl=$4 config=$5 prop=$6
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
    if (cd "$dir" && cargo run -q -p model --release --locked -- --variant fx --config "$config" --expect-violation "$prop"); then
        echo "mutant $name: killed by the model ($prop violated) in $(( $(date +%s) - start )) s"
    else
        echo "mutant $name: SURVIVED (no violation of $prop) in $(( $(date +%s) - start )) s" >&2
        failed=1
    fi
    rm -rf "$dir"
}

mutant estimate-not-at-first-reading kernel/src/kernel/axis.rs \
    '        self.obs = AlphaBeta::at(self.measured(p));' \
    '        self.obs = AlphaBeta::at(self.measured(p).plus(S::from_f32(0.001)));' \
    small 'SR-1: an estimate does not start at rest at its first reading'
mutant fault-zeroes-one-axis kernel/src/kernel/supervisor.rs \
    '            *out = [S::ZERO; AXES];' \
    '            out[0] = S::ZERO;' \
    small 'SR-4: output in the tick a fault is detected'
mutant second-fault-overwrites-the-first kernel/src/kernel/supervisor.rs \
    '            if self.mode != Mode::Fault {' \
    '            if true {' \
    small "SR-5: a latched fault's reason changed"
# A latch that something other than <ENABLE> leaves: a kernel whose
# <HOME> clears a SoftEstop (to Unhomed, then homes).
mutant home-leaves-soft-estop kernel/src/kernel/homing_seq.rs \
    '        if let Some(r) = self.homing_refusal() {' \
    '        if self.mode == super::supervisor::Mode::SoftEstop { self.mode = super::supervisor::Mode::Unhomed; } if let Some(r) = self.homing_refusal() {' \
    small 'SR-5: a latch left without an accepted enable'
mutant enable-ignores-a-present-cause kernel/src/kernel/intake.rs \
    '        if let Some(cause) = detected.or_else(|| self.present_cause(sense)) {' \
    '        if let Some(cause) = detected.or_else(|| self.present_cause(sense)).filter(|_| false) {' \
    small 'SR-6: enable cleared a latch while a cause was present'
# A lock-up: a kernel that takes an unhomed joint's switch (its homing
# input) for an enable cause refuses <ENABLE> for good after a homing run
# stopped with an axis on its switch.
mutant lock-up-on-homing-switch kernel/src/kernel/supervisor.rs \
    '            if homed && sense.limits & bit(i) != 0 {' \
    '            if sense.limits & bit(i) != 0 {' \
    small 'SR-6/31: recoverability: enable or home refused after a latch with no physical cause'
mutant ramp-latches-a-tick-late kernel/src/kernel/supervisor.rs \
    '                if k >= self.p.stop_ticks && then_home == 0 {' \
    '                if k > self.p.stop_ticks && then_home == 0 {' \
    small 'SR-7: the ramp did not end in SoftEstop at k = N'
mutant enable-arms-the-timeout kernel/src/kernel/intake.rs \
    '        self.transition(Edge::Enable);' \
    '        self.transition(Edge::Enable); self.armed = true;' \
    small 'SR-8: the timeout armed by anything but an accepted motion'
mutant ignore-limit-switch kernel/src/kernel/supervisor.rs \
    '            let pressed = limits & bit(i) != 0;' \
    '            let pressed = limits & bit(i) != 0 && i > AXES;' \
    small 'SR-10: a limit switch did not fault in the same tick'
mutant ignore-encoder-loss kernel/src/kernel/axis.rs \
    '                    if self.invalid > k.invalid_limit {' \
    '                    if self.invalid > k.invalid_limit && axis > 5 {' \
    small 'SR-11: the encoder fault did not come in the same tick'
mutant no-homing-dependencies kernel/src/kernel/homing_seq.rs \
    '            needs |= g;' \
    '            needs |= 0;' \
    homing 'SR-13: an axis moved in homing before its dependencies were homed'
mutant rehoming-keeps-homed kernel/src/kernel/homing_seq.rs \
    '        self.homed &= !mask;' \
    '        self.homed &= !0;' \
    small 'SR-14: a re-homed axis still counted homed when its run started'
mutant motion-accepted-unhomed kernel/src/kernel/supervisor.rs \
    '            Mode::Unhomed => Some(Reject::NotHomed),' \
    '            Mode::Unhomed => None,' \
    small 'SR-15: motion accepted outside Operational'
mutant waiting-axis-creeps kernel/src/kernel/homing_seq.rs \
    '            if group & bit(i) == 0 {' \
    '            if group & bit(i) == 0 && { *o = S::from_f32(0.001); true } {' \
    small 'SR-16: an axis not in a moving homing phase output non-zero'
mutant limits-not-checked kernel/src/kernel/intake.rs \
    '        self.p.limits.check(t)' \
    '        self.p.limits.check(t).or(Ok(()))' \
    small 'SR-17: an out-of-limits target accepted'
mutant ignore-hardware-fault kernel/src/kernel.rs \
    '        let mut fault: Option<FaultReason> = sense.hardware_fault.map(FaultReason::Hardware);' \
    '        let mut fault: Option<FaultReason> = sense.hardware_fault.map(FaultReason::Hardware).filter(|_| false);' \
    small 'SR-21: a hardware fault did not fault in the same tick'
# The model identifies a homing axis in Idle or Done by its phase and
# velocity only (`AxisHoming`'s `Hash`: the run record is dead there, and
# the kernel reaches a finished axis only through `phase()`). The merged
# states are still explored: a kernel whose finished axis reads its record
# (reports itself seeking while its tick count is non-zero, which every
# finished axis has) must fail. (A kernel reading the record in a way that
# differs between merged states is what `kernel`'s
# `homing::tests::idle_and_done_forget_the_run_record` fails.)
mutant done-axis-reads-its-record kernel/src/homing.rs \
    '        self.phase' \
    '        if self.phase == Phase::Done && self.ticks > 0 { Phase::FastSeek } else { self.phase }' \
    homing 'SR-14: an axis of a homing run counted homed before its zero was captured'
# A finished homing axis waits, stepped, for the rest of its group (the
# homing configuration's J4 may finish a tick after J5): a kernel whose
# finished axis still counts its timeout faults a run that should
# complete, naming the waiting axis.
mutant done-axis-times-out-while-waiting kernel/src/homing.rs \
    '        if !self.phase.is_moving() {' \
    '        if !self.phase.is_moving() && self.phase != Phase::Done {' \
    homing 'SR-14/16: a finished homing axis moved, left Done or faulted while its group was still moving'
mutant phases-kept-after-homing kernel/src/kernel/homing_seq.rs \
    '            ax.homing.reset(false);' \
    '            let _ = ax;' \
    small "SR-32: a state outside the kernel's state invariant (Kernel::invariant)"

exit "$failed"
