#!/usr/bin/env bash
# The hostile-ADS1251 run: `gyrotc run` on the simulated board in
# real time at 1 kSPS, with the simulated reader's timing randomised on top of
# this host's own latency: wake-ups 0-300 us after the DRDY edge, 2 % of them
# stalls of up to 3 ms (past the 937.5 us DOUT mode), edge events delivered up
# to 40 us late and stamped up to 40 us late (the driver told so:
# stamp_latency_max_s), SPI messages starting up to 100 us late and returning up to
# 50 us after their last clock. Passes when no corrupted sample reached the
# controller and every corrupted transfer was counted as a late read; prints
# the counts of the run's summary (--summary-json).
#
# Usage: scripts/hostile_adc.sh [--duration S] [--gyrotc PATH] [--out DIR]
#   --duration S   seconds of the run (default 600)
#   --gyrotc PATH  the executable (default build/release/app/gyrotc, else
#                  build/debug-asan/app/gyrotc, else gyrotc on PATH)
#   --out DIR      configuration, log and summary (default build/hostile-adc)
# Needs jq. Runs with --allow-non-rt where SCHED_FIFO is not permitted. The
# short version is a test: tests/integration/faults/hostile_adc_test.cpp.
set -euo pipefail
cd "$(dirname "$0")/.."

duration=600
gyrotc=
out=build/hostile-adc
while [ $# -gt 0 ]; do
  case "$1" in
    --duration) duration=$2; shift 2 ;;
    --gyrotc) gyrotc=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    -h|--help) sed -n '2,19p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "hostile_adc.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
if [ -z "$gyrotc" ]; then
  for candidate in build/release/app/gyrotc build/debug-asan/app/gyrotc; do
    if [ -x "$candidate" ]; then gyrotc=$candidate; break; fi
  done
  [ -n "$gyrotc" ] || gyrotc=$(command -v gyrotc || true)  # an installed one
fi
[ -n "$gyrotc" ] && [ -x "$gyrotc" ] || { echo "hostile_adc.sh: no gyrotc executable; build first or pass --gyrotc" >&2; exit 2; }
command -v jq >/dev/null || { echo "hostile_adc.sh: needs jq (apt install jq)" >&2; exit 2; }
mkdir -p "$out"

config=$out/gyrotc-hostile.toml
sed -e 's/^adc_wake_min_us = .*/adc_wake_min_us = 0.0/' \
    -e 's/^adc_wake_max_us = .*/adc_wake_max_us = 300.0/' \
    -e 's/^adc_stall_probability = .*/adc_stall_probability = 0.02/' \
    -e 's/^adc_stall_max_us = .*/adc_stall_max_us = 3000.0/' \
    -e 's/^adc_irq_delay_max_us = .*/adc_irq_delay_max_us = 40.0/' \
    -e 's/^adc_stamp_delay_max_us = .*/adc_stamp_delay_max_us = 40.0/' \
    -e 's/^stamp_latency_max_s = .*/stamp_latency_max_s = 0.00004/' \
    -e 's/^adc_spi_start_max_us = .*/adc_spi_start_max_us = 100.0/' \
    -e 's/^adc_spi_return_max_us = .*/adc_spi_return_max_us = 50.0/' \
    -e 's/^stream = .*/stream = "none"/' \
    -e 's/^status_interval_s = .*/status_interval_s = 60.0/' \
    deploy/config/gyrotc-sim.toml > "$config"
grep -q '^adc_stall_probability = 0.02' "$config" || { echo "hostile_adc.sh: could not set the [sim] adc keys" >&2; exit 2; }
# The configuration names its calibration relative to itself.
cp deploy/config/calibration.toml "$out/calibration.toml"

summary=$out/summary.json
echo "hostile_adc.sh: $gyrotc run, ${duration} s at 1 kSPS; log in $out/run.log" >&2
rc=0
"$gyrotc" run --config "$config" --duration "$duration" --allow-non-rt --summary-json "$summary" 2> "$out/run.log" || rc=$?
if [ "$rc" -ne 0 ]; then
  echo "hostile_adc.sh: '$gyrotc run --config $config' failed (exit $rc); the end of $out/run.log:" >&2
  tail -n 5 "$out/run.log" >&2
  exit "$rc"
fi

jq -r '"samples accepted        \(.sim_adc.accepted_samples)",
       "  of them corrupted     \(.sim_adc.accepted_corrupted_samples)",
       "conversions             \(.sim_adc.conversions)",
       "transfers               \(.sim_adc.transfers)",
       "  corrupted (truth)     \(.sim_adc.corrupted_transfers)",
       "late reads (driver)     \(.late_reads)",
       "missed conversions      \(.missed_conversions)",
       "spurious edges          \(.spurious_edges)",
       "DRDY timeouts           \(.adc_timeouts)",
       "overruns                \(.overruns)",
       "SCHED_FIFO              \(.realtime)",
       "latency us p50/p99/max  \(.latency_us.p50 | round)/\(.latency_us.p99 | round)/\(.latency_us.max | round)"' "$summary"
if jq -e '.sim_adc.accepted_corrupted_samples == 0 and .late_reads >= .sim_adc.corrupted_transfers' "$summary" >/dev/null; then
  echo "PASS: no corrupted sample accepted; every corrupted transfer counted as a late read"
else
  echo "FAIL: see $summary" >&2
  exit 1
fi
