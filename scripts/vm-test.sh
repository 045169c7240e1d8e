#!/usr/bin/env bash
# The virtual board: the gyrotc DEB, built as for the board, installed with apt
# in a minimal Debian root (systemd as init, Debian's kernel) booted under
# qemu-system-<arch> without KVM, and checked there (scripts/vm/guest-checks.sh):
# the unit under systemd (sysusers, READY=1, SCHED_FIFO and locked memory, no
# sandbox denial over 30 s, watchdog, reload, crash -> safe-off -> restart,
# stop, where outputs may go) and the libgpiod back-end against the kernel's
# gpio-sim driver, built out of tree for that kernel (tools/gpiosim_check.cpp).
# One PASS/FAIL line per check, then "vm-test: N/M passed"; exit 0 only if all
# passed. Everything comes from the Debian archive; the build chroot, the root
# and its kernel are cached between runs. Needs root (mmdebstrap, chroot) and,
# for a foreign architecture, qemu-user through binfmt_misc.
set -euo pipefail
cd "$(dirname "$0")/.."
src=$PWD

usage() {
  cat <<'EOF'
Usage: scripts/vm-test.sh [aarch64|amd64] [options]

Builds the gyrotc DEB for the architecture (default aarch64, cross-built) in a
Debian build chroot, a minimal Debian root of the same release with systemd
and Debian's kernel, gpio-sim for that kernel, boots it under qemu-system-<arch>
(TCG, serial console, no network) and runs the checks of
scripts/vm/guest-checks.sh there. Prints one PASS/FAIL line per check and
"vm-test: N/M passed"; exit status 0 only if all passed.

Options:
  --suite trixie|bookworm  Debian release of the build chroot and the root
                           (default trixie: libgpiod 2.x; bookworm: libgpiod 1.6)
  --cache DIR              where the build chroot, the root and the kernel are kept
                           between runs (default build/vm-test)
  --refresh                rebuild the cached build chroot and root from the archive
  --timeout MIN            give up on the VM after MIN minutes (default 40)
  --guest-script FILE      run FILE in the VM instead of scripts/vm/guest-checks.sh
                           (development: it gets the same /vmtest folder)
  -h, --help               this text

Environment: GYROTC_VM_MIRROR (default http://deb.debian.org/debian) and
GYROTC_VM_SECURITY_MIRROR (default http://deb.debian.org/debian-security).
The first run downloads about 600 MB and takes 15-40 min on 2 cores; later runs
rebuild only what changed and boot the cached root. Logs: <cache>/logs/; what the
guest saw (its journal, the emulator's event log, the records): <cache>/run-*/artifacts/.
EOF
}

arch=aarch64 suite=trixie cache=build/vm-test refresh=0 timeout_min=40 guest_script=scripts/vm/guest-checks.sh
while [ $# -gt 0 ]; do
  case "$1" in
    aarch64 | amd64) arch=$1 ;;
    --suite) suite=${2:?--suite needs trixie or bookworm}; shift ;;
    --cache) cache=${2:?--cache needs a folder}; shift ;;
    --refresh) refresh=1 ;;
    --timeout) timeout_min=${2:?--timeout needs minutes}; shift ;;
    --guest-script) guest_script=${2:?--guest-script needs a file}; shift ;;
    -h | --help) usage; exit 0 ;;
    *) echo "vm-test: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
  shift
done
case "$suite" in trixie | bookworm) ;; *) echo "vm-test: --suite must be trixie or bookworm, not '$suite'" >&2; exit 2 ;; esac
[[ "$timeout_min" =~ ^[0-9]+$ ]] && [ "$timeout_min" -gt 0 ] || { echo "vm-test: --timeout wants whole minutes, got '$timeout_min'" >&2; exit 2; }
[ -f "$guest_script" ] || { echo "vm-test: --guest-script '$guest_script': no such file" >&2; exit 2; }

