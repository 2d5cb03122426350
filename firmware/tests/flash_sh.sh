#!/usr/bin/env bash
# Every exit path of firmware/flash.sh, with stub tools on a PATH of our own
# and a fake sysfs USB tree (FLASH_SYS_USB): no board, no teensy_loader_cli
# and no network needed. Run by the test command (ci/test.sh).
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/../.." && pwd)"
FLASH="$ROOT/firmware/flash.sh"
T="$(mktemp -d /tmp/flash-sh-test.XXXXXX)"
trap 'rm -rf "$T"' EXIT

# PATH: only what flash.sh needs besides the tool under test
mkdir -p "$T/bin" "$T/bin-tool"
for tool in bash dirname cat timeout sleep env; do
  ln -s "$(command -v "$tool")" "$T/bin/$tool"
done
# the interpreter itself, not a version manager's shim (which needs its own
# environment)
ln -s "$(python3 -c 'import sys; print(sys.executable)')" "$T/bin/python3"
# the stub loader: records its arguments; STUB_RC / STUB_SLEEP set its behaviour
cat >"$T/bin-tool/teensy_loader_cli" <<'STUB'
#!/usr/bin/env bash
echo "$*" >"$STUB_LOG"
sleep "${STUB_SLEEP:-0}"
exit "${STUB_RC:-0}"
STUB
chmod +x "$T/bin-tool/teensy_loader_cli"
# a failing apt-get for --install
mkdir -p "$T/bin-apt"
printf '#!/usr/bin/env bash\necho "apt-get stub: $*" >&2\nexit 100\n' >"$T/bin-apt/apt-get"
chmod +x "$T/bin-apt/apt-get"
export STUB_LOG="$T/stub.log"

# images
GOOD="$T/good.hex"
printf ':020000040000FA\n:0400000001020304F2\n:00000001FF\n' >"$GOOD"
printf ':020000040000FA\n:0400000001020304F3\n:00000001FF\n' >"$T/checksum.hex"
printf ':020000040000FA\n:0400000001020304F2\n' >"$T/truncated.hex"
printf 'hello\n' >"$T/text.hex"
printf ':00000001FF\n' >"$T/empty.hex"

# buses: none, a hub only, a running board (the image), the bootloader
usb_dev() { mkdir -p "$1/$2"; echo "$3" >"$1/$2/idVendor"; echo "$4" >"$1/$2/idProduct"; }
usb_dev "$T/bus-hub" 1-0:1.0 1d6b 0002
usb_dev "$T/bus-old" 1-0:1.0 1d6b 0002; usb_dev "$T/bus-old" 1-1 1209 0001
usb_dev "$T/bus-running" 1-0:1.0 1d6b 0002; usb_dev "$T/bus-running" 1-1 16c0 0483
usb_dev "$T/bus-halfkay" 1-0:1.0 1d6b 0002; usb_dev "$T/bus-halfkay" 1-1 16c0 0478

FAILS=0 N=0
check() { # $1 = name, $2 = expected exit code, $3 = text expected in the output, then: env assignments -- args
  local name="$1" want="$2" text="$3"; shift 3
  local envs=() rc=0 out
  while [ "$1" != -- ]; do envs+=("$1"); shift; done; shift
  N=$((N + 1))
  out="$(env -i HOME="$T" "${envs[@]}" "$T/bin/bash" "$FLASH" "$@" 2>&1)" || rc=$?
  if [ "$rc" = "$want" ] && [[ "$out" == *"$text"* ]]; then
    echo "ok   $name (exit $rc)"
  else
    echo "FAIL $name: exit $rc (want $want), output:"; echo "$out" | sed 's/^/    /'
    FAILS=$((FAILS + 1))
  fi
}
P_TOOL="PATH=$T/bin-tool:$T/bin"
P_NOTOOL="PATH=$T/bin"

