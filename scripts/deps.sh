#!/usr/bin/env bash
# Installs the Debian packages gyrotc needs. Idempotent: apt runs only when
# something is missing. Usage: scripts/deps.sh [native] [aarch64] [armhf] [bench]
set -euo pipefail

want=("$@")
[ ${#want[@]} -eq 0 ] && want=(native)

pkgs=()
need_arch=()
for w in "${want[@]}"; do
  case "$w" in
    native)
      pkgs+=(build-essential cmake pkg-config file libeigen3-dev libgpiod-dev catch2 libcli11-dev
             libtomlplusplus-dev nlohmann-json3-dev libbenchmark-dev
             systemd) ;;  # systemd: systemd-analyze for tests/deploy
    aarch64)
      need_arch+=(arm64)
      pkgs+=(g++-aarch64-linux-gnu qemu-user libgpiod-dev:arm64 libtomlplusplus-dev:arm64
             libbenchmark-dev:arm64) ;;
    armhf)
      need_arch+=(armhf)
      pkgs+=(g++-arm-linux-gnueabihf qemu-user libgpiod-dev:armhf libtomlplusplus-dev:armhf
             libbenchmark-dev:armhf) ;;
    bench)
      pkgs+=(rt-tests time jq) ;;  # cyclictest, /usr/bin/time, JSON for scripts/bench.sh
    *) echo "deps.sh: unknown set '$w' (native, aarch64, armhf, bench)" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0

SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
for a in "${need_arch[@]}"; do
  dpkg --print-foreign-architectures | grep -qx "$a" || $SUDO dpkg --add-architecture "$a"
done
echo "deps.sh: installing ${missing[*]}" >&2
$SUDO apt-get update -qq || echo "deps.sh: apt-get update reported errors; trying the install anyway" >&2
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
