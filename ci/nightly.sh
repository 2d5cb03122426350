# Sourced by the scripts that need a nightly toolchain (fuzzing, Miri): sets
# NIGHTLY to the pinned build, installing it if missing.
# The nightly is pinned (the same build every run): nightly-2026-05-20 is
# rustc 1.97.0-nightly (e50aa6fba 2026-05-19). An installed `nightly` of
# exactly that build is used as is; otherwise the dated toolchain is
# installed.
NIGHTLY_PIN=nightly-2026-05-20
NIGHTLY_BUILD="e50aa6fba 2026-05-19"
if rustup run "$NIGHTLY_PIN" rustc --version >/dev/null 2>&1; then
    NIGHTLY="$NIGHTLY_PIN"
elif rustc +nightly --version 2>/dev/null | grep -q "($NIGHTLY_BUILD)"; then
    NIGHTLY=nightly
else
    rustup toolchain install "$NIGHTLY_PIN" --profile minimal
    NIGHTLY="$NIGHTLY_PIN"
fi
