#!/usr/bin/env bash
# Installs the Debian packages gyrotc needs, on Debian 12 (bookworm), Debian 13
# (trixie) and what is built on them (Raspberry Pi OS). Idempotent: apt runs
# only when something is missing.
#
# Usage: scripts/deps.sh [native] [aarch64] [armhf] [bench] [vm]
#   native   compiler, CMake, ccache, the libraries and test tools (jq for the docs
#            test's hostile-ADC run) (default)
#   aarch64  cross compiler, qemu-user and the arm64 libraries (adds the dpkg
#            architecture arm64 if it is missing, and says so first)
#   armhf    the same for 32-bit ARM hard-float
#   bench    cyclictest, GNU time and jq for scripts/bench.sh
#   vm       mmdebstrap, qemu-system and qemu-user for scripts/vm-test.sh
#   yocto    OE's host tools and the en_US.UTF-8 locale for deploy/yocto/check-layer.sh
# Runs apt-get directly as root, through sudo otherwise.
set -euo pipefail
cd "$(dirname "$0")/.."

want=("$@")
[ ${#want[@]} -eq 0 ] && want=(native)

say() { echo "deps.sh: $*" >&2; }

# The suite decides a few package names; an unknown one (a derivative) gets
# the names apt knows.
codename=$( (. /etc/os-release 2>/dev/null && echo "${VERSION_CODENAME:-}") || true)
available() { apt-cache show "$1" >/dev/null 2>&1; }
case "$codename" in
  bookworm) catch2=catch2 ;;        # Catch2 2.13, header-only
  trixie) catch2=libcatch2-dev ;;   # Catch2 3.x, a static library
  *) if available libcatch2-dev; then catch2=libcatch2-dev; else catch2=catch2; fi ;;
esac

pkgs=()
need_arch=()
need_locale=0
cross_catch2=()  # target architectures whose Catch2 3 library is unpacked privately (below)
for w in "${want[@]}"; do
  case "$w" in
    native)
      pkgs+=(build-essential cmake ccache pkg-config file libeigen3-dev libgpiod-dev "$catch2" libcli11-dev
             libtomlplusplus-dev nlohmann-json3-dev libbenchmark-dev
             libfuse3-dev  # the board emulator, gyrotc-emu (docs/EMULATOR.md)
             systemd  # systemd-analyze for tests/deploy
             python3-prometheus-client  # its parser reads the daemon's metrics file in a test
             jq) ;;  # scripts/hostile_adc.sh, which the docs test runs
    aarch64 | armhf)
      if [ "$w" = aarch64 ]; then arch=arm64 triple=aarch64-linux-gnu; else arch=armhf triple=arm-linux-gnueabihf; fi
      need_arch+=("$arch")
      pkgs+=("g++-$triple" qemu-user "libgpiod-dev:$arch" "libtomlplusplus-dev:$arch" "libbenchmark-dev:$arch"
             "libfuse3-dev:$arch")
      [ "$catch2" = libcatch2-dev ] && cross_catch2+=("$arch") ;;
    bench)
      pkgs+=(rt-tests time jq) ;;  # cyclictest, /usr/bin/time, JSON for scripts/bench.sh
    vm)
      # mmdebstrap and arch-test for the roots, qemu-system for the boards,
      # qemu-user through binfmt_misc for a foreign root's maintainer scripts
      # (qemu-user-static: Debian 12's static build; on 13 it pulls qemu-user
      # and qemu-user-binfmt), cpio for the initramfs
      pkgs+=(mmdebstrap arch-test qemu-system-arm qemu-system-x86 qemu-user-static cpio) ;;
    yocto)
      pkgs+=(build-essential python3 git gawk wget diffstat chrpath cpio file lz4 zstd rpcsvc-proto
             patch bzip2 locales hostname)
      need_locale=1 ;;
    *) say "unknown set '$w' (native, aarch64, armhf, bench, vm, yocto)"; exit 2 ;;
  esac
done

# How to run apt-get and dpkg as root.
as_root() {
  if [ "$(id -u)" -eq 0 ]; then
    "$@"
  elif command -v sudo >/dev/null 2>&1; then
    sudo "$@"
  else
    say "needs root to install packages: run it as root, or install sudo; or install by hand: ${missing[*]}"
    exit 1
  fi
}

missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
added_arch=0
for a in "${need_arch[@]}"; do
  if ! dpkg --print-foreign-architectures | grep -qx "$a" && [ "$(dpkg --print-architecture)" != "$a" ]; then
    say "adding the dpkg architecture '$a' (dpkg --add-architecture $a) for the cross-build libraries"
    as_root dpkg --add-architecture "$a"
    added_arch=1
  fi
done
if [ ${#missing[@]} -gt 0 ] || [ "$added_arch" = 1 ]; then
  say "installing ${missing[*]:-(package lists only)}"
  as_root apt-get update -qq || say "apt-get update reported errors; trying the install anyway"
  if [ ${#missing[@]} -gt 0 ]; then
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  fi
fi

# bitbake's sanity check wants the en_US.UTF-8 locale.
if [ "$need_locale" = 1 ] && ! locale -a 2>/dev/null | grep -qix 'en_US.utf-\?8'; then
  say "generating the en_US.UTF-8 locale (bitbake's sanity check needs it)"
  as_root sed -i 's/^# *\(en_US.UTF-8 UTF-8\)/\1/' /etc/locale.gen
  as_root locale-gen >/dev/null
fi

# Catch2 3 (trixie) is a static library installed at /usr/lib without a
# multiarch path, so the build machine's and the target's cannot be installed
# side by side. The target's package is unpacked under build/cross-deps/<arch>,
# where cmake/toolchains/debian-multiarch-common.cmake finds it.
for a in "${cross_catch2[@]}"; do
  version=$(apt-cache policy "libcatch2-dev:$a" | awk '/Candidate:/ {print $2}')
  dir=build/cross-deps/$a
  [ -f "$dir/.version" ] && [ "$(cat "$dir/.version")" = "$version" ] && continue
  say "unpacking libcatch2-dev:$a $version into $dir (the test library of the $a build)"
  tmp=$(mktemp -d)
  (cd "$tmp" && apt-get download -qq "libcatch2-dev:$a" 2>/dev/null) ||
    { say "cannot download libcatch2-dev:$a (apt-get download)"; rm -rf "$tmp"; exit 1; }
  rm -rf "$dir" && mkdir -p "$dir"
  dpkg-deb -x "$tmp"/libcatch2-dev_*_"$a".deb "$dir"
  echo "$version" >"$dir/.version"
  rm -rf "$tmp"
done
exit 0
