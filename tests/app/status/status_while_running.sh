#!/usr/bin/env bash
# `gyrotc run` on the simulated board as an ordinary process, as a user starts
# it: `gyrotc status --json` gives the documented fields, a state in words and
# numeric temperatures and current, within seconds of the start; the
# Prometheus file parses with the Prometheus Python client's own parser, HELP
# and TYPE for every family; once the run ends, `gyrotc status` says no daemon
# runs (exit 1) and the metrics say gyrotc_up 0.
# Usage: status_while_running.sh GYROTC SOURCE_DIR WORK_DIR
set -euo pipefail
gyrotc=$1 src=$2 work=$3
# Debian's Python, where python3-prometheus-client installs (not a pyenv or venv first on PATH).
python3() { if [ -x /usr/bin/python3 ]; then /usr/bin/python3 "$@"; else command python3 "$@"; fi; }
python3 -c 'import prometheus_client.parser' 2>/dev/null || {
  echo "SKIPPED: python3-prometheus-client is not installed (scripts/deps.sh installs it): the metrics file is not parsed"
  exit 77
}
rm -rf "$work" && mkdir -p "$work"
cp "$src/deploy/config/gyrotc-sim.toml" "$src/deploy/config/calibration.toml" "$work/"
sed -i -e 's|^status_file = .*|status_file = "status.json"|' \
       -e 's|^# metrics_file = .*|metrics_file = "gyrotc.prom"|' "$work/gyrotc-sim.toml"
grep -q '^metrics_file = "gyrotc.prom"' "$work/gyrotc-sim.toml" || { echo "FAIL: gyrotc-sim.toml has no metrics_file line to enable"; exit 1; }

"$gyrotc" run --config "$work/gyrotc-sim.toml" --duration 12 --allow-non-rt >"$work/run.out" 2>"$work/run.err" &
daemon=$!
trap 'kill $daemon 2>/dev/null || true' EXIT
start=$(date +%s%N)
# Until the first casing reading (one DS18B20 conversion: 750 ms) is in the status.
while :; do
  if "$gyrotc" status --config "$work/gyrotc-sim.toml" --json >"$work/status.out" 2>"$work/status.err" &&
     python3 -c 'import json,sys; j=json.load(open(sys.argv[1])); sys.exit(0 if j["state"] != "starting" else 1)' "$work/status.out"; then
    break
  fi
  if [ $(( ($(date +%s%N) - start) / 1000000 )) -gt 10000 ]; then
    echo "FAIL: no status with a casing reading 10 s after the start"; cat "$work/status.err" "$work/run.err"; exit 1
  fi
  sleep 0.1
done
echo "status with a casing reading $(( ($(date +%s%N) - start) / 1000000 )) ms after the start"

python3 - "$work/status.out" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
for key in ("format", "running", "state", "summary", "pid", "hal", "config", "mode", "uptime_s", "casing_c",
            "ambient_c", "setpoint_c", "error_c", "tec_a", "tec_limit_a", "compensation_c", "estimate", "flags", "flag_names", "faults",
            "calibration", "latency_us", "counters", "status_file", "age_s", "problem"):
    assert key in j, f"status --json has no {key}"
assert j["state"] in ("warming", "cooling", "holding", "saturated", "fault"), j["state"]
for key in ("casing_c", "ambient_c", "setpoint_c", "tec_a", "tec_limit_a", "compensation_c"):
    assert isinstance(j[key], (int, float)), f"{key} is not a number: {j[key]!r}"
assert j["estimate"] is None, "the PID has no model estimate"
assert j["running"] is True and j["problem"] is None
assert len(j["calibration"]["sha256"]) == 64
print("status:", j["summary"])
PY

# The metrics as node_exporter's textfile collector would read them, mid-run.
cp "$work/gyrotc.prom" "$work/running.prom"
python3 - "$work/running.prom" <<'PY'
import sys
from prometheus_client.parser import text_string_to_metric_families
text = open(sys.argv[1]).read()
families = list(text_string_to_metric_families(text))
assert families, "no metric families"
for f in families:
    assert f.documentation, f"{f.name}: no HELP"
    assert f.type in ("gauge", "counter"), f"{f.name}: type {f.type} (no TYPE line?)"
    assert f.name.startswith("gyrotc_"), f.name
values = {(s.name, tuple(sorted(s.labels.items()))): s.value for f in families for s in f.samples}
assert values[("gyrotc_up", ())] == 1
assert sum(v for (n, _), v in values.items() if n == "gyrotc_state") == 1, "exactly one state is 1"
assert ("gyrotc_tec_current_amperes", ()) in values and ("gyrotc_casing_temperature_celsius", ()) in values
assert ("gyrotc_compensation_temperature_celsius", ()) in values
print(f"metrics: {len(families)} families parsed by prometheus_client")
PY

wait $daemon
trap - EXIT
if "$gyrotc" status --config "$work/gyrotc-sim.toml" >"$work/after.out" 2>"$work/after.err"; then
  echo "FAIL: gyrotc status exits 0 after the daemon stopped"; cat "$work/after.out"; exit 1
fi
grep -q "no gyrotc daemon is running: the last one (pid $daemon) stopped" "$work/after.err" ||
  { echo "FAIL: gyrotc status after the stop says:"; cat "$work/after.err"; exit 1; }
grep -qx "gyrotc_up 0" "$work/gyrotc.prom" || { echo "FAIL: gyrotc_up is not 0 after the stop"; exit 1; }
echo "after the stop: $(cat "$work/after.err")"
