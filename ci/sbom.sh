#!/usr/bin/env bash
# CycloneDX SBOM of the firmware image: the firmware crate's normal
# dependencies for thumbv7em-none-eabihf (what can be linked into the
# image; proc-macro crates are listed, build scripts' dependencies are not),
# written to target/sbom/parol6-image.cdx.json. Needs cargo-cyclonedx
# (pinned and installed by ci/test.sh). docs/safety/DEPENDENCIES.md.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=target/sbom
NAME=parol6-image.cdx
mkdir -p "$OUT"
# cargo-cyclonedx writes NAME.json beside every workspace member's
# Cargo.toml; keep the firmware's and remove the others, even on failure.
cleanup() { git ls-files --others --exclude-standard -- "*/$NAME.json" "$NAME.json" | xargs -r rm -f; }
trap cleanup EXIT
# A fixed time stamp: the same lock gives the same file.
SOURCE_DATE_EPOCH="$(git log -1 --format=%ct 2>/dev/null || echo 0)" \
  cargo cyclonedx --manifest-path firmware/Cargo.toml --target thumbv7em-none-eabihf --format json \
    --spec-version 1.5 --no-build-deps --override-filename "$NAME" -q
mv firmware/$NAME.json "$OUT/$NAME.json"
python3 - "$OUT/$NAME.json" <<'PY'
import json, sys
bom = json.load(open(sys.argv[1]))
names = {c["name"] for c in bom.get("components", [])}
need = {"teensy4-bsp", "imxrt-ral", "imxrt-usbd", "usb-device", "usbd-serial", "cortex-m", "cortex-m-rt",
        "defmt", "heapless", "fixed", "critical-section", "kernel", "protocol", "hal-imxrt"}
missing = sorted(need - names)
print(f"SBOM {sys.argv[1]}: CycloneDX {bom['specVersion']}, {len(bom.get('components', []))} components")
if missing:
    sys.exit(f"SBOM lacks crates the image links: {missing}")
PY
