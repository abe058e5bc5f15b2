#!/usr/bin/env bash
# The real drive 0005 as a robot's recordings: converted once (tools/recordings/kitti_to_recordings.py)
# to a ROS 1 bag written by Debian's python3-rosbag, a ROS 2 bag (.db3) and an MCAP file, each holding
# the clouds (with a ring field), the OXTS ground truth on /ground_truth, the OXTS fixes and
# /tf_static. On each, and on the KITTI folder, the paper's protocol: pl-map build of the even scans
# at their ground-truth poses, tiled and published; pl-localize of the odd scans with 16 beams, LiDAR
# only, from the first odd scan's pose; pl-eval ape. Prints each run's APE and the largest distance
# between its poses and the folder run's, scan by scan (the issue asks for 1 mm at most); then the
# reading speed of the bag's clouds beside a plain read of the same file (bench_recordings).
#   bench/recordings_kitti05.sh BIN_DIR WORK_DIR
set -euo pipefail
bin=${1:?usage: recordings_kitti05.sh BIN_DIR WORK_DIR}
work=${2:?usage: recordings_kitti05.sh BIN_DIR WORK_DIR}
root=$(cd "$(dirname "$0")/.." && pwd)
source "$root/bench/k05_map.sh"
k05_map recordings_kitti05 "$bin" "$work" || exit 0
if ! /usr/bin/python3 -c 'import rosbag, sensor_msgs.msg' 2>/dev/null; then
  echo "recordings_kitti05: skipped, Debian's python3-rosbag and python3-sensor-msgs are not installed"
  exit 0
fi
export PL_NO_PROGRESS=1 OMP_NUM_THREADS=1
rec="$work/recordings"
mkdir -p "$rec"
if [[ ! -f "$rec/done" || ! -f "$rec/k05_pcl_xyzi.bag" ]]; then
  echo "converting drive 0005 to a ROS 1 bag, a ROS 2 bag and an MCAP file in $rec (once)"
  "$bin/pl-dataset" poses "$drive" --format tum --out "$rec/gt.tum" >/dev/null
  start=$(date +%s)
  /usr/bin/python3 "$root/tools/recordings/kitti_to_recordings.py" "$drive" "$rec/gt.tum" "$rec/k05"
  /usr/bin/python3 "$root/tools/recordings/kitti_to_recordings.py" "$drive" "$rec/gt.tum" "$rec/k05_plain" --formats bag --bag-compression none
  # As other tools lay the clouds out: the Velodyne driver's fields with every time 0, and PCL's PointXYZI.
  /usr/bin/python3 "$root/tools/recordings/kitti_to_recordings.py" "$drive" "$rec/gt.tum" "$rec/k05_zero_time" --formats bag --layout velodyne-zero-time
  /usr/bin/python3 "$root/tools/recordings/kitti_to_recordings.py" "$drive" "$rec/gt.tum" "$rec/k05_pcl_xyzi" --formats bag --layout pcl-xyzi
  echo "converted in $(($(date +%s) - start)) s" >"$rec/done"
fi
cat "$rec/done"

