#!/usr/bin/env bash
# Flash the PAROL6 image to a Teensy 4.1 with teensy_loader_cli. See usage()
# for the arguments, the exit codes and the udev rule. It never waits for a
# board it cannot see: the USB bus is read from sysfs (no lsusb needed), and
# only a board that is on the bus is waited for, at most FLASH_WAIT_S.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
ME="flash.sh"
WAIT_S="${FLASH_WAIT_S:-15}"
# sysfs USB devices (a test points this at a fake tree)
SYS_USB="${FLASH_SYS_USB:-/sys/bus/usb/devices}"

# exit codes
E_USAGE=2 E_NO_IMAGE=3 E_BAD_IMAGE=4 E_NO_TOOL=5 E_NO_BOARD=6 E_FLASH=7

usage() {
  cat <<EOF
usage: firmware/flash.sh [-h|--help] [--install] [HEX]

Writes HEX (default: target/firmware/parol6.hex, made by firmware/build.sh)
to a Teensy 4.1 with teensy_loader_cli --mcu=TEENSY41.

A Teensy in its bootloader (HalfKay, USB 16c0:0478) is written at once. A
board running this image (USB serial 16c0:0483) is first asked to reboot
into the bootloader (teensy_loader_cli -s: the serial line set to 134
baud); the image does so only while the arm is at rest (it answers
BOOTLOADER_REFUSED MOVING otherwise: stop the arm and run this again).
Otherwise press the program button on the board.

  -h, --help   this text
  --install    install teensy_loader_cli (Debian package teensy-loader-cli,
               apt-get, as root) if it is not on PATH

Environment: FLASH_WAIT_S (default 15) bounds the wait for the reboot and
the write once a Teensy is on the bus.

Exit codes:
  0  flashed
  2  usage (unknown option, more than one HEX)
  3  no image (HEX missing: run firmware/build.sh)
  4  bad image (not a well-formed Intel HEX file: record syntax, checksums,
     end-of-file record)
  5  no tool (teensy_loader_cli or python3 not found, or --install failed)
  6  no board (the USB bus cannot be read, or no Teensy on it)
  7  flashing failed (teensy_loader_cli failed or did not finish in time:
     a running image refuses the reboot while the arm moves)

Linux permissions: without root, the bootloader and the running image need
a udev rule, e.g. in /etc/udev/rules.d/49-teensy.rules:
  SUBSYSTEMS=="usb", ATTRS{idVendor}=="16c0", ATTRS{idProduct}=="0478", MODE:="0666"
  SUBSYSTEMS=="usb", ATTRS{idVendor}=="16c0", ATTRS{idProduct}=="0483", MODE:="0666", ENV{ID_MM_DEVICE_IGNORE}="1"
then: udevadm control --reload-rules && udevadm trigger. PJRC's rule file
for every Teensy (00-teensy.rules) covers both pairs as well.
EOF
}

die() { # $1 = exit code, $2... = message
  local rc="$1"; shift
  echo "$ME: $*" >&2
  exit "$rc"
}

HEX="" INSTALL=0
while [ "$#" -gt 0 ]; do
  case "$1" in
    -h|--help) usage; exit 0 ;;
    --install) INSTALL=1 ;;
    --) shift; [ "$#" -le 1 ] || die "$E_USAGE" "more than one image given (see --help)"
        [ "$#" = 0 ] || HEX="$1"; break ;;
    -*) die "$E_USAGE" "unknown option $1 (see --help)" ;;
    *) [ -z "$HEX" ] || die "$E_USAGE" "more than one image given: $HEX and $1 (see --help)"
       HEX="$1" ;;
  esac
  shift
done
case "$WAIT_S" in ''|*[!0-9]*) die "$E_USAGE" "FLASH_WAIT_S must be a whole number of seconds, not '$WAIT_S'" ;; esac
HEX="${HEX:-$ROOT/target/firmware/parol6.hex}"

# 1. the image, before anything else
[ -f "$HEX" ] || die "$E_NO_IMAGE" "$HEX not found; run firmware/build.sh first"
command -v python3 >/dev/null 2>&1 || die "$E_NO_TOOL" "python3 not found (needed to check the image)"
if ! WHY="$(python3 - "$HEX" 2>&1 <<'PY'
import sys
path = sys.argv[1]
data_records = 0
try:
    text = open(path, "rb").read().decode("ascii")
