#!/usr/bin/env bash
# Install what the twin's build needs (unicorn-engine-sys builds Unicorn's C
# sources with cmake and generates bindings with libclang). Debian packages;
# run as root (or with sudo available). Idempotent.
set -euo pipefail
need=()
for p in libclang-dev cmake pkg-config; do
  dpkg -s "$p" >/dev/null 2>&1 || need+=("$p")
done
if [ "${#need[@]}" -gt 0 ]; then
  SUDO=""; [ "$(id -u)" = 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${need[@]}"
fi
echo "twin setup: libclang-dev cmake pkg-config present"
