#!/bin/sh
# Scale of `quadid identify` with the log's length: simulates two long flights
# at 1 kHz (default noise, 18 columns) and identifies each under /usr/bin/time -v,
# printing wall time, CPU time and peak memory. Targets (issue 4): a 20-minute
# flight at 1 kHz (1.2 million rows) in under 2 s with under 500 MB; time
# linear in the length.
#
# Usage: bench/identify_scale.sh [QUADID] [MINUTES...]   (default: build/quadid, 10 20)
set -eu
QUADID=${1:-build/quadid}
[ $# -gt 0 ] && shift
MINUTES=${*:-10 20}
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
printf '%-8s %10s %10s %9s %9s %9s\n' minutes rows MB wall_s cpu_s peak_MB
for min in $MINUTES; do
  log="$TMP/flight_${min}min.csv"
  "$QUADID" simulate --trajectory table2 --duration $((min * 60)) --rate 1000 --noise default -o "$log" >/dev/null
  rows=$(($(grep -vc '^#' "$log") - 1))
  mb=$(($(wc -c <"$log") / 1000000))
  /usr/bin/time -v "$QUADID" identify "$log" --window 10: >/dev/null 2>"$TMP/time.txt"
  wall=$(sed -n 's/.*Elapsed (wall clock) time (h:mm:ss or m:ss): //p' "$TMP/time.txt")
  user=$(sed -n 's/.*User time (seconds): //p' "$TMP/time.txt")
  sys=$(sed -n 's/.*System time (seconds): //p' "$TMP/time.txt")
  rss=$(sed -n 's/.*Maximum resident set size (kbytes): //p' "$TMP/time.txt")
  cpu=$(awk "BEGIN { print $user + $sys }")
  printf '%-8s %10s %10s %9s %9s %9s\n' "$min" "$rows" "$mb" "$wall" "$cpu" "$((rss / 1000))"
  rm -f "$log"
done
