#!/usr/bin/env bash
# Regenerates every picture in the docs from the commands the docs show, so a
# figure cannot go stale silently: builds gyrotc and tune_suite (release
# preset), runs them, and writes docs/figures/*.svg and docs/tuning/ (with
# docs/TUNING.md's generated section). Prints each command before it runs it;
# on a failure, prints the command and the last lines of its output and exits
# non-zero. About 2 minutes after the build.
#   scripts/docs-figures.sh            regenerate
#   scripts/docs-figures.sh --help     this text
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ ${1:-} == -h || ${1:-} == --help ]]; then
  sed -n '2,9p' "$0" | sed 's/^# \{0,1\}//'
  exit 0
fi
if [[ $# -gt 0 ]]; then
  echo "docs-figures.sh: unknown argument '$1' (see --help)" >&2
  exit 2
fi

cmake --preset release >/dev/null
cmake --build --preset release -j "${JOBS:-$(nproc)}" --target gyrotc tune_suite >/dev/null
root=$PWD
gyrotc=$root/build/release/app/gyrotc
work=$PWD/build/release/docs-figures
figures=$PWD/docs/figures
rm -rf "$work"
mkdir -p "$work" "$figures"
cd "$work"

step() {
  echo "+ $*"
  if ! "$@" >"$work/last.log" 2>&1; then
    echo "docs-figures.sh: failed: $*" >&2
    tail -n 20 "$work/last.log" >&2
    exit 1
  fi
}

# README and the guide's simulate section: the main job, and the two controllers compared.
step "$gyrotc" simulate --profile fig26 --controller tuned --out tuned
step "$gyrotc" simulate --profile fig26 --controller paper --out paper --plot "$figures/fig26.svg"
step "$gyrotc" simulate --profile fig26 --controller paper --out paper --plot "$figures/fig26-vs-tuned.svg" --compare tuned

# The guide's fit section: the calibration report of the paper's Table 2.
step "$gyrotc" fit --data "$root/data/table2_zero_bias.csv" --method auto --plot "$figures/fit-table2.svg"

# The guide's allan section: the compensated rate with the loop on.
printf "time_s,ambient_c\n0,25\n1500,25\n" > flat.csv
step "$gyrotc" simulate --profile flat.csv --controller paper --sample-rate-hz 100 \
  --rate-csv rate_on.csv --rate-window 900:1500
step "$gyrotc" allan --data rate_on.csv --plot "$figures/allan.svg"

# docs/SELFCAL.md: the self-calibration sweep at 20 C and the calibration it gives.
step "$gyrotc" simulate --profile selfcal --ambient-c 20 --out selfcal --plot "$figures/selfcal.svg"
step "$gyrotc" calibrate --data selfcal/record.csv --out selfcal.toml --plot "$figures/selfcal-fit.svg"

# The guide's tune section: the identification experiment and the model fitted to it.
step "$gyrotc" simulate --profile tune --out tune
step "$gyrotc" tune --data tune/record.csv --out controller.toml --plot "$figures/tune.svg"

# The guide's identify example: a die lagging the casing by a further 300 s.
printf "time_s,ambient_c\n0,25\n1800,25\n3000,45\n4800,45\n7200,5\n9000,5\n10200,25\n12000,25\n" > ramps.csv
printf "[effects.thermal_lag]\ntau_s = 300\n" > hidden.toml
: > base.toml
step "$gyrotc" simulate --profile ramps.csv --controller off --plant hidden.toml --sample-rate-hz 100 --out meas/
step "$gyrotc" identify --data meas/simulation.csv --plant base.toml --report report/ --out-plant found.toml
cp report/plot.svg "$figures/identify.svg"

# docs/TUNING.md's generated section and docs/tuning/*.svg. The suite exits 1
# when a variant the physics can hold fails a criterion: its table says which,
# and the figures are written all the same; any other failure stops here.
cd - >/dev/null
echo "+ build/release/tools/tune_suite --random 30 --network 24 --seed 77"
suite_status=0
build/release/tools/tune_suite --random 30 --network 24 --seed 77 >"$work/last.log" 2>&1 || suite_status=$?
if [[ $suite_status -eq 1 ]]; then
  echo "docs-figures.sh: tune_suite: not every feasible variant passes (docs/TUNING.md's table says which)"
elif [[ $suite_status -ne 0 ]]; then
  echo "docs-figures.sh: failed: build/release/tools/tune_suite --random 30 --network 24 --seed 77" >&2
  tail -n 20 "$work/last.log" >&2
  exit 1
fi

echo "docs-figures.sh: wrote $(ls "$figures" | wc -l) figures in docs/figures/ and docs/tuning/ (git diff shows what changed)"