case "$arch" in
  aarch64) debarch=arm64 triple=aarch64-linux-gnu karch=arm64 qemu=qemu-system-aarch64 console=ttyAMA0
           machine=(-M virt -cpu cortex-a72) toolchain=/src/cmake/toolchains/aarch64-linux-gnu.cmake ;;
  amd64) debarch=amd64 triple=x86_64-linux-gnu karch=x86 qemu=qemu-system-x86_64 console=ttyS0
         machine=(-M q35 -cpu max) toolchain= ;;
esac
mirror=${GYROTC_VM_MIRROR:-http://deb.debian.org/debian}
security=${GYROTC_VM_SECURITY_MIRROR:-http://deb.debian.org/debian-security}
sources=("deb $mirror $suite main" "deb $mirror $suite-updates main" "deb $security $suite-security main")

t0=$SECONDS
say() { echo "vm-test: $* [$(((SECONDS - t0) / 60))m$(((SECONDS - t0) % 60))s]" >&2; }
mapfile -t plan < <(bash "$guest_script" --plan | sed -n 's/^vm-test: plan //p' | tr ' ' '\n')
# A step on this machine failed: that check fails, the VM never runs.
die() {
  echo "FAIL $1: $2"
  [ -n "${3:-}" ] && [ -f "$3" ] && tail -25 "$3" | sed 's/^/    /'
  echo "vm-test: 0/${#plan[@]} passed ($arch, $suite; stopped before the VM: $1)"
  exit 1
}

[ "$(id -u)" -eq 0 ] || { echo "vm-test: needs root (mmdebstrap, chroot): sudo $0 $*" >&2; exit 2; }
scripts/deps.sh vm

mkdir -p "$cache/logs"
cache=$(cd "$cache" && pwd)
logs=$cache/logs
bc=$cache/$suite-build-$(dpkg --print-architecture)-$debarch   # the build chroot
rd=$cache/$suite-$debarch                                        # the root, its kernel and gpio-sim
say "$arch, Debian $suite; cache $cache; load average $(cut -d' ' -f1-3 /proc/loadavg)"

# --- a foreign root needs qemu-user through binfmt_misc -------------------------
host_arch=$(dpkg --print-architecture)
if [ "$debarch" != "$host_arch" ] && ! arch-test "$debarch" >/dev/null 2>&1; then
  # What systemd-binfmt does at boot, for machines without it (containers).
  say "registering qemu-user for $debarch with binfmt_misc (/usr/lib/binfmt.d/qemu-$arch.conf)"
  mountpoint -q /proc/sys/fs/binfmt_misc || mount -t binfmt_misc binfmt_misc /proc/sys/fs/binfmt_misc 2>/dev/null || true
  [ -e "/proc/sys/fs/binfmt_misc/qemu-$arch" ] ||
    cat "/usr/lib/binfmt.d/qemu-$arch.conf" >/proc/sys/fs/binfmt_misc/register 2>/dev/null || true
  arch-test "$debarch" >/dev/null 2>&1 ||
    die binfmt "this machine cannot run $debarch programs through qemu-user (binfmt_misc: $(ls /proc/sys/fs/binfmt_misc 2>&1 | tr '\n' ' ')); mmdebstrap needs that for the $debarch root"
fi

in_chroot() { env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin HOME=/root LANG=C.UTF-8 DEBIAN_FRONTEND=noninteractive chroot "$bc" "$@"; }
# A cached tree to rebuild: an mmdebstrap killed mid-run leaves its proc, sys
# and dev mounts inside, and rm -rf must never follow them out of the tree.
remove_tree() {
  awk -v d="$1/" 'index($2, d) == 1 {print $2}' /proc/mounts | sort -r | while read -r m; do umount -l "$m"; done
  rm -rf --one-file-system "$1"
}
stamp_ok() { [ "$refresh" = 0 ] && [ -f "$1/.vm-test-stamp" ] && [ "$(cat "$1/.vm-test-stamp")" = "$2" ]; }

# --- 1. the build chroot ------------------------------------------------------------
build_pkgs=(cmake make pkg-config file dpkg-dev xz-utils kmod libeigen3-dev libcli11-dev nlohmann-json3-dev)
if [ "$debarch" = "$host_arch" ]; then
  build_archs=$host_arch
  build_pkgs+=(g++ libgpiod-dev libtomlplusplus-dev libfuse3-dev)
else
  build_archs=$host_arch,$debarch
  build_pkgs+=("g++-$triple" "libgpiod-dev:$debarch" "libtomlplusplus-dev:$debarch" "libfuse3-dev:$debarch")
fi
stamp="$suite $build_archs ${build_pkgs[*]} ${sources[*]}"
if ! stamp_ok "$bc" "$stamp"; then
  say "[1/5] build chroot: mmdebstrap $suite ($build_archs) -> $bc (log: $logs/build-chroot.log)"
  remove_tree "$bc"
  mmdebstrap --variant=apt --architectures="$build_archs" --include="$(IFS=,; echo "${build_pkgs[*]}")" \
    "$suite" "$bc" "${sources[@]}" >"$logs/build-chroot.log" 2>&1 || die build-chroot "mmdebstrap failed" "$logs/build-chroot.log"
  echo "$stamp" >"$bc/.vm-test-stamp"
else
  say "[1/5] build chroot: cached ($bc)"
fi
cp /etc/resolv.conf "$bc/etc/resolv.conf" 2>/dev/null || true
in_chroot apt-get update -qq >"$logs/apt-update.log" 2>&1 || die build-chroot "apt-get update in the build chroot failed" "$logs/apt-update.log"

# The root's packages: systemd as init, the tools the checks use, and the
# run-time libraries of the -dev packages gyrotc builds against (the DEB's
# Depends are checked against the root once it is built).
runtime_of() { in_chroot apt-cache show --no-all-versions "$1" | sed -n 's/^Depends: //p' | tr ',' '\n' | sed 's/[ (].*//;s/^ *//' | grep '^lib' | head -1; }
dev_arch=$([ "$debarch" = "$host_arch" ] && echo "" || echo ":$debarch")
root_pkgs=(systemd-sysv udev apt kmod gpiod procps adduser
           "$(runtime_of "libgpiod-dev$dev_arch")" "$(runtime_of "libtomlplusplus-dev$dev_arch")"
           "$(runtime_of "libfuse3-dev$dev_arch")")
kmeta=linux-image-$debarch
kimg=$(in_chroot apt-cache depends "$kmeta$dev_arch" | sed -n 's/^ *Depends: \(linux-image-[^: ]*\).*/\1/p' | head -1)
[ -n "$kimg" ] || die kernel "no kernel package behind $kmeta in $suite"
kver=${kimg#linux-image-}
# Bump root_format when the recipe below changes in a way the stamp does not show.
root_format=1
root_stamp="$root_format $suite $debarch ${root_pkgs[*]} $kimg ${sources[*]}"

# --- 2. the root (in the background) and the DEB ---------------------------------------
root_pid=
if ! stamp_ok "$rd" "$root_stamp"; then
  say "[2/5] root: mmdebstrap $suite $debarch (${root_pkgs[*]}) in the background (log: $logs/root.log)"
  remove_tree "$rd" && mkdir -p "$rd"
  mmdebstrap --variant=minbase --architectures="$debarch" --include="$(IFS=,; echo "${root_pkgs[*]}")" \
    --customize-hook='echo vmboard >"$1/etc/hostname"' \
    "$suite" "$rd/root" "${sources[@]}" >"$logs/root.log" 2>&1 &
  root_pid=$!
else
  say "[2/5] root: cached ($rd, kernel $kver)"
fi

say "[3/5] DEB: cmake + cpack in the build chroot (log: $logs/build.log)"
# The sources into the chroot for an incremental build: a file whose content
# changed gets the copy time as its mtime (make must rebuild what uses it, even
# if it was edited while an earlier build ran), an unchanged one keeps the
# previous copy's; files gone from the tree go from the copy.
rm -rf "$bc/src.new" && mkdir -p "$bc/src.new" "$bc/src"
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  # Tracked and new files of the work tree as they are now (uncommitted edits too).
  git ls-files -z -co --exclude-standard | while IFS= read -r -d '' f; do [ -e "$f" ] && printf '%s\0' "$f"; done |
    tar --null -T - -cf - | tar -xf - -C "$bc/src.new"
else
  tar --exclude=./build --exclude=./.git -cf - . | tar -xf - -C "$bc/src.new"
fi
(cd "$bc/src.new" && find . -type f -print0) | while IFS= read -r -d '' f; do
  if ! cmp -s "$bc/src.new/$f" "$bc/src/$f"; then
    mkdir -p "$bc/src/$(dirname "$f")"
    cp "$bc/src.new/$f" "$bc/src/$f" && chmod --reference="$bc/src.new/$f" "$bc/src/$f"
  fi
done
(cd "$bc/src" && find . -type f -print0) | while IFS= read -r -d '' f; do
  [ -e "$bc/src.new/$f" ] || rm -f "$bc/src/$f"
done
rm -rf "$bc/src.new"
in_chroot sh -ec "
  cmake -S /src -B /build -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX=/usr \
        -DGYROTC_BUILD_TESTS=OFF -DGYROTC_BUILD_BENCH=OFF ${toolchain:+-DCMAKE_TOOLCHAIN_FILE=$toolchain}
  cmake --build /build -j$(nproc)
  rm -f /build/gyrotc_*.deb /build/gyrotc-emu_*.deb
  cd /build && cpack -G DEB" >"$logs/build.log" 2>&1 || { [ -n "$root_pid" ] && kill "$root_pid" 2>/dev/null || true; die build "the DEB did not build" "$logs/build.log"; }
deb=$(cd "$bc/build" && ls gyrotc_*_"$debarch".deb)
emu_deb=$(cd "$bc/build" && ls gyrotc-emu_*_"$debarch".deb 2>/dev/null) ||
  die build "no gyrotc-emu package: the build did not find libfuse3 (see $logs/build.log)" "$logs/build.log"
say "      $deb: Depends: $(dpkg-deb -f "$bc/build/$deb" Depends)"
say "      $emu_deb: Depends: $(dpkg-deb -f "$bc/build/$emu_deb" Depends)"

# --- 4. Debian's kernel and gpio-sim built for it ------------------------------------------
if [ -n "$root_pid" ]; then
  say "[4/5] kernel $kimg and gpio-sim for it (log: $logs/kernel.log)"
  kpkgver=$(in_chroot apt-cache show --no-all-versions "$kimg$dev_arch" | sed -n 's/^Version: //p' | head -1)
  kheaders=linux-headers-$kver
  hdeps=$(in_chroot apt-cache show --no-all-versions "$kheaders$dev_arch" | sed -n 's/^Depends: //p' | head -1)
  kcommon=$(tr ',' '\n' <<<"$hdeps" | sed -n 's/^ *\(linux-headers-[^ ]*-common[^ ]*\).*/\1/p' | head -1)
  kbuild=$(tr ',' '\n' <<<"$hdeps" | sed -n 's/^ *\(linux-kbuild-[^ ]*\).*/\1/p' | head -1)
  kgcc=$(tr ',' '\n' <<<"$hdeps" | sed -n 's/^ *\(gcc-[0-9][0-9]*\).*/\1/p' | head -1)
  ksrc=linux-source-$(sed 's/^\([0-9]*\.[0-9]*\).*/\1/' <<<"$kver")
  cc_pkg=$([ "$debarch" = "$host_arch" ] && echo "$kgcc" || echo "$kgcc-$triple")
  cc=$([ "$debarch" = "$host_arch" ] && echo "$kgcc" || echo "$triple-$kgcc")
  [ -n "$kpkgver" ] && [ -n "$kcommon" ] && [ -n "$kbuild" ] && [ -n "$kgcc" ] ||
    die kernel "cannot resolve the headers of $kimg ($kpkgver): Depends '$hdeps'"
  in_chroot sh -ec "
    rm -rf /kernel && mkdir -p /kernel/image /kernel/gpio-sim && cd /kernel
    apt-get install -y -qq --no-install-recommends $kbuild $cc_pkg >/dev/null
    apt-get download -qq $kimg$dev_arch $kheaders$dev_arch $kcommon $ksrc=$kpkgver
    dpkg-deb -x ${kimg}_*.deb image
    dpkg-deb -x ${kcommon}_*.deb /
    dpkg-deb -x ${kheaders}_*.deb /
    depmod -b /kernel/image/usr $kver  # trixie kernels ship their modules under /usr/lib/modules
    # gpio-sim and the interrupt simulator it needs (Debian builds neither).
    dpkg-deb --fsys-tarfile ${ksrc}_*.deb | tar -xOf - ./usr/src/$ksrc.tar.xz | xz -dc |
      tar -xf - --strip-components=1 $ksrc/drivers/gpio/gpio-sim.c $ksrc/kernel/irq/irq_sim.c
    cp drivers/gpio/gpio-sim.c gpio-sim/gpio-sim-main.c
    # irq_to_desc() is not exported to modules; generic_handle_irq() does the same lookup.
    sed 's/handle_simple_irq(irq_to_desc(irqnum));/generic_handle_irq(irqnum);/' kernel/irq/irq_sim.c >gpio-sim/irq-sim.c
    grep -q 'generic_handle_irq(irqnum);' gpio-sim/irq-sim.c || { echo 'irq_sim.c: the irq_to_desc() call to replace is not there'; exit 1; }
    printf 'obj-m := gpio-sim.o\ngpio-sim-y := gpio-sim-main.o irq-sim.o\n' >gpio-sim/Kbuild
    make -C /usr/src/$kheaders M=/kernel/gpio-sim ARCH=$karch CROSS_COMPILE=${triple}- CC=$cc modules
    rm -f *.deb" >"$logs/kernel.log" 2>&1 || { kill "$root_pid" 2>/dev/null || true; die kernel "the kernel or gpio-sim failed" "$logs/kernel.log"; }
  say "      waiting for the root (log: $logs/root.log)"
  wait "$root_pid" || die root "mmdebstrap of the $debarch root failed" "$logs/root.log"
  # Debian's kernel, unpacked here (its modules in the root), no initramfs
  # tool run under emulation: the whole root is the initramfs.
  cp "$bc/kernel/image/boot/vmlinuz-$kver" "$rd/vmlinuz"
  mkdir -p "$rd/root/usr/lib/modules"  # else cp makes the version folder itself .../modules
  cp -a "$bc/kernel/image/usr/lib/modules/$kver" "$rd/root/usr/lib/modules/"
  cp "$bc/kernel/gpio-sim/gpio-sim.ko" "$rd/gpio-sim.ko"
  echo "$kimg $kpkgver" >"$rd/kernel"
  cp "$rd/root/var/lib/dpkg/status" "$rd/dpkg-status"
  (cd "$rd/root" && find . -print0 | cpio --null -o -H newc --quiet) >"$rd/root.cpio"
  rm -rf "$rd/root" "$bc/kernel"
  echo "$root_stamp" >"$rd/.vm-test-stamp"
  say "      root.cpio $(du -m "$rd/root.cpio" | cut -f1) MB, $(cat "$rd/kernel")"
else
  say "[4/5] kernel and gpio-sim: cached ($(cat "$rd/kernel"))"
fi

# Every dependency of the DEB must be in the root: there is no network in the VM.
missing=()
for dep in $( (dpkg-deb -f "$bc/build/$deb" Depends; echo ,; dpkg-deb -f "$bc/build/$emu_deb" Depends) | tr ',' '\n' | sed 's/[ (|].*//;s/^ *//'); do
  grep -qx "Package: $dep" "$rd/dpkg-status" || missing+=("$dep")
done
[ ${#missing[@]} -eq 0 ] || die deb-install "the root lacks ${missing[*]} that $deb depends on (the VM has no network): rerun with --refresh"

# --- 5. boot it and run the checks -----------------------------------------------------------
run=$cache/run-$suite-$debarch
rm -rf "$run" && mkdir -p "$run/cpio/vmtest" "$run/cpio/etc/systemd/system/multi-user.target.wants" "$run/artifacts"
cp "$guest_script" "$run/cpio/vmtest/run"
cp "$bc/build/$deb" "$bc/build/$emu_deb" "$bc/build/tools/gpiosim_check" "$rd/gpio-sim.ko" "$run/cpio/vmtest/"
printf 'DEB=%s\nEMU_DEB=%s\nGPIO_KO=/vmtest/gpio-sim.ko\nGPIOSIM_CHECK=gpiosim_check\nRUN_S=30\n' "$deb" "$emu_deb" \
  >"$run/cpio/vmtest/vm.env"
cat >"$run/cpio/etc/systemd/system/vmtest.service" <<'EOF'
[Unit]
Description=gyrotc virtual board checks (scripts/vm-test.sh)
After=multi-user.target
SuccessAction=poweroff-force
FailureAction=poweroff-force

[Service]
Type=oneshot
ExecStart=/bin/bash /vmtest/run
StandardOutput=tty
StandardError=tty
TTYPath=/dev/hvc0
TimeoutStartSec=infinity
EOF
ln -s ../vmtest.service "$run/cpio/etc/systemd/system/multi-user.target.wants/vmtest.service"
# No logins, and nothing that would reach for the network.
for u in getty-static.service apt-daily.timer apt-daily-upgrade.timer; do ln -s /dev/null "$run/cpio/etc/systemd/system/$u"; done
(cd "$run/cpio" && find . -print0 | cpio --null -o -H newc --quiet -R 0:0) >"$run/run.cpio"
cat "$rd/root.cpio" "$run/run.cpio" >"$run/initrd.cpio"

say "[5/5] booting $qemu ($(cat "$rd/kernel"), no KVM): console $run/console.log"
: >"$run/results.txt"
"$qemu" "${machine[@]}" -smp 2 -m 2048 -display none -no-reboot -nic none \
  -kernel "$rd/vmlinuz" -initrd "$run/initrd.cpio" \
  -append "rdinit=/sbin/init console=$console systemd.getty_auto=0 systemd.show_status=0" \
  -device virtio-serial-pci -chardev file,id=results,path="$run/results.txt" -device virtconsole,chardev=results \
  -virtfs local,path="$run/artifacts",mount_tag=artifacts,security_model=none,id=artifacts \
  -serial file:"$run/console.log" >"$run/qemu.log" 2>&1 &
qemu_pid=$!
trap 'kill $qemu_pid 2>/dev/null || true' EXIT
shown=0
deadline=$((SECONDS + timeout_min * 60))
timed_out=0
while :; do
  running=1
  kill -0 "$qemu_pid" 2>/dev/null || running=0
  # Results as they come (whole lines only), details included.
  lines=$(tr -d '\r' <"$run/results.txt" | wc -l)
  if [ "$lines" -gt "$shown" ]; then
    tr -d '\r' <"$run/results.txt" | sed -n "$((shown + 1)),${lines}p" | grep -v '^vm-test: plan ' || true
    shown=$lines
  fi
  [ "$running" = 0 ] && break
  if [ $SECONDS -ge $deadline ]; then
    timed_out=1
    kill "$qemu_pid" 2>/dev/null || true
    wait "$qemu_pid" 2>/dev/null || true
    break
  fi
  sleep 2
done
wait "$qemu_pid" 2>/dev/null || true
trap - EXIT
rm -f "$run/initrd.cpio"

results=$(tr -d '\r' <"$run/results.txt")
passed=0
for check in "${plan[@]}"; do
  if grep -q "^PASS $check:" <<<"$results"; then
    passed=$((passed + 1))
  elif ! grep -q "^FAIL $check:" <<<"$results"; then
    why=$([ "$timed_out" = 1 ] && echo "the VM ran out of time (--timeout $timeout_min)" || echo "the VM stopped first")
    echo "FAIL $check: no result: $why; see $run/console.log"
  fi
done
say "done; load average $(cut -d' ' -f1-3 /proc/loadavg); the guest's logs (journal, emulator events, records): $run/artifacts"
echo "vm-test: $passed/${#plan[@]} passed ($arch, Debian $suite, $(cut -d' ' -f1 "$rd/kernel" | sed 's/linux-image-//'), $(((SECONDS - t0) / 60)) min $(((SECONDS - t0) % 60)) s)"
[ "$passed" -eq "${#plan[@]}" ]
