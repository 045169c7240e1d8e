#!/usr/bin/env bash
# The main job: installs what is missing, builds gyrotc (native release) and
# runs it.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/deps.sh native
cmake --preset release >/dev/null
cmake --build --preset release -j "${JOBS:-$(nproc)}" --target gyrotc
build/release/app/gyrotc --version
build/release/app/gyrotc --help
