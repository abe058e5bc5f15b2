#!/bin/bash
# pl-localize --log, end to end: a small generated town drive and its map (pl-sim, pl-map), localized
# with and without a log; the log read by @mcap/core (check_run_log.mjs) and the poses compared.
#   run_log_test.sh BIN_DIR NODE_DIR WORK_DIR
set -uo pipefail
bin=$1 node_dir=$2 work=$3
here=$(cd "$(dirname "$0")" && pwd)
fail() { echo "run_log_test: $*" >&2; exit 1; }
run() {
  echo "+ $*"
  "$@" >"$work/last.log" 2>&1 || { cat "$work/last.log"; fail "failed: $*"; }
}
rm -rf "$work" && mkdir -p "$work" && cd "$work" || fail "cannot make $work"

run "$bin/pl-sim" --route loop --frames 30 --seed 5 --traffic 2 --out drive
run "$bin/pl-map" build --dataset drive --poses gt --out map.pcd
run "$bin/pl-map" tile --cloud map.pcd --db maps.sqlite --map town
run "$bin/pl-map" publish --db maps.sqlite --map town --version 1
loc=("$bin/pl-localize" --dataset drive --db maps.sqlite --map town --beams 16)

# 1. Wheel odometry, started from the first GPS fix (a search: the first scans are not ok).
run "${loc[@]}" --init gps --out with.tum --kitti-out with.txt --log run.mcap
grep -q " log: .* -> run.mcap" "$work/last.log" || fail "pl-localize printed no log line"
grep " log: " "$work/last.log"
run "${loc[@]}" --init gps --out without.tum --kitti-out without.txt
# One pose per scan: the same with and without the log. (The odometry-rate poses of --out are not
# compared: which of them come before a scan's correction depends on how long the scan took on the
# wall clock, run to run; part 2 compares them where they do not.)
cmp with.txt without.txt || fail "the per-scan poses differ with --log (with.txt, without.txt in $work)"
scans=$(grep -vc '^#' with.txt)
node "$here/check_run_log.mjs" --modules "$node_dir" --log run.mcap --poses with.tum --scans "$scans" --gps ||
  fail "run.mcap (wheel odometry) failed the check"
# The check is not vacuous: a pose file one line short fails it.
head -n -1 with.tum >short.tum
if node "$here/check_run_log.mjs" --modules "$node_dir" --log run.mcap --poses short.tum --scans "$scans" --gps >check.log 2>&1; then
  fail "check_run_log.mjs passed a pose file one line short"
fi
grep -q "/pose holds" check.log || { cat check.log; fail "check_run_log.mjs failed a pose file one line short without saying why"; }

# 2. LiDAR only, started at the ground truth: every output is one pose per scan and the same run to
# run: both files must be identical with and without the log. A smaller ROI (50 m: the map's 20 m
# tiles come and go over the 30 m drive) makes /map change: a message each time (5 here).
run "${loc[@]}" --init gt --odometry lidar --roi-radius 50 --out lidar-with.tum --kitti-out lidar-with.txt --log lidar.mcap
run "${loc[@]}" --init gt --odometry lidar --roi-radius 50 --out lidar-without.tum --kitti-out lidar-without.txt
cmp lidar-with.tum lidar-without.tum || fail "the fused poses differ with --log (lidar-with.tum, lidar-without.tum in $work)"
cmp lidar-with.txt lidar-without.txt || fail "the per-scan poses differ with --log (lidar-with.txt, lidar-without.txt in $work)"
node "$here/check_run_log.mjs" --modules "$node_dir" --log lidar.mcap --poses lidar-with.tum --scans "$(grep -vc '^#' lidar-with.txt)" --gps --min-maps 3 ||
  fail "lidar.mcap (LiDAR only) failed the check"
ls -l run.mcap lidar.mcap
echo "run_log_test: ok"
