#!/usr/bin/env bash
# Registration on the paper's protocol on the real drive 0005 (KITTI raw 2011_09_26, 154 HDL-64E
# scans, OXTS ground truth): the map is the even-numbered scans merged at their ground-truth poses
# (0.2 m voxels, tiled into a SQLite map store); the odd-numbered scans are localized against it with
# 16 of the 64 beams, from the first odd scan's ground-truth pose, on constant-velocity prediction.
# bench_localize runs ours and the PCL registrations side by side in one run; a second run restarts
# ours, PCL's ICP and GICP at every scan's ground-truth pose and 0.2 m from it (--from-truth: the
# floors, and how much of a floor is the start); then the whole product (pl-localize + pl-eval ape)
# on the same protocol.
#   bench/localize_kitti05.sh BIN_DIR WORK_DIR [--quick N]
# The map is prepared once into WORK_DIR/k05. Without the real data it says so and stops (exit 0).
set -euo pipefail
bin=${1:?usage: localize_kitti05.sh BIN_DIR WORK_DIR [--quick N]}
work=${2:?usage: localize_kitti05.sh BIN_DIR WORK_DIR [--quick N]}
shift 2
quick=""
if [[ "${1:-}" == "--quick" ]]; then quick=${2:?--quick takes a number of scans}; fi
source "$(dirname "$0")/k05_map.sh"
k05_map bench_localize "$bin" "$work" || exit 0

# Ours against PCL, scan by scan, one thread.
export OMP_NUM_THREADS=1
if [[ ! -x "$bin/bench_localize" ]]; then
  echo "bench_localize: skipped, built without PCL (install libpcl-dev); pl-localize alone follows"
else
  "$bin/bench_localize" "$drive" "$k05/maps.sqlite" --map k05 ${quick:+--quick "$quick"}
  echo
  echo "the floors: each scan from its ground-truth pose and 0.2 m from it (a run of its own)"
  "$bin/bench_localize" "$drive" "$k05/maps.sqlite" --map k05 --from-truth ${quick:+--quick "$quick"}
fi

# The whole product on the same protocol: pl-localize on the odd scans, pl-eval against their
# ground truth (every second line of the drive's poses, from the second: frames 1, 3, 5, ...).
echo
echo "whole product: pl-localize --beams 16 --scans odd --odometry lidar --init gt, then pl-eval ape"
if [[ -n "$quick" ]]; then head -n "$quick" "$k05/gt_odd.txt" >"$k05/gt_odd.quick" && mv "$k05/gt_odd.quick" "$k05/gt_odd.txt"; fi
export PL_NO_PROGRESS=1
"$bin/pl-localize" --dataset "$drive" --db "$k05/maps.sqlite" --map k05 --beams 16 --scans odd --odometry lidar \
  --init gt ${quick:+--count "$quick"} --out "$k05/odd.tum" --kitti-out "$k05/odd.txt" --timing "$k05/odd_timing.csv"
"$bin/pl-eval" ape --est "$k05/odd.txt" --gt "$k05/gt_odd.txt"
