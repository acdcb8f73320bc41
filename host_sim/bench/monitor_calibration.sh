#!/usr/bin/env bash
# False alarms and detection of `feedid monitor` on simulated logs
# (docs/monitor.md). Usage: bash host_sim/bench/monitor_calibration.sh [build/bin/feedid] [seed offset]
# The offset (default 0) draws other drives, noise and change times: a held-out set.
# Prints one Markdown row per log. About 4 minutes on 2 cores.
set -euo pipefail
B=${1:-build/bin/feedid}
offset=${2:-0}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
rates=(1000 2000 4000 8000)
echo "| log | program | rate (Hz) | logged as | change | alarms (time of change / raised) |"
echo "|---|---|---|---|---|---|"
i=0
for kind in free step; do
  for prog in ladder sine production; do
    for seed in 1 2 3 4 5 6; do
      i=$((i + 1))
      rate=${rates[$((i % 4))]}
      flog=$([ $((i % 3)) = 0 ] && echo held || ([ $((i % 3)) = 1 ] && echo averaged || echo instant))
      vlog=$([ $((i % 2)) = 0 ] && echo lowpass || echo average)
      args=(--program "$prog" --duration 600 --seed "$((seed + 100 * i + offset))" --rate "$rate" --force-log "$flog" --velocity-log "$vlog")
      change="none"
      if [ "$kind" = step ]; then
        t=$((120 + (97 * i + 13 * offset) % 360))
        frac=$(awk -v i="$i" 'BEGIN { f = 0.05 + 0.10 * ((i * 37) % 11) / 10; if (i % 2) f = -f; printf "%.3f", f }')
        dir=$([ $((i % 2)) = 0 ] && echo pos || echo neg)
        args+=(--change-time "$t" --change-coulomb-fraction "$frac" --change-direction "$dir")
        change="Fc $dir $frac at $t s"
      fi
      "$B" simulate "${args[@]}" --out "$tmp/log.csv" >/dev/null 2>&1
      alarms=$("$B" monitor --in "$tmp/log.csv" 2>/dev/null | awk '/^ALARM/ { sub(/^ALARM at /, ""); printf "%s%s", sep, $0; sep = "; " }')
      echo "| $i | $prog | $rate | force $flog, velocity $vlog | $change | ${alarms:-none} |"
    done
  done
done
