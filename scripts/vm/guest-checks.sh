#!/bin/bash
# The checks scripts/vm-test.sh runs inside its virtual board (as root, from
# the run disk mounted at /vmtest, started by vmtest.service after boot).
# Prints "vm-test: plan <checks>" first, then one "PASS <check>: ..." or
# "FAIL <check>: ..." line per check (details indented below a FAIL); the host
# counts them. Not meant to run anywhere else: it installs a package, edits
# /etc/gyrotc and loads a kernel module.
# `guest-checks.sh --plan` only prints the plan (the host counts on it).
set -u
PLAN=(deb-install sysusers start realtime sandbox watchdog outputs reload crash-restart stop
      output-refused seccomp-kill gpio-sim-module udev-gpiochip gpio-chip-lookup gpio-drdy-edge
      gpio-drdy-timeout gpio-drdy-conversions gpio-edge-queue gpio-discard gpio-es-output
      gpio-consumers safe-off-es)
echo "vm-test: plan ${PLAN[*]}"
[ "${1:-}" = --plan ] && exit 0

cd /vmtest
. ./vm.env   # DEB, GPIO_KO, GPIOSIM_CHECK, RUN_S
export SYSTEMD_COLORS=0 SYSTEMD_PAGER= NO_COLOR=1 DEBIAN_FRONTEND=noninteractive

declare -A done_checks=()
pass() { done_checks[$1]=1; echo "PASS $1: $2"; }
# fail CHECK REASON [DETAIL LINES...]
fail() {
  done_checks[$1]=1
  echo "FAIL $1: $2"
  shift 2
  local l
  for l in "$@"; do printf '%s\n' "$l" | sed 's/^/    /'; done
}
prop() { systemctl show -P "$1" gyrotc.service; }
# A journal position, and the unit's (or the kernel's) messages after it.
mark() { journalctl -n0 --show-cursor -q 2>/dev/null | sed -n 's/^-- cursor: //p'; }
log_since() { journalctl --no-pager -q -o cat --after-cursor="$1" "${@:2}"; }
# wait_for SECONDS COMMAND...: polls COMMAND every 0.5 s.
wait_for() {
  local end=$((SECONDS + $1))
  shift
  until "$@"; do
    [ $SECONDS -ge $end ] && return 1
    sleep 0.5
  done
}
unit_log() { log_since "$1" -u gyrotc.service; }
# Kernel seccomp records (audit type 1326) of gyrotc processes, and systemd's
# own word on a kill.
denials_since() {
  log_since "$1" -k | grep -E 'type=1326|audit: .*SECCOMP' | grep -E 'comm="gyrotc"|exe="/usr/bin/gyrotc"'
  log_since "$1" -u gyrotc.service | grep -E 'code=killed, status=31|status=31/SYS|Watchdog timeout'
}

# --- 1. the package, as a user installs it ------------------------------------
out=$(apt install -y "./$DEB" 2>&1)
if [ $? -eq 0 ] && dpkg-query -W -f='${Status}' gyrotc 2>/dev/null | grep -q "install ok installed"; then
  pass deb-install "apt install ./$DEB: $(dpkg-query -W -f='${Package} ${Version} ${Architecture}' gyrotc)"
else
  fail deb-install "apt install ./$DEB failed" "$(printf '%s\n' "$out" | tail -15)"
fi

entry=$(getent passwd gyrotc)
IFS=: read -r _ _ uid gid _ home shell <<<"$entry"
if [ -n "$entry" ] && [ "$uid" -lt 1000 ] && [ "$home" = /var/lib/gyrotc ] && [[ "$shell" == */nologin ]] &&
   [ "$(getent group gyrotc | cut -d: -f3)" = "$gid" ]; then
  pass sysusers "systemd-sysusers created user gyrotc (uid $uid, group gyrotc $gid, home $home, shell $shell)"
else
  fail sysusers "no system user gyrotc as /usr/lib/sysusers.d/gyrotc.conf describes" "getent: '$entry'"
fi

