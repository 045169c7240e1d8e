#!/usr/bin/env bash
# The self-calibration's own error bound against its true error (issue 73,
# docs/SELFCAL.md). For every plant of docs/selfcal/plants/ and every seed:
# `gyrotc simulate --profile selfcal` at 20 C ambient, `gyrotc calibrate`
# (which states its 95 % bound over the calibrated range), then the casing
# held at 10, 15, .., 65 C with that calibration (`simulate --controller off
# --calibration`), whose calibration_error_max_abs_dps (the worst hold's mean
# compensated rate with the gyro's noise taken out: what the calibration
# itself leaves of the plant's curve) is the true error. Prints a Markdown
# table per plant and pooled: the runs whose true error lies within the
# bound, the median of true / bound and the median bound. Exits 1 when the
# pooled coverage is under 93 % or the median ratio under 0.3. About half a
# minute per run on one core after the build.
# Usage: scripts/selfcal-bound-study.sh [OPTIONS]
#   --seeds A-B   the noise seeds (default 1-20)
#   --jobs N      runs at once (default: the cores)
#   --help        this text
set -euo pipefail
cd "$(dirname "$0")/.."
gyrotc=$PWD/build/release/app/gyrotc
work=$PWD/build/release/selfcal-bound-study

one() {  # plant seed: one run, one line "plant seed true_dps bound_dps lo_c hi_c"
  local plant=$1 seed=$2 name d
  name=$(basename "$plant" .toml)
  d=$work/$name-$seed
  mkdir -p "$d"
  {
    "$gyrotc" simulate --profile selfcal --ambient-c 20 --plant "$plant" --seed "$seed" --out "$d/selfcal" &&
      "$gyrotc" calibrate --data "$d/selfcal/record.csv" --out "$d/cal.toml" --json >"$d/calibrate.json" &&
      holds_profile "$(casing_offset_c "$plant")" "$d/holds.csv" &&
      "$gyrotc" simulate --profile "$d/holds.csv" --controller off --plant "$plant" --seed "$((seed + 1000))" \
        --calibration "$d/cal.toml" --out "$d/holds"
  } >"$d/log" 2>&1 || { echo "selfcal-bound-study.sh: $name seed $seed failed: see $d/log" >&2; return 1; }
  printf '%s %s %s %s\n' "$name" "$seed" "$(jq '.calibration_error_max_abs_dps' "$d/holds/summary.json")" \
    "$(jq -r '"\(.bound.range_dps) \(.bound.range_c[0]) \(.bound.range_c[1])"' "$d/calibrate.json")"
}

seeds=1-20
jobs=$(nproc)
while [[ $# -gt 0 ]]; do
  case $1 in
    -h|--help) sed -n '2,20p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    --seeds) [[ $# -ge 2 && $2 =~ ^[0-9]+-[0-9]+$ ]] || { echo "selfcal-bound-study.sh: --seeds needs A-B" >&2; exit 2; }
             seeds=$2; shift 2 ;;
    --jobs) [[ $# -ge 2 && $2 =~ ^[1-9][0-9]*$ ]] || { echo "selfcal-bound-study.sh: --jobs needs a whole number" >&2; exit 2; }
            jobs=$2; shift 2 ;;
    --one) # internal: one run, for the parallel runner
           # shellcheck source=scripts/lib/selfcal-holds.sh
           source scripts/lib/selfcal-holds.sh; one "$2" "$3"; exit ;;
    *) echo "selfcal-bound-study.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
command -v jq >/dev/null || { echo "selfcal-bound-study.sh: needs jq (scripts/deps.sh native)" >&2; exit 2; }
first=${seeds%-*}
last=${seeds#*-}
(( first <= last )) || { echo "selfcal-bound-study.sh: --seeds $seeds: the first is after the last" >&2; exit 2; }

cmake --preset release >/dev/null
cmake --build --preset release -j "$jobs" --target gyrotc >/dev/null
rm -rf "$work"
mkdir -p "$work"
runs=$(( (last - first + 1) * $(ls docs/selfcal/plants/*.toml | wc -l) ))
echo "selfcal-bound-study.sh: $runs runs, $jobs at once; records in $work" >&2
for plant in docs/selfcal/plants/*.toml; do
  for seed in $(seq "$first" "$last"); do echo "$plant $seed"; done
done | xargs -P "$jobs" -n 2 "$0" --one >"$work/runs.txt"
sort -k1,1 -k2,2n "$work/runs.txt" -o "$work/runs.txt"
[[ $(wc -l <"$work/runs.txt") -eq $runs ]] || { echo "selfcal-bound-study.sh: some runs failed" >&2; exit 1; }

echo "Seeds $seeds (\`scripts/selfcal-bound-study.sh --seeds $seeds\`):"
echo
echo "| plant | runs | true error within the bound | median true / bound | true error, median (worst) deg/s | bound, median (range) deg/s |"
echo "|---|---|---|---|---|---|"
awk '
  function median(a, n,   i, j, t) { for (i = 2; i <= n; i++) { t = a[i]; for (j = i - 1; j >= 1 && a[j] > t; j--) a[j + 1] = a[j]; a[j + 1] = t }
                                     return n % 2 ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2 }
  function row(name, n, held, r, e, b, worst, blo, bhi) {
    printf "| %s | %d | %d (%.1f %%) | %.2f | %.4f (%.4f) | %.4f (%.4f .. %.4f) |\n", name, n, held, 100 * held / n,
      median(r, n), median(e, n), worst, median(b, n), blo, bhi }
  {
    p = $1; n[p]++; N++
    if ($3 <= $4) { held[p]++; H++ }
    r[p, n[p]] = $3 / $4; R[N] = $3 / $4; e[p, n[p]] = $3; E[N] = $3; b[p, n[p]] = $4; B[N] = $4
    if ($3 > worst[p]) worst[p] = $3; if ($3 > W) W = $3
    if (!(p in blo) || $4 < blo[p]) blo[p] = $4; if ($4 > bhi[p]) bhi[p] = $4
    if (BLO == "" || $4 < BLO) BLO = $4; if ($4 > BHI) BHI = $4
    if (!(p in seen)) { seen[p] = 1; order[++P] = p }
  }
  END {
    for (k = 1; k <= P; k++) {
      p = order[k]; delete rr; delete ee; delete bb
      for (i = 1; i <= n[p]; i++) { rr[i] = r[p, i]; ee[i] = e[p, i]; bb[i] = b[p, i] }
      row(p, n[p], held[p] + 0, rr, ee, bb, worst[p], blo[p], bhi[p])
    }
    row("**pooled**", N, H, R, E, B, W, BLO, BHI)
    ratio = median(R, N)
    exit (H / N < 0.93 || ratio < 0.3) ? 1 : 0
  }' "$work/runs.txt"
