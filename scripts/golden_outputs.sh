#!/usr/bin/env bash
# Records what quadid prints for a fixed set of commands, so that a redesign can
# show "every printed number unchanged" (issue 36): run it before and after, then
#   diff -r BEFORE AFTER
# Usage: scripts/golden_outputs.sh QUADID_EXE OUT_DIR [SHARED_DATA_DIR]
# Each command's stdout goes to NAME.out, stderr to NAME.err, its exit code to NAME.rc;
# files it writes stay in OUT_DIR/files. Timings and absolute paths are masked.
set -uo pipefail
exe=$(readlink -f "$1"); out=$(mkdir -p "$2" && cd "$2" && pwd); shared=${3:-$(dirname "$0")/../../shared/data}
shared=$(readlink -f "$shared" 2>/dev/null || echo "$shared")
mkdir -p "$out/files"; cd "$out/files"
mask() { sed -E -e "s#$out/files/##g" -e "s#$shared#SHARED#g" \
  -e 's/[0-9]+(\.[0-9]+)? ?(ms|s) (of CPU|in all|elapsed)/T \3/g' \
  -e 's/(took|in|time:?) [0-9]+(\.[0-9]+)? ?(ms|s)\b/\1 T/g' \
  -e 's/[0-9]+(\.[0-9]+)? ?(ms|s)\)/T)/g' -e 's/[0-9]+(\.[0-9]+)? (logs|runs|flights)\/s/N \2\/s/g' -e 's/"(seconds|elapsed_s|wall_s)": [0-9.e+-]+/"\1": T/g'; }
run() {  # run NAME ARGS...
  local name=$1; shift
  "$exe" "$@" > "$out/$name.out.raw" 2> "$out/$name.err.raw"; echo $? > "$out/$name.rc"
  mask < "$out/$name.out.raw" > "$out/$name.out"; mask < "$out/$name.err.raw" > "$out/$name.err"
  rm -f "$out/$name.out.raw" "$out/$name.err.raw"
}
run design design --seed 1 -o traj.json
run check_traj check-trajectory traj.json
run check_table2 check-trajectory table2
run simulate simulate --trajectory traj.json --duration 50 -o flight.csv
run identify identify flight.csv --verbose
run identify_summary identify flight.csv
run identify_json identify flight.csv --json -o result.json
run identify_json_stdout identify flight.csv --json
run validate validate --log flight.csv --params result.json
run sim_table2 simulate --trajectory table2 --duration 50 --seed 3 -o flight2.csv
run identify_table2 identify flight2.csv --json
run reproduce reproduce --out repro
run montecarlo montecarlo --runs 12 --seed 1 --threads 2 --json
run design_cf design --vehicle crazyflie21 --seed 2 --starts 2 -o cf_traj.json
run sim_cf simulate --vehicle crazyflie21 --trajectory cf_traj.json --duration 30 --seed 2 -o cf.csv
run identify_cf identify cf.csv --vehicle crazyflie21 --json -o cf_result.json
run identify_cf_text identify cf.csv --vehicle crazyflie21 --verbose
run identify_cf_km identify cf.csv --vehicle crazyflie21 --known-mass 0.0347 --json
run validate_cf validate --log cf.csv --vehicle crazyflie21 --params cf_result.json
if [ -d "$shared/crazyflie-usd" ]; then
  for f in jana00 jana01 jana04 jana06; do
    run "real_${f}_text" identify "$shared/crazyflie-usd/$f" --vehicle crazyflie21 --verbose
    run "real_${f}_json" identify "$shared/crazyflie-usd/$f" --vehicle crazyflie21 --json
    run "real_${f}_km" identify "$shared/crazyflie-usd/$f" --vehicle crazyflie21 --known-mass 0.0347 --json
    run "loginfo_$f" log-info "$shared/crazyflie-usd/$f"
    run "import_$f" import "$shared/crazyflie-usd/$f" -o "import_$f.csv"
  done
  run batch_real batch --vehicle crazyflie21 --known-mass 0.0347 "$shared"/crazyflie-usd/jana0{0,1,4,6}
fi
if [ -d "$shared/px4-ulog" ]; then
  for f in "$shared"/px4-ulog/*.ulg; do b=$(basename "$f" .ulg)
    run "loginfo_$b" log-info "$f"; run "import_$b" import "$f" -o "import_$b.csv"; run "identify_$b" identify "$f" --verbose
  done
fi
for c in design check-trajectory simulate identify validate reproduce import log-info batch montecarlo export; do
  run "help_$c" "$c" --help
done
# Timestamps inside written files are masked by comparing content only where it is data.
find "$out/files" -name '*.html' -exec sed -i -E 's/[0-9]+(\.[0-9]+)? s\b/T s/g' {} +
echo "golden outputs in $out"