# The simulated board, with a CSV recording in the unit's state directory.
cp /etc/gyrotc/gyrotc.toml /etc/gyrotc/vm-board.toml.orig
cp /etc/gyrotc/gyrotc-sim.toml /etc/gyrotc/gyrotc.toml
sed -i 's|^record_csv = ""|record_csv = "/var/lib/gyrotc/record.csv"|' /etc/gyrotc/gyrotc.toml
grep -q '^record_csv = "/var/lib/gyrotc/record.csv"' /etc/gyrotc/gyrotc.toml ||
  echo "vm-test: note: could not set output.record_csv in /etc/gyrotc/gyrotc.toml"

# --- 2. the service under systemd ----------------------------------------------
c_start=$(mark)
started_s=$SECONDS
if out=$(systemctl start gyrotc 2>&1) && [ "$(prop ActiveState)" = active ] && [ "$(prop SubState)" = running ]; then
  pid=$(prop MainPID)
  puid=$(awk '/^Uid:/ {print $2}' "/proc/$pid/status")
  if [ "$puid" = "$uid" ]; then
    pass start "systemctl start returned after READY=1 (Type=$(prop Type)): active/running, MainPID $pid, uid $puid (gyrotc)"
  else
    fail start "MainPID $pid runs as uid '$puid', not gyrotc ($uid)"
  fi
else
  pid=
  fail start "systemctl start gyrotc: $(prop ActiveState)/$(prop SubState) $(prop Result)" "$out" "$(unit_log "$c_start" | tail -20)"
fi

if [ -n "$pid" ]; then
  fifo=
  for t in /proc/"$pid"/task/*; do
    policy=$(chrt -p "${t##*/}" 2>/dev/null)
    if grep -q SCHED_FIFO <<<"$policy"; then
      fifo="thread ${t##*/} ($(cat "$t/comm")): $(tr '\n' ' ' <<<"$policy" | sed 's/pid [0-9]*.s //g')"
      break
    fi
  done
  vmlck=$(awk '/^VmLck:/ {print $2}' "/proc/$pid/status")
  line=$(unit_log "$c_start" | grep -m1 'running on the simulated board')
  if [ -n "$fifo" ] && [ "${vmlck:-0}" -gt 0 ] && grep -q 'SCHED_FIFO, memory locked' <<<"$line"; then
    pass realtime "$fifo; VmLck ${vmlck} kB; log: ${line}"
  else
    fail realtime "SCHED_FIFO '${fifo:-none}', VmLck '${vmlck:-?}' kB" "log: ${line:-no 'running on' line}"
  fi
else
  fail realtime "not running"
fi

# >= RUN_S seconds of running: no denial, no kill, no restart, the watchdog fed.
wd_first=$(prop WatchdogTimestampMonotonic)
sleep $((RUN_S - (SECONDS - started_s) > 0 ? RUN_S - (SECONDS - started_s) : 0))
ran_s=$((SECONDS - started_s))
wd_last=$(prop WatchdogTimestampMonotonic)
denied=$(denials_since "$c_start")
complaints=$(unit_log "$c_start" -p warning | grep -iE 'not permitted|permission denied|read-only file system|EPERM|EACCES|EROFS|seccomp')
if [ -n "$pid" ] && [ "$(prop MainPID)" = "$pid" ] && [ "$(prop NRestarts)" = 0 ] && [ "$(prop ActiveState)" = active ] &&
   [ -z "$denied" ] && [ -z "$complaints" ]; then
  pass sandbox "${ran_s} s active under SystemCallFilter=$(prop SystemCallFilter | wc -w)-call allow list, ProtectSystem=$(prop ProtectSystem): same MainPID, 0 restarts, no seccomp record or EPERM/EACCES/EROFS in the journal"
else
  fail sandbox "after ${ran_s} s: MainPID $(prop MainPID) (was ${pid:-none}), NRestarts $(prop NRestarts), $(prop ActiveState)" \
    "${denied}" "${complaints}" "$(unit_log "$c_start" -p warning | tail -10)"
fi
if [ "$(prop WatchdogUSec)" = 5s ] && [ -n "$wd_first" ] && [ "${wd_last:-0}" -gt "${wd_first:-0}" ] &&
   ! unit_log "$c_start" | grep -q 'Watchdog timeout'; then
  pass watchdog "WatchdogSec=$(prop WatchdogUSec): last WATCHDOG=1 moved from $((wd_first / 1000)) ms to $((wd_last / 1000)) ms over the run, no watchdog timeout"
