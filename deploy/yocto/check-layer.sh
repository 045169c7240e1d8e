#!/usr/bin/env bash
# Checks meta-gyrotc with a real bitbake: given checkouts of bitbake,
# openembedded-core and meta-openembedded of one release series, it makes a
# throw-away build directory (MACHINE qemuarm64, systemd, ptest; no libgpiod
# pin), then
#   1. bitbake -p            parses every recipe of the three layers and ours;
#   2. bitbake -n gyrotc     resolves gyrotc's whole task graph (a dry run: nothing
#                            is fetched or built);
#   3. bitbake -e            reports the variables QA and packaging depend on:
#                            gyrotc's LICENSE, LIC_FILES_CHKSUM, DEPENDS, RRECOMMENDS,
#                            PACKAGECONFIG, REQUIRED_DISTRO_FEATURES, the libgpiod,
#                            catch2 and tomlplusplus versions and recipe files chosen,
#                            and whether buildpaths is an error or a warning.
# It exits non-zero if any step fails. No network is needed (BB_NO_NETWORK).
#
# Usage: deploy/yocto/check-layer.sh BITBAKE OE_CORE META_OE [--keep]
#   e.g. for scarthgap: bitbake 2.8, openembedded-core and meta-openembedded
#   branch scarthgap; for walnascar: bitbake 2.12 and branch walnascar.
#   --keep  keep the build directory (printed) instead of removing it
# Needs the host tools OE's sanity check asks for (scripts/deps.sh yocto) and an
# en_US.UTF-8 locale. bitbake refuses to run as root: as root the script runs it
# as the unprivileged user nobody.
set -euo pipefail

usage() { sed -n '2,24p' "$0" | sed 's/^# \{0,1\}//'; }
[ "${1:-}" = -h ] || [ "${1:-}" = --help ] && { usage; exit 0; }
if [ $# -lt 3 ]; then
  echo "check-layer.sh: needs the bitbake, openembedded-core and meta-openembedded checkouts (see --help)" >&2
  exit 2
fi
abs() { (cd "$1" && pwd); }
bitbake_dir=$(abs "$1")
oe_core=$(abs "$2")
meta_oe=$(abs "$3")
keep=${4:-}
layer=$(abs "$(dirname "$0")/meta-gyrotc")
for f in "$bitbake_dir/bin/bitbake" "$oe_core/meta/conf/layer.conf" "$meta_oe/meta-oe/conf/layer.conf"; do
  [ -e "$f" ] || { echo "check-layer.sh: $f not found: wrong checkout?" >&2; exit 2; }
done

build=$(mktemp -d /tmp/gyrotc-check-layer.XXXXXX)
cleanup() { [ "$keep" = --keep ] && echo "build directory kept: $build" || rm -rf "$build"; }
trap cleanup EXIT
mkdir -p "$build/conf"
cat >"$build/conf/bblayers.conf" <<EOF
POKY_BBLAYERS_CONF_VERSION = "2"
BBPATH = "\${TOPDIR}"
BBFILES ?= ""
BBLAYERS = "$oe_core/meta $meta_oe/meta-oe $layer"
EOF
cat >"$build/conf/local.conf" <<EOF
MACHINE = "qemuarm64"
DISTRO_FEATURES:append = " systemd usrmerge ptest"
INIT_MANAGER = "systemd"
VIRTUAL-RUNTIME_init_manager = "systemd"
PACKAGE_CLASSES = "package_ipk"
BB_NO_NETWORK = "1"
CONNECTIVITY_CHECK_URIS = ""
BB_NUMBER_THREADS = "2"
PARALLEL_MAKE = "-j 2"
EOF

# bitbake as an unprivileged user: nobody, when run as root.
as_user=()
if [ "$(id -u)" -eq 0 ]; then
  chown -R nobody:nogroup "$build"
  as_user=(setpriv --reuid=nobody --regid=nogroup --clear-groups)
fi
bb() {
  (cd "$build" && env -i HOME="$build" LANG=en_US.UTF-8 LC_ALL=en_US.UTF-8 \
     PATH="$bitbake_dir/bin:$oe_core/scripts:/usr/sbin:/usr/bin:/sbin:/bin" BBPATH="$build" \
     "${as_user[@]}" "$bitbake_dir/bin/bitbake" "$@")
}
series=$(sed -n 's/^LAYERSERIES_CORENAMES *= *"\([^"]*\)".*/\1/p' "$oe_core/meta/conf/layer.conf")
echo "=== check-layer: bitbake $(git -C "$bitbake_dir" describe --always 2>/dev/null || echo '?'), openembedded-core series '$series'"

echo "=== 1. bitbake -p (parse)"
bb -p 2>&1 | tail -n 5
echo "=== 2. bitbake -n gyrotc (dry run of the task graph)"
bb -n gyrotc 2>&1 | tail -n 5

echo "=== 3. variables"
bb -e gyrotc >"$build/gyrotc.env" 2>&1
value() { sed -n "s/^$1=\"\(.*\)\"$/\1/p" "$2" | tr -s ' ' | sed 's/^ //; s/ $//'; }
for v in LICENSE LIC_FILES_CHKSUM DEPENDS PACKAGECONFIG REQUIRED_DISTRO_FEATURES \
         "RRECOMMENDS:gyrotc" PTEST_PATH ERROR_QA WARN_QA; do
  val=$(value "$v" "$build/gyrotc.env")
  case "$v" in
    ERROR_QA | WARN_QA) echo "$v has buildpaths: $(echo " $val " | grep -q ' buildpaths ' && echo yes || echo no)" ;;
    *) echo "$v = $val" ;;
  esac
done
for r in libgpiod catch2 tomlplusplus; do
  bb -e "$r" >"$build/$r.env" 2>&1
  echo "$r: PV $(value PV "$build/$r.env"), $(value FILE "$build/$r.env" | sed "s#^$meta_oe/##; s#^$layer/#meta-gyrotc/#")"
done
license=$(value LICENSE "$build/gyrotc.env")
[ "$license" = Apache-2.0 ] || { echo "check-layer.sh: gyrotc's LICENSE is '$license'" >&2; exit 1; }
echo "=== check-layer: OK ($series)"
