#!/usr/bin/env bash
# The whole test suite, as CI runs it: installs what is missing, then builds
# and tests (1) natively with AddressSanitizer + UBSan and (2) cross-compiled
# for aarch64 with the tests run under qemu-aarch64. Warnings are errors.
# Exits non-zero if anything fails. Build trees: build/debug-asan, build/aarch64.
set -euo pipefail
cd "$(dirname "$0")/.."

scripts/deps.sh native aarch64
jobs=${JOBS:-$(nproc)}
status=0

run_preset() {
  local preset=$1
  echo "=== [$preset] configure + build"
  cmake --preset "$preset" >/dev/null
  cmake --build --preset "$preset" -j "$jobs"
  echo "=== [$preset] tests"
  ctest --preset "$preset" -j "$jobs" || status=1
}

run_preset debug-asan
run_preset aarch64
echo "=== aarch64 test binary: $(file -b build/aarch64/tests/test_app_csv | cut -d, -f1-2)"
exit $status