else
  fail watchdog "WatchdogUSec '$(prop WatchdogUSec)', WATCHDOG=1 seen at '${wd_first}' then '${wd_last}' (monotonic us)"
fi

csv=/var/lib/gyrotc/record.csv
rows=$(($(wc -l <"$csv" 2>/dev/null || echo 1) - 1))
stream_rows=$(unit_log "$c_start" | grep -cE '^[0-9]+\.[0-9]{3},')
if [ -f "$csv" ] && [ "$(stat -c %U:%G "$csv")" = gyrotc:gyrotc ] && head -1 "$csv" | grep -q '^time_s,' &&
   [ "$rows" -ge $((RUN_S / 3)) ] && [ "$stream_rows" -ge $((RUN_S / 3)) ]; then
  pass outputs "output.stream stdout -> journal ($stream_rows lines), output.record_csv -> $csv ($(stat -c '%U:%G %a' "$csv"), $rows rows after ${ran_s} s) in StateDirectory=$(prop StateDirectory)"
else
  fail outputs "record $csv: $(stat -c '%U:%G %a %s bytes' "$csv" 2>&1), $rows rows; $stream_rows stream lines in the journal" \
    "$(head -3 "$csv" 2>&1)"
fi

c=$(mark)
systemctl reload gyrotc
if wait_for 20 sh -c "journalctl -q -o cat --after-cursor='$c' -u gyrotc.service | grep -q 'SIGHUP: calibration reloaded from'" &&
   [ "$(prop MainPID)" = "$pid" ] && [ "$(prop ActiveState)" = active ]; then
  pass reload "systemctl reload: $(unit_log "$c" | grep -m1 'SIGHUP: calibration reloaded' | cut -c1-160)..., same MainPID $pid"
else
  fail reload "no 'SIGHUP: calibration reloaded' line, or the process changed (MainPID $(prop MainPID), was $pid)" "$(unit_log "$c" | tail -10)"
fi

c=$(mark)
old_pid=$(prop MainPID)
kill -SEGV "$old_pid"
restarted() { p=$(prop MainPID); [ "$p" != 0 ] && [ "$p" != "$old_pid" ] && [ "$(prop ActiveState)" = active ] && [ "$(prop SubState)" = running ]; }
if wait_for 60 restarted; then
  log=$(unit_log "$c")
  exited=$(grep -m1 -E 'Main process exited.*SEGV' <<<"$log")
  safeoff=$(grep -m1 -n 'safe-off: TEC at 0 A, OPA548 disabled' <<<"$log")
  running=$(grep -m1 -n 'running on the simulated board' <<<"$log")
  if [ -n "$exited" ] && [ -n "$safeoff" ] && [ -n "$running" ] && [ "${safeoff%%:*}" -lt "${running%%:*}" ]; then
    pass crash-restart "kill -SEGV $old_pid -> '$exited' -> ExecStopPost '${safeoff#*:}' -> restarted as $(prop MainPID) (NRestarts $(prop NRestarts))"
  else
    fail crash-restart "restarted, but not in the order crash, safe-off, start" "$log"
  fi
else
  fail crash-restart "no restart within 60 s: $(prop ActiveState)/$(prop SubState), MainPID $(prop MainPID)" "$(unit_log "$c" | tail -15)"
fi

c=$(mark)
systemctl stop gyrotc
log=$(unit_log "$c")
if [ "$(prop ActiveState)" = inactive ] && [ "$(prop Result)" = success ] &&
   grep -q 'SIGTERM after .*(safe-off)' <<<"$log" && grep -q 'safe-off: TEC at 0 A, OPA548 disabled' <<<"$log"; then
  pass stop "systemctl stop: inactive, Result=success; '$(grep -m1 -o 'SIGTERM after .*(safe-off)' <<<"$log")', ExecStopPost '$(grep -m1 -o 'safe-off: TEC at 0 A.*' <<<"$log")'"
else
  fail stop "$(prop ActiveState), Result=$(prop Result)" "$log"
fi