check "help"                 0 "Exit codes:"            "$P_TOOL" -- --help
check "short help"           0 "usage: firmware/flash.sh" "$P_TOOL" -- -h
check "unknown option"       2 "unknown option --bogus" "$P_TOOL" -- --bogus
check "two images"           2 "more than one image"    "$P_TOOL" -- "$GOOD" "$GOOD"
check "two images after --"  2 "more than one image"    "$P_TOOL" -- -- "$GOOD" "$GOOD"
check "bad FLASH_WAIT_S"     2 "FLASH_WAIT_S"           "$P_TOOL" FLASH_WAIT_S=soon -- "$GOOD"
check "no image"             3 "not found"              "$P_TOOL" -- "$T/missing.hex"
check "bad checksum"         4 "checksum wrong"         "$P_TOOL" -- "$T/checksum.hex"
check "truncated"            4 "no end-of-file record"  "$P_TOOL" -- "$T/truncated.hex"
check "not hex"              4 "a record starts with"   "$P_TOOL" -- "$T/text.hex"
check "no data"              4 "no data record"         "$P_TOOL" -- "$T/empty.hex"
check "bad image, no tool"   4 "checksum wrong"         "$P_NOTOOL" -- "$T/checksum.hex"
check "no tool"              5 "teensy_loader_cli not found" "$P_NOTOOL" FLASH_SYS_USB="$T/bus-halfkay" -- "$GOOD"
check "install fails"        5 "could not install"      "PATH=$T/bin-apt:$T/bin" FLASH_SYS_USB="$T/bus-halfkay" -- --install "$GOOD"
S=$(date +%s)
check "no bus"               6 "cannot see the USB bus" "$P_TOOL" FLASH_SYS_USB="$T/no-such-dir" -- "$GOOD"
[ $(( $(date +%s) - S )) -le 2 ] || { echo "FAIL no bus: waited"; FAILS=$((FAILS + 1)); }
check "no board"             6 "no Teensy"              "$P_TOOL" FLASH_SYS_USB="$T/bus-hub" -- "$GOOD"
check "old image, no soft reboot" 6 "press the program button" "$P_TOOL" FLASH_SYS_USB="$T/bus-old" -- "$GOOD"
check "running, refuses (moving)" 7 "refuses the reboot while the arm moves" "$P_TOOL" FLASH_SYS_USB="$T/bus-running" STUB_SLEEP=5 FLASH_WAIT_S=1 STUB_LOG="$STUB_LOG" -- "$GOOD"
rm -f "$STUB_LOG"
check "running, soft reboot"  0 "asking the running image" "$P_TOOL" FLASH_SYS_USB="$T/bus-running" STUB_LOG="$STUB_LOG" -- "$GOOD"
if [ "$(cat "$STUB_LOG" 2>/dev/null)" != "--mcu=TEENSY41 -s -w -v $GOOD" ]; then
  echo "FAIL running, soft reboot: teensy_loader_cli got '$(cat "$STUB_LOG" 2>/dev/null)'"; FAILS=$((FAILS + 1))
fi
check "tool fails"           7 "failed (exit 1)"        "$P_TOOL" FLASH_SYS_USB="$T/bus-halfkay" STUB_RC=1 STUB_LOG="$STUB_LOG" -- "$GOOD"
check "tool hangs"           7 "did not finish within 1s" "$P_TOOL" FLASH_SYS_USB="$T/bus-halfkay" STUB_SLEEP=5 FLASH_WAIT_S=1 STUB_LOG="$STUB_LOG" -- "$GOOD"
rm -f "$STUB_LOG"
check "flashed"              0 "flashed"                "$P_TOOL" FLASH_SYS_USB="$T/bus-halfkay" STUB_LOG="$STUB_LOG" -- "$GOOD"
if [ "$(cat "$STUB_LOG" 2>/dev/null)" != "--mcu=TEENSY41 -w -v $GOOD" ]; then
  echo "FAIL flashed: teensy_loader_cli got '$(cat "$STUB_LOG" 2>/dev/null)'"; FAILS=$((FAILS + 1))
fi
echo "flash.sh: $((N - FAILS)) of $N exit-path checks passed"
[ "$FAILS" = 0 ]
