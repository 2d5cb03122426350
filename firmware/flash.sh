#!/usr/bin/env bash
# Flash target/firmware/parol6.hex to a Teensy 4.1 with teensy_loader_cli.
# Fails at once (never waits) if the tool or a Teensy is missing: the Teensy
# must be in HalfKay bootloader mode (press the program button) or running a
# sketch that answers the soft reboot request. The wait (-w) is bounded.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
HEX="${1:-$ROOT/target/firmware/parol6.hex}"
WAIT_S="${FLASH_WAIT_S:-15}"
[ -f "$HEX" ] || { echo "flash.sh: $HEX not found; run firmware/build.sh first" >&2; exit 2; }
command -v teensy_loader_cli >/dev/null 2>&1 || {
  echo "flash.sh: teensy_loader_cli not installed (apt-get install teensy-loader-cli)" >&2; exit 3; }
# PJRC HalfKay bootloader 16c0:0478; a running Teensy (USB serial) 16c0:0483..0489.
if command -v lsusb >/dev/null 2>&1; then
  if ! lsusb -d 16c0: >/dev/null 2>&1; then
    echo "flash.sh: no Teensy (USB vendor 16c0) attached; connect it and press the program button" >&2; exit 4
  fi
else
  echo "flash.sh: lsusb not available; trying for at most ${WAIT_S}s" >&2
fi
timeout --foreground "$WAIT_S" teensy_loader_cli --mcu=TEENSY41 -w -v "$HEX" || {
  echo "flash.sh: no Teensy answered within ${WAIT_S}s" >&2; exit 5; }