# One protocol run: map, tiles, localization, APE; its poses in $rec/NAME.txt.
protocol() {
  local name=$1 dataset=$2
  shift 2
  local dir="$rec/$name"
  mkdir -p "$dir"
  rm -f "$dir/maps.sqlite"*
  local t0
  t0=$(date +%s.%N)
  "$bin/pl-map" build --dataset "$dataset" --poses gt --every 2 --out "$dir/even.pcd" "$@" >/dev/null
  local t1
  t1=$(date +%s.%N)
  "$bin/pl-map" tile --cloud "$dir/even.pcd" --db "$dir/maps.sqlite" --map k05 >/dev/null
  "$bin/pl-map" publish --db "$dir/maps.sqlite" --map k05 --version 1 >/dev/null
  "$bin/pl-localize" --dataset "$dataset" --db "$dir/maps.sqlite" --map k05 --beams 16 --scans odd --odometry lidar --init gt \
    --out "$dir/odd.tum" --kitti-out "$dir/odd.txt" "$@" >/dev/null
  local t2
  t2=$(date +%s.%N)
  local ape
  ape=$("$bin/pl-eval" ape --est "$dir/odd.txt" --gt "$k05/gt_odd.txt" --json)
  local diff="-"
  if [[ -f "$rec/folder/odd.txt" && "$name" != folder ]]; then
    diff=$(paste -d' ' <(grep -v '^#' "$dir/odd.txt") <(grep -v '^#' "$rec/folder/odd.txt") |
      awk '{ d = sqrt(($4 - $16) ^ 2 + ($8 - $20) ^ 2 + ($12 - $24) ^ 2); if (d > m) m = d } END { printf "%.6f", m }')
  fi
  python3 - "$name" "$ape" "$diff" "$(echo "$t1 - $t0" | bc)" "$(echo "$t2 - $t1" | bc)" <<'PY'
import json, sys
name, ape, diff, tmap, tloc = sys.argv[1], json.loads(sys.argv[2]), sys.argv[3], float(sys.argv[4]), float(sys.argv[5])
print("| %s | %.4f | %.4f | %.4f | %.4f | %s | %.1f s | %.1f s |" % (name, ape["mean"], ape["median"], ape["rmse"], ape["max"],
      diff if diff == "-" else "%.3f mm" % (1000 * float(diff)), tmap, tloc))
PY
}

echo
echo "| input | APE mean (m) | median | RMSE | max | largest distance from the folder run's poses | pl-map build | tiles + pl-localize |"
echo "|---|---|---|---|---|---|---|---|"
protocol folder "$drive"
protocol "ROS 1 bag (rosbag, lz4 chunks)" "$rec/k05.bag" --truth-topic /ground_truth
protocol "ROS 2 bag (.db3, CDR)" "$rec/k05_ros2" --truth-topic /ground_truth
protocol "MCAP (CDR)" "$rec/k05.mcap" --truth-topic /ground_truth
protocol "ROS 1 bag, Velodyne layout, time all 0" "$rec/k05_zero_time.bag" --truth-topic /ground_truth
protocol "ROS 1 bag, PCL PointXYZI (no ring)" "$rec/k05_pcl_xyzi.bag" --truth-topic /ground_truth

# The localizer alone: each recording on the folder's map, started from the same pose given as
# numbers (--init X,Y,Z,YAW), so that nothing but the reading differs.
echo
echo "the localizer alone, on the folder's map from the same given start: largest distance from the folder run's poses"
start=$(awk 'NR == 1 { printf "%.17g,%.17g,%.17g,%.17g", $4, $8, $12, atan2($5, $1) }' "$k05/gt_odd.txt")
alone() {
  local name=$1 dataset=$2
  shift 2
  "$bin/pl-localize" --dataset "$dataset" --db "$rec/folder/maps.sqlite" --map k05 --beams 16 --scans odd --odometry lidar \
    --init "$start" --out "$rec/alone.tum" --kitti-out "$rec/alone_$name.txt" "$@" >/dev/null
}
alone folder "$drive"
for f in k05.bag k05_ros2 k05.mcap k05_zero_time.bag k05_pcl_xyzi.bag; do
  alone "$f" "$rec/$f" --truth-topic /ground_truth
  paste -d' ' <(grep -v '^#' "$rec/alone_$f.txt") <(grep -v '^#' "$rec/alone_folder.txt") |
    awk -v f="$f" '{ d = sqrt(($4 - $16) ^ 2 + ($8 - $20) ^ 2 + ($12 - $24) ^ 2); if (d > m) m = d } END { printf "  %s: %.6f mm over %d scans\n", f, 1000 * m, NR }'
done

echo
echo "reading speed, one core: the clouds read and decoded beside a plain read of the same file"
"$bin/bench_recordings" "$rec/k05_plain.bag" "$rec/k05.bag" "$rec/k05.mcap" "$rec/k05_ros2"