# Everything but the state directory is read-only to the service
# (ProtectSystem=strict), even a folder the gyrotc user owns: an output there
# stops the start with the path and the reason.
mkdir -p /srv/gyrotc-out && chown gyrotc:gyrotc /srv/gyrotc-out
sed -i 's|^record_csv = .*|record_csv = "/srv/gyrotc-out/record.csv"|' /etc/gyrotc/gyrotc.toml
c=$(mark)
systemctl start gyrotc >/dev/null 2>&1
started=$?
sleep 1
systemctl stop gyrotc >/dev/null 2>&1
systemctl reset-failed gyrotc >/dev/null 2>&1
refusal=$(unit_log "$c" | grep -m1 'srv/gyrotc-out/record.csv')
if [ "$started" -ne 0 ] && grep -q 'Read-only file system' <<<"$refusal" && [ ! -e /srv/gyrotc-out/record.csv ]; then
  pass output-refused "record_csv in /srv/gyrotc-out (owned by gyrotc): the start fails with '$refusal'"
else
  fail output-refused "systemctl start exit $started; no read-only refusal naming the path" "$(unit_log "$c" | tail -10)"
fi
sed -i 's|^record_csv = .*|record_csv = "/var/lib/gyrotc/record.csv"|' /etc/gyrotc/gyrotc.toml

# The shipped unit answers a filtered call with EPERM, which the daemon might
# swallow. With the filter's answer turned into a kill (a drop-in), any
# system call outside the allow list during start, run, reload, stop and
# safe-off ends the process and leaves a seccomp record.
mkdir -p /run/systemd/system/gyrotc.service.d
printf '[Service]\nSystemCallErrorNumber=kill\n' >/run/systemd/system/gyrotc.service.d/vm-test-seccomp-kill.conf
systemctl daemon-reload
errno_setting=$(prop SystemCallErrorNumber)
c=$(mark)
systemctl start gyrotc >/dev/null 2>&1
sleep 10
kpid=$(prop MainPID)
systemctl reload gyrotc
sleep 3
after_reload=$(prop ActiveState)/$(prop MainPID)
systemctl stop gyrotc
denied=$(denials_since "$c")
rm -rf /run/systemd/system/gyrotc.service.d
systemctl daemon-reload
# systemctl shows "kill" as systemd's internal number for it (INT_MAX - 1).
if { [ "$errno_setting" = kill ] || [ "$errno_setting" = 2147483646 ]; } && [ "$kpid" != 0 ] && [ "$after_reload" = "active/$kpid" ] && [ -z "$denied" ] &&
   [ "$(prop Result)" = success ]; then
  pass seccomp-kill "with SystemCallErrorNumber=kill: started, ran 10 s, reloaded, stopped (Result=success) with no seccomp kill"
else
  fail seccomp-kill "SystemCallErrorNumber='$errno_setting': after reload $after_reload (MainPID was $kpid), Result=$(prop Result)" \
    "$denied" "$(unit_log "$c" | tail -12)"
fi

# --- 3. the GPIO back-end against a kernel GPIO chip (gpio-sim) -----------------
sim=/sys/kernel/config/gpio-sim/gyrotc
label=gyrotc-vm-sim
modprobe configfs 2>/dev/null
mountpoint -q /sys/kernel/config || mount -t configfs none /sys/kernel/config
out=$(insmod "$GPIO_KO" 2>&1)
vermagic=$(modinfo -F vermagic "$GPIO_KO" 2>/dev/null)
chip=
if [ -d /sys/kernel/config/gpio-sim ] && mkdir "$sim" "$sim/bank0" "$sim/bank0/line0" "$sim/bank0/line1" &&
   echo 4 >"$sim/bank0/num_lines" && echo "$label" >"$sim/bank0/label" &&
   echo DRDY >"$sim/bank0/line0/name" && echo OPA548_ES >"$sim/bank0/line1/name" && echo 1 >"$sim/live"; then
  chip=$(cat "$sim/bank0/chip_name")
  simdir=/sys/devices/platform/$(cat "$sim/dev_name")/$chip
  pass gpio-sim-module "gpio-sim built for $(uname -r) (vermagic '${vermagic%% *}'), chip $chip '$label' with lines DRDY, OPA548_ES"
else
  fail gpio-sim-module "insmod $GPIO_KO / configfs chip failed on $(uname -r)" "$out" "vermagic: $vermagic" "$(dmesg | tail -5)"
fi