except (OSError, UnicodeDecodeError) as e:
    sys.exit(f"cannot read it as ASCII text: {e}")
lines = text.splitlines()
for n, line in enumerate(lines, 1):
    if not line.startswith(":"):
        sys.exit(f"line {n}: a record starts with ':'")
    body = line[1:]
    try:
        raw = bytes.fromhex(body)
    except ValueError:
        sys.exit(f"line {n}: not hexadecimal")
    if len(raw) < 5 or len(raw) != raw[0] + 5:
        sys.exit(f"line {n}: length does not match its byte count")
    if sum(raw) & 0xFF:
        sys.exit(f"line {n}: checksum wrong")
    kind = raw[3]
    if kind > 5:
        sys.exit(f"line {n}: unknown record type {kind:02X}")
    if kind == 0:
        data_records += 1
    if kind == 1:
        if any(l.strip() for l in lines[n:]):
            sys.exit(f"line {n}: records after the end-of-file record")
        break
else:
    sys.exit("no end-of-file record (truncated?)")
if data_records == 0:
    sys.exit("no data record")
PY
)"; then
  die "$E_BAD_IMAGE" "$HEX is not a valid Intel HEX image: ${WHY:-invalid}"
fi

# 2. the tool
if ! command -v teensy_loader_cli >/dev/null 2>&1; then
  if [ "$INSTALL" = 1 ]; then
    echo "$ME: installing teensy_loader_cli (apt-get install teensy-loader-cli)" >&2
    { apt-get install -y teensy-loader-cli >&2 && command -v teensy_loader_cli >/dev/null 2>&1; } ||
      die "$E_NO_TOOL" "could not install teensy-loader-cli (as root: apt-get update && apt-get install teensy-loader-cli)"
  else
    die "$E_NO_TOOL" "teensy_loader_cli not found: apt-get install teensy-loader-cli (or firmware/flash.sh --install)"
  fi
fi

# 3. the board: read the bus from sysfs, at once
[ -d "$SYS_USB" ] || die "$E_NO_BOARD" "cannot see the USB bus ($SYS_USB missing); nothing to wait for"
HALFKAY=0 RUNNING=0 OLD=0
for dev in "$SYS_USB"/*; do
  [ -f "$dev/idVendor" ] && [ -f "$dev/idProduct" ] || continue
  vid="$(cat "$dev/idVendor")"; pid="$(cat "$dev/idProduct")"
  case "$vid:$pid" in
    16c0:0478) HALFKAY=1 ;;
    16c0:0483) RUNNING=1 ;;
    1209:0001) OLD=1 ;;
  esac
done
SOFT=()
if [ "$HALFKAY" = 0 ]; then
  if [ "$RUNNING" = 1 ]; then
    SOFT=(-s)
  elif [ "${OLD:-0}" = 1 ]; then
    die "$E_NO_BOARD" "a board runs an image that does not answer the soft reboot (USB 1209:0001): press the program button on the Teensy, then run this again"
  else
    die "$E_NO_BOARD" "no Teensy (bootloader 16c0:0478 or running image 16c0:0483) on the bus: connect the board, or press its program button"
  fi
fi

# 4. write it (a Teensy is there: the wait only bounds the reboot and the write)
if [ "${#SOFT[@]}" -gt 0 ]; then
  echo "$ME: asking the running image to reboot into the bootloader, then writing $HEX"
else
  echo "$ME: writing $HEX"
fi
rc=0
timeout --foreground "$WAIT_S" teensy_loader_cli --mcu=TEENSY41 "${SOFT[@]}" -w -v "$HEX" || rc=$?
if [ "$rc" = 124 ]; then
  if [ "${#SOFT[@]}" -gt 0 ]; then
    die "$E_FLASH" "no bootloader within ${WAIT_S}s: the image refuses the reboot while the arm moves (stop it, or press the program button)"
  fi
  die "$E_FLASH" "teensy_loader_cli did not finish within ${WAIT_S}s"
elif [ "$rc" != 0 ]; then
  die "$E_FLASH" "teensy_loader_cli failed (exit $rc)"
fi
echo "$ME: flashed; the board reboots into the image"
