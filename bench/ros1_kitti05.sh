#!/usr/bin/env bash
# The ROS 1 node on the real drive 0005, against pl-localize on the same bag: the drive's ROS 1 bag
# (tools/recordings/kitti_to_recordings.py, written by Debian's rosbag; made once) cut to its odd
# scans, played by `rosbag play --clock` into pl_localizer_node (started by its launch file, the
# paper's map of the even scans from a local store, 16 beams, LiDAR only, every scan registered);
# pl-localize on the same bag's odd scans with the same map, settings and start. Prints the APE of
# both against the OXTS poses of the odd scans and the largest distance between their poses, scan
# by scan.
#   bench/ros1_kitti05.sh BIN_DIR WORK_DIR   (BIN_DIR's build has the node: BIN_DIR/../ros1)
set -euo pipefail
bin=${1:?usage: ros1_kitti05.sh BIN_DIR WORK_DIR}
work=${2:?usage: ros1_kitti05.sh BIN_DIR WORK_DIR}
root=$(cd "$(dirname "$0")/.." && pwd)
ros1=$(cd "$bin/.." && pwd)/ros1
source "$root/bench/k05_map.sh"
k05_map ros1_kitti05 "$bin" "$work" || exit 0
if [[ ! -x "$ros1/lib/pl_localizer/pl_localizer_node" ]] || ! command -v rosmaster >/dev/null || ! command -v roslaunch >/dev/null; then
  echo "ros1_kitti05: skipped, the ROS 1 node is not built or rosmaster/roslaunch are not installed (docs/ros1.md)"
  exit 0
fi
export PL_NO_PROGRESS=1 OMP_NUM_THREADS=1
dir="$work/ros1"
mkdir -p "$dir"
dir=$(cd "$dir" && pwd)
if [[ ! -f "$dir/k05_odd.bag" ]]; then
  echo "converting drive 0005 to a ROS 1 bag of its odd scans in $dir (once)"
  "$bin/pl-dataset" poses "$drive" --format tum --out "$dir/gt.tum" >/dev/null
  /usr/bin/python3 "$root/tools/recordings/kitti_to_recordings.py" "$drive" "$dir/gt.tum" "$dir/k05" --formats bag
  /usr/bin/python3 - "$dir/k05.bag" "$dir/k05_odd.bag.partial" <<'PY'
import sys, rosbag
n = 0
with rosbag.Bag(sys.argv[2], 'w') as out:
    for topic, msg, t in rosbag.Bag(sys.argv[1]).read_messages():
        if topic == '/velodyne_points':
            n += 1
            if n % 2 == 1:  # the first cloud is scan 0: keep scans 1, 3, ...
                continue
        out.write(topic, msg, t)
PY
  mv "$dir/k05_odd.bag.partial" "$dir/k05_odd.bag"
fi

# The start: the first odd scan's OXTS pose as x, y, z, yaw (the node's base is the LiDAR here).
read -r x y z yaw < <(awk 'NR == 1 { printf "%.17g %.17g %.17g %.17g\n", $4, $8, $12, atan2($5, $1) * 180 / atan2(0, -1) }' "$k05/gt_odd.txt")
"$bin/pl-localize" --dataset "$dir/k05.bag" --truth-topic /ground_truth --db "$k05/maps.sqlite" --map k05 --beams 16 --scans odd \
  --odometry lidar --init "$x,$y,$z,$yaw" --init-search off --out "$dir/ref.tum" --kitti-out "$dir/ref.txt" >/dev/null

port=$((20000 + RANDOM % 20000))
export ROS_MASTER_URI=http://127.0.0.1:$port ROS_HOME=$dir/ros ROS_LOG_DIR=$dir/ros/log
export CMAKE_PREFIX_PATH=$ros1 ROS_PACKAGE_PATH=$ros1/share ROSCONSOLE_STDOUT_LINE_BUFFERED=1
pids=()
cleanup() { for p in "${pids[@]}"; do kill -INT -- -"$p" 2>/dev/null || true; done; sleep 1; }
trap cleanup EXIT
setsid rosmaster --core -p "$port" >"$dir/master.log" 2>&1 &
pids+=($!)
for _ in $(seq 50); do rosparam list >/dev/null 2>&1 && break; sleep 0.2; done
rosparam set /use_sim_time true
rosparam set /pl_localizer/initial_pose "[$x, $y, $z, 0, 0, $yaw]"
rosparam set /pl_localizer/initial_search false
rosparam set /pl_localizer/queue_scans true
rosparam set /pl_localizer/use_odometry false
rosparam set /pl_localizer/base_frame velodyne
rosparam set /pl_localizer/beams 16
setsid roslaunch pl_localizer localizer.launch store:="$k05/maps.sqlite" map:=k05 init:=pose respawn:=false \
  points:=/velodyne_points >"$dir/node.log" 2>&1 &
pids+=($!)
# The node's per-scan poses, until it has every odd scan.
scans=$(grep -vc '^#' "$dir/ref.txt")
setsid /usr/bin/python3 - "$dir/node.txt" "$scans" >"$dir/listen.log" 2>&1 <<'PY' &
import sys, time, rospy
from geometry_msgs.msg import PoseWithCovarianceStamped
out, want = sys.argv[1], int(sys.argv[2])
poses = []
def on_pose(m):
    p, q = m.pose.pose.position, m.pose.pose.orientation
    x, y, z, w = q.x, q.y, q.z, q.w
    r = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
         [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
         [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    poses.append([r[0][0], r[0][1], r[0][2], p.x, r[1][0], r[1][1], r[1][2], p.y, r[2][0], r[2][1], r[2][2], p.z])
rospy.init_node('bench_listen', anonymous=True)
rospy.Subscriber('/pl_localizer/pose', PoseWithCovarianceStamped, on_pose)
t = time.time()
while len(poses) < want and time.time() - t < 600:
    time.sleep(0.1)
with open(out, 'w') as f:
    f.write('# frame: lidar\n# frames: 1-%d:2\n' % (2 * len(poses) - 1))
    for p in poses:
        f.write(' '.join('%.17g' % v for v in p) + '\n')
print('poses', len(poses))
PY
pids+=($!)
listener=$!
sleep 3
rosbag play --clock -r 0.5 --wait-for-subscribers "$dir/k05_odd.bag" --topics /velodyne_points /tf_static >"$dir/play.log" 2>&1
wait "$listener" || true
node=$(grep -vc '^#' "$dir/node.txt" || true)
diff=$(paste -d' ' <(grep -v '^#' "$dir/node.txt") <(grep -v '^#' "$dir/ref.txt") |
  awk '{ d = sqrt(($4 - $16) ^ 2 + ($8 - $20) ^ 2 + ($12 - $24) ^ 2); if (d > m) m = d } END { printf "%.6f", m }')
echo
echo "| run | scans | APE mean (m) | median | RMSE | max |"
echo "|---|---|---|---|---|---|"
for run in ref node; do
  "$bin/pl-eval" ape --est "$dir/$run.txt" --gt "$k05/gt_odd.txt" --json | python3 -c "
import json, sys
text = sys.stdin.read()
a = json.loads(text[text.index('{'):])
print('| %s | %d | %.4f | %.4f | %.4f | %.4f |' % ('$run' == 'ref' and 'pl-localize on the bag' or 'pl_localizer_node, bag played', a['matched'], a['mean'], a['median'], a['rmse'], a['max']))"
done
echo
echo "node: $node of $scans scans; largest distance from pl-localize's poses, scan by scan: $(python3 -c "print('%.6f mm' % (1000 * $diff))")"
