#!/usr/bin/env bash
# The statistical sweeps, in one command: the test cases tagged [sweep]
# (ctest label sweep), each a property checked over many simulated records:
# that the estimators' standard errors match their scatter, that their
# intervals cover the truth, that a null is rarely flagged. They are not part
# of scripts/check.sh (under the sanitizers and under QEMU they took a third
# and a half of its test time); .ci/run runs them after it. Installs what is
# missing, builds the release test executables that hold them (target
# sweep_tests) and runs them natively (`ctest --preset sweep`). Exits non-zero
# if any fails.
#
# Usage: scripts/sweeps.sh [--no-deps]
#   --no-deps   do not run scripts/deps.sh
# Env: JOBS (default nproc). Build tree: build/release.
# Under QEMU, after scripts/check.sh has built build/aarch64:
#   ctest --preset aarch64-sweep
set -euo pipefail
cd "$(dirname "$0")/.."

deps=1
while [ $# -gt 0 ]; do
  case "$1" in
    --no-deps) deps=0; shift ;;
    -h|--help) sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "sweeps.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
jobs=${JOBS:-$(nproc)}

if [ "$deps" = 1 ]; then scripts/deps.sh native; fi
echo "=== [release] configure + build sweep_tests"
cmake --preset release >/dev/null
cmake --build --preset release -j "$jobs" --target sweep_tests
echo "=== [release] the statistical sweeps"
ctest --preset sweep -j "$jobs" --no-tests=error