if [ -n "$chip" ]; then
  udevadm settle --timeout=30
  owner=$(stat -c '%G %a' "/dev/$chip")
  if [ "$owner" = "gyrotc 660" ]; then
    pass udev-gpiochip "/dev/$chip: group gyrotc, mode 660 (60-gyrotc.rules, applied by udev)"
  else
    fail udev-gpiochip "/dev/$chip: '$owner', want 'gyrotc 660'"
  fi
  # The back-end's own checks (tools/gpiosim_check.cpp), one line each.
  timeout 300 "./$GPIOSIM_CHECK" --chip "$chip" --sim-dir "$simdir" --label "$label" \
    --drdy DRDY --drdy-offset 0 --es OPA548_ES --es-offset 1 >gpiosim.out 2>&1
  status=$?
  while IFS= read -r line; do
    case "$line" in
      PASS\ * | FAIL\ *) name=${line#* }; name=${name%%:*}; done_checks[$name]=1; echo "$line" ;;
      *) echo "    $line" ;;
    esac
  done <gpiosim.out
  for name in gpio-chip-lookup gpio-drdy-edge gpio-drdy-timeout gpio-drdy-conversions gpio-edge-queue gpio-discard \
              gpio-es-output gpio-consumers; do
    [ -n "${done_checks[$name]:-}" ] || fail "$name" "gpiosim_check ended (exit $status) before this check"
  done

  # gyrotc safe-off on a board whose OPA548 E/S line is the simulated one (and
  # whose SPI devices are missing): the kernel's GPIO trace shows every level
  # the line is driven to. E/S is pulled up, so only our drive keeps it low.
  base=
  for d in /sys/class/gpio/gpiochip*; do
    [ "$(cat "$d/label" 2>/dev/null)" = "$label" ] && base=$(cat "$d/base")
  done
  es_gpio=$((${base:-0} + 1))
  board=/etc/gyrotc/vm-board.toml
  sed -e "s|^drdy = .*|drdy = \"$chip:DRDY\"|" -e "s|^es = .*|es = \"$chip:OPA548_ES\"|" \
      -e 's|^file = "calibration.toml"|file = "/etc/gyrotc/calibration.toml"|' /etc/gyrotc/vm-board.toml.orig >"$board"
  echo pull-up >"$simdir/sim_gpio1/pull"
  tr=/sys/kernel/tracing
  mountpoint -q $tr || mount -t tracefs nodev $tr
  echo 0 >$tr/tracing_on; echo >$tr/trace
  echo 1 >$tr/events/gpio/enable && echo 1 >$tr/tracing_on
  safe_out=$(runuser -u gyrotc -- /usr/bin/gyrotc safe-off --config "$board" 2>&1)
  safe_status=$?
  echo 0 >$tr/tracing_on
  trace=$(grep -E "gpio_(value|direction): $es_gpio " $tr/trace | sed 's/^.*\(gpio_[a-z]*: \)/\1/')
  echo 0 >$tr/events/gpio/enable
  sets=$(grep -c "gpio_value: $es_gpio set" <<<"$trace")
  if [ -n "$base" ] && grep -q "gpio_direction: $es_gpio out (0)" <<<"$trace" && [ "$sets" -ge 1 ] &&
     ! grep -q "gpio_value: $es_gpio set 1" <<<"$trace" && grep -q spidev <<<"$safe_out"; then
    pass safe-off-es "gyrotc safe-off (as gyrotc; exit $safe_status: '$(grep -m1 -o "cannot open spidev '[^']*'" <<<"$safe_out")' ...): E/S (gpio $es_gpio, pulled up) driven only low: $(tr '\n' ';' <<<"$trace")"
  else
    fail safe-off-es "E/S (gpio $es_gpio) trace or safe-off output not as expected (exit $safe_status)" "$safe_out" "trace: $trace"
  fi
else
  for name in udev-gpiochip gpio-chip-lookup gpio-drdy-edge gpio-drdy-timeout gpio-drdy-conversions gpio-edge-queue \
              gpio-discard gpio-es-output gpio-consumers safe-off-es; do
    fail "$name" "no gpio-sim chip"
  done
fi

for name in "${PLAN[@]}"; do
  [ -n "${done_checks[$name]:-}" ] || fail "$name" "the guest script skipped it"
done
echo "vm-test: guest done"
