# The self-calibration studies' holds (scripts/selfcal-study.sh,
# scripts/selfcal-bound-study.sh): each plant's casing held at 10, 15, .., 65 C
# with the controller off, where each calibration is judged. Sourced.

# The casing the electronics' heat holds above the ambient with the TEC off,
# steady state: P / (G_leak + K_tec) + P / G_shell. Each plant's holds are set
# from it so the casing sits at 10 .. 65 C; the table shows where it was.
casing_offset_c() {
  local p=$1
  local leak power
  leak=$(sed -n 's/^shell_casing_leak_w_per_k = //p' "$p"); leak=${leak:-0.02}
  power=$(sed -n 's/^internal_power_w = //p' "$p"); power=${power:-0.3}
  awk -v l="$leak" -v q="$power" 'BEGIN { printf "%.3f", q / (l + 0.085) + q / 0.6 }'
}

holds_profile() {  # three hours per hold, 5 C/10 min between
  local offset=$1 out=$2 t=0
  echo "segment,start_s,end_s,ambient_start_c,ambient_end_c,description" >"$out"
  local prev=""
  for c in 10 15 20 25 30 35 40 45 50 55 60 65; do
    a=$(awk -v c="$c" -v o="$offset" 'BEGIN { printf "%.2f", c - o }')
    if [[ -n $prev ]]; then
      echo "r$c,$t,$((t + 600)),$prev,$a,ramp" >>"$out"
      t=$((t + 600))
    else
      echo "s$c,0,0,$a,$a,start" >>"$out"
    fi
    echo "h$c,$t,$((t + 10800)),$a,$a,casing near $c C" >>"$out"
    t=$((t + 10800))
    prev=$a
  done
}

