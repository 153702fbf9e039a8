#!/bin/sh
# Issue 13's whole-process figures, two builds side by side: median wall time
# of RUNS runs of each command, alternating the builds so that a busy machine
# weighs on both alike. Targets: design with 8 starts < 2.5 s, identify of a
# 50 s 500 Hz log < 15 ms, reproduce < 4 s (folder < 25 MB).
#
# Usage: bench/process_times.sh [NEW] [OLD] [RUNS]
#   NEW, OLD: quadid executables (default build/quadid, and none: NEW only)
#   RUNS: runs of each command (default 5)
set -eu
NEW=${1:-build/quadid}
OLD=${2:-}
RUNS=${3:-5}
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
"$NEW" simulate --trajectory table2 --duration 50 -o "$TMP/log.csv" >/dev/null

# one EXE OUT ARGS...: appends the wall time of one run to OUT.
one() {
  exe=$1
  out=$2
  shift 2
  t0=$(date +%s%N)
  "$exe" "$@" >/dev/null 2>&1
  t1=$(date +%s%N)
  echo "$t0 $t1" | awk '{ printf "%.4f\n", ($2 - $1) / 1e9 }' >>"$out"  # ms resolution (time(1) gives 10 ms)
}
median() { sort -n "$1" | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }

printf '%-40s %8s %8s\n' command new_s old_s
for cmd in "identify $TMP/log.csv" \
           "design --seed 1 --no-precision -o $TMP/d.json" \
           "design --seed 1 -o $TMP/d.json" \
           "reproduce --out $TMP/rep"; do
  : >"$TMP/new.txt"
  : >"$TMP/old.txt"
  i=0
  while [ $i -lt "$RUNS" ]; do  # alternating, so that a busy machine weighs on both alike
    # shellcheck disable=SC2086
    one "$NEW" "$TMP/new.txt" $cmd
    if [ -d "$TMP/rep" ]; then du -sm "$TMP/rep" | cut -f1 >"$TMP/rep_mb.txt"; fi
    rm -rf "$TMP/rep"
    # shellcheck disable=SC2086
    if [ -n "$OLD" ]; then one "$OLD" "$TMP/old.txt" $cmd; fi
    rm -rf "$TMP/rep"
    i=$((i + 1))
  done
  old=-
  if [ -n "$OLD" ]; then old=$(median "$TMP/old.txt"); fi
  printf '%-40s %8s %8s\n' "$(echo "$cmd" | sed "s|$TMP/||g")" "$(median "$TMP/new.txt")" "$old"
done
echo "reproduce folder (new build): $(cat "$TMP/rep_mb.txt") MB"
