#!/usr/bin/env bash
# Runs every benchmark, with the real data beside the repository when it is there.
#   bench/run.sh BIN_DIR     (PL_BENCH_BEFORE=REV: the earlier build the speed and size figures are set beside)
set -euo pipefail
bin=${1:?usage: bench/run.sh BIN_DIR}
root=$(cd "$(dirname "$0")/.." && pwd)
data=$("$root/tools/shared-data.sh" || true)
scan=""
# The build the speed and size figures are set beside: main before the work of 2026-12-07 on them.
before_rev=${PL_BENCH_BEFORE:-8f68d64}
before_bin=$(bash "$(dirname "$0")/before_build.sh" "$before_rev" "$root/build/bench")
if [[ -n "$data" ]]; then scan="$data/kitti-raw-2011_09_26_drive_0005_sync/velodyne_points/data/0000000000.bin"; fi

echo "== bench_voxel: voxel grid vs pcl::VoxelGrid"
if [[ -x "$bin/bench_voxel" ]]; then "$bin/bench_voxel" $scan; else echo "skipped: built without PCL (install libpcl-dev)"; fi

echo
echo "== bench_nearest: pl-eval map's nearest-neighbour queries vs nanoflann"
"$bin/bench_nearest"

echo
echo "== bench_sim: simulated scans per second, one core"
"$bin/bench_sim"

echo
echo "== bench_server: tile serving against nginx, ROI queries, tile compression"
bash "$(dirname "$0")/bench_server.sh" "$bin" "$root/build/bench"

echo
echo "== map_bytes: map bytes per attribute and the localizer's APE on each map, $before_rev's tiles beside these"
bash "$(dirname "$0")/map_bytes.sh" "$before_bin" "$bin" "$root/build/bench/map_bytes"

echo
echo "== viewer: the map viewer in headless Chromium (software WebGL) on loopback: time to first tiles, frames per second"
bash "$(dirname "$0")/viewer.sh" "$bin" "$root/build/bench"

echo
echo "== bench_localize: drive 0005, the paper's protocol (ours vs PCL)"
if [[ -n "$data" ]]; then
  bash "$(dirname "$0")/localize_kitti05.sh" "$bin" "$root/build/bench"
else
  echo "skipped: no real data (tools/shared-data.sh found none)"
fi

echo
echo "== localize_speed: drive 0005's protocol on one core, time a scan by stage, this build beside $before_rev and PCL"
bash "$(dirname "$0")/localize_speed.sh" "$before_bin" "$bin" "$root/build/bench"

echo
echo "== sim_vs_real: drive 0005 beside pl-sim on the same trajectory and protocol"
bash "$(dirname "$0")/sim_vs_real.sh" "$bin" "$root/build/bench"

echo
echo "== localize_rates: drive 0005 at 1-4x speed, LiDAR only, and a kidnapping"
bash "$(dirname "$0")/localize_rates.sh" "$bin" "$root/build/bench"

echo
echo "== k05_windows: drive 0005's protocol on windows of the drive (where the 1x error comes from)"
bash "$(dirname "$0")/k05_windows.sh" "$bin" "$root/build/bench"
echo
echo "== k05_stress: drive 0005 with a narrower field of view, other beam counts, faster, and starts given off the truth"
bash "$(dirname "$0")/k05_stress.sh" "$bin" "$root/build/bench"

echo
echo "== global_town: --init global (no pose) at 10 places of the simulated town loop, six months later, with traffic"
bash "$(dirname "$0")/global_town.sh" "$bin" "$root/build/bench"

echo
echo "== changes_town: change reports from three vehicles six months later, the tiles they agree changed, scored against pl-sim's truth"
bash "$(dirname "$0")/changes_town.sh" "$bin" "$root/build/bench/changes_town"

echo
echo "== localize_kitti00: the whole product on the KITTI 00 trajectory, all 4,541 scans (pl-sim data)"
bash "$(dirname "$0")/localize_kitti00.sh" "$bin" "$root/build/bench"

echo
echo "== gloam_kitti00: G-LOAM map building on the KITTI 00 trajectory, all 4,541 scans (pl-sim data)"
bash "$(dirname "$0")/gloam_kitti00.sh" "$bin" "$root/build/bench"

echo
echo "== gloam_speed: the whole G-LOAM build of 1,200 KITTI 00 scans and of the town, this build beside $before_rev"
bash "$(dirname "$0")/gloam_speed.sh" "$before_bin" "$bin" "$root/build/bench/gloam_speed"

echo
echo "== gloam_kitti05: G-LOAM on real data, KITTI raw drive 0005 with a consumer GPS"
bash "$(dirname "$0")/gloam_kitti05.sh" "$bin" "$root/build/bench"

echo
echo "== multi_drive_town: a town mapped from three drives with traffic: ghosts, static structure kept, the localizer on the map; 1 to 3 drives"
bash "$(dirname "$0")/multi_drive_town.sh" "$bin" "$root/build/bench/multi_drive_town"

echo
echo "== multi_drive_kitti05: drive 0005 cut in two and built as two drives, against the whole drive (real data)"
bash "$(dirname "$0")/multi_drive_kitti05.sh" "$bin" "$root/build/bench"

echo
echo "== add_drive: a drive added to a published map (--base-map) against the map built anew: tiles rebuilt and byte-identical"
bash "$(dirname "$0")/add_drive.sh" "$bin" "$root/build/bench"

echo
echo "== recordings_kitti05: drive 0005 as a ROS 1 bag (rosbag), a ROS 2 bag and MCAP, against the folder; reading speed"
bash "$(dirname "$0")/recordings_kitti05.sh" "$bin" "$root/build/bench"

echo
echo "== ros1_kitti05: the ROS 1 node on drive 0005's bag (rosbag play) against pl-localize on the same bag"
bash "$(dirname "$0")/ros1_kitti05.sh" "$bin" "$root/build/bench"

echo
echo "== fleet: a 25.8 km2 map in PostgreSQL, two replicas, Varnish and nginx, 2,000 virtual vehicles (pl-fleet); a replica killed, PostgreSQL restarted, tampering in the cache"
bash "$(dirname "$0")/fleet.sh" "$bin" "$root/build/bench/fleet"
