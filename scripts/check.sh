#!/usr/bin/env bash
# The whole test suite, as CI runs it: installs what is missing, then builds
# and tests (1) natively with AddressSanitizer + UBSan, (2) cross-compiled
# for aarch64 with the tests run under qemu-aarch64, and (3) the commands the
# README and docs/ show, run with the release gyrotc (ctest -L docs). The
# statistical sweeps (label sweep) are left to scripts/sweeps.sh. Warnings
# are errors in (1) and (2). Exits non-zero if anything fails. Build trees:
# build/debug-asan, build/aarch64, build/release.
set -euo pipefail
cd "$(dirname "$0")/.."

scripts/deps.sh native aarch64
jobs=${JOBS:-$(nproc)}
status=0

# Each stage's wall time is printed: the whole must stay within 45 min on
# two cores, and the log shows where it goes; with the compiler cache (the
# presets use ccache when it is installed, scripts/ccache-stats.sh) each
# build's hit rate too.
run_preset() {
  local preset=$1 start=$SECONDS stats
  echo "=== [$preset] configure + build"
  cmake --preset "$preset" >/dev/null
  stats=$(scripts/ccache-stats.sh snapshot)
  cmake --build --preset "$preset" -j "$jobs"
  echo "=== [$preset] tests (the build took $((SECONDS - start)) s$(scripts/ccache-stats.sh since "$stats"))"
  start=$SECONDS
  ctest --preset "$preset" -j "$jobs" || status=1
  echo "=== [$preset] the tests took $((SECONDS - start)) s"
}

run_preset debug-asan
run_preset aarch64
echo "=== aarch64 test binary: $(file -b build/aarch64/tests/test_app_csv | cut -d, -f1-2)"

echo "=== [release] the documented commands"
cmake --preset release >/dev/null
stats=$(scripts/ccache-stats.sh snapshot)
targets=(gyrotc)
if cmake --build --preset release --target help | grep 'gyrotc-emu$' >/dev/null; then targets+=(gyrotc-emu); fi
cmake --build --preset release -j "$jobs" --target "${targets[@]}"
echo "=== [release] built$(scripts/ccache-stats.sh since "$stats")"
ctest --preset release -L docs || status=1
echo "=== check.sh: $SECONDS s in all"
exit $status
