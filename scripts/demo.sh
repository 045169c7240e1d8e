#!/usr/bin/env bash
# The main job: installs what is missing, builds gyrotc (native release) and
# runs the closed-loop chamber simulation of the seed's Fig. 26 (the seed's
# controller on the simulated board), printing the summary and where the
# time series and the plot are.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/deps.sh native
cmake --preset release >/dev/null
cmake --build --preset release -j "${JOBS:-$(nproc)}" --target gyrotc
build/release/app/gyrotc --version
out=build/release/simulate-fig26
build/release/app/gyrotc simulate --profile fig26 --controller paper --out "$out" --plot "$out/fig26.svg"
