#!/usr/bin/env bash
# G-LOAM on real data: KITTI raw drive 2011_09_26_drive_0005 (154 HDL-64E scans, ~69 m) against its
# OXTS ground truth.
#   1. LiDAR odometry alone: APE and drift (end-point error over path length), and the path length
#      against the OXTS positions and against the OXTS velocities integrated over time
#   2. G-LOAM with the drive's GPS degraded to a consumer receiver (pl-dataset degrade-gps: 1 Hz,
#      sigma 1.5 m): APE raw, rigidly aligned (se3) and aligned with scale (sim3)
#   3. map crispness: the voxels the same scans occupy when merged at each trajectory's poses
#   4. an SVG top view of the map with the three trajectories
#   bench/gloam_kitti05.sh BIN_DIR WORK_DIR
set -euo pipefail
bin=${1:?usage: bench/gloam_kitti05.sh BIN_DIR WORK_DIR}
work=${2:?usage: bench/gloam_kitti05.sh BIN_DIR WORK_DIR}
root=$(cd "$(dirname "$0")/.." && pwd)
data=$("$root/tools/shared-data.sh" || true)
drive="$data/kitti-raw-2011_09_26_drive_0005_sync"
if [[ -z "$data" || ! -d "$drive" ]]; then
  echo "(skipped: drive 0005 is not beside the repository)"
  exit 0
fi
mkdir -p "$work/gloam-k05"
d=$(cd "$work/gloam-k05" && pwd)
export PL_NO_PROGRESS=1

"$bin/pl-dataset" poses "$drive" --out "$d/oxts.txt" >/dev/null
"$bin/pl-map" build --dataset "$drive" --poses lidar --out "$d/lidar-map.pcd" --traj-out "$d/lidar.txt" \
  --report "$d/lidar-report.json" >"$d/lidar.log"
# The same scans merged at the OXTS poses: a map is as crisp as its poses are consistent.
"$bin/pl-map" build --dataset "$drive" --poses gt --out "$d/oxts-map.pcd" >/dev/null
"$bin/pl-dataset" degrade-gps "$drive" --out "$d/consumer" --rate 1 --sigma 1.5 --seed 1 >"$d/consumer.log"
"$bin/pl-map" build --dataset "$d/consumer" --poses lidar --gps --loops --out "$d/gloam-map.pcd" --traj-out "$d/gloam.txt" \
  --report "$d/gloam-report.json" >"$d/gloam.log"
for est in lidar gloam; do
  for align in none se3 sim3; do
    "$bin/pl-eval" ape --json --align $align --est "$d/$est.txt" --gt "$d/oxts.txt" >"$d/$est-ape-$align.json"
  done
done
"$bin/pl-eval" topview --cloud "$d/gloam-map.pcd" --cell 0.25 --shade height --title "KITTI raw 2011_09_26_drive_0005: G-LOAM map" \
  --traj "$d/oxts.txt:OXTS ground truth" --traj "$d/gloam.txt:G-LOAM (LiDAR + 1 Hz consumer GPS)" \
  --traj "$d/lidar.txt:LiDAR odometry alone" --out "$d/top.svg" >/dev/null

python3 - "$d" "$drive" <<'PY'
import glob, json, math, os, sys
d, drive = sys.argv[1], sys.argv[2]
J = lambda n: json.load(open(os.path.join(d, n)))
def positions(path):
    return [tuple(float(v) for v in line.split()[3::4]) for line in open(path) if line.strip()]
def length(p):
    return sum(math.dist(p[i], p[i + 1]) for i in range(len(p) - 1))
gt, lo, gl = positions(f"{d}/oxts.txt"), positions(f"{d}/lidar.txt"), positions(f"{d}/gloam.txt")
# The OXTS velocities (forward, left) integrated over the OXTS timestamps: a second measure of the path.
rows = [[float(v) for v in open(f).read().split()] for f in sorted(glob.glob(f"{drive}/oxts/data/*.txt"))]
ts = []
for line in open(f"{drive}/oxts/timestamps.txt"):
    h, m, s = line.split()[1].split(":")
    ts.append(int(h) * 3600 + int(m) * 60 + float(s))
speed = [math.hypot(r[8], r[9]) for r in rows]
vel_len = sum(0.5 * (speed[i] + speed[i + 1]) * (ts[i + 1] - ts[i]) for i in range(len(rows) - 1))
posacc = sorted(r[23] for r in rows)
print(f"  OXTS path {length(gt):.2f} m from its positions (position accuracy it reports: median {posacc[len(posacc)//2]:.2f} m), "
      f"{vel_len:.2f} m from its velocities ({100 * (vel_len / length(gt) - 1):+.1f} %)")
end = math.dist(lo[-1], gt[-1])
print(f"  LiDAR odometry alone: path {length(lo):.2f} m ({100 * (length(lo) / length(gt) - 1):+.1f} % against the OXTS positions, "
      f"{100 * (length(lo) / vel_len - 1):+.2f} % against its velocities); end-point drift {end:.2f} m = {100 * end / length(gt):.2f} % of the path")
for est, name in (("lidar", "LiDAR odometry alone"), ("gloam", "G-LOAM, consumer GPS")):
    parts = []
    for align in ("none", "se3", "sim3"):
        a = J(f"{est}-ape-{align}.json")
        extra = f" (scale {a['scale']:.4f})" if align == "sim3" and "scale" in a else ""
        parts.append(f"{align} {a['mean']:.3f}/{a['median']:.3f}/{a['rmse']:.3f}{extra}")
    print(f"  {name:<22} APE mean/median/RMSE [m]: " + ", ".join(parts))
def voxels(name):
    with open(os.path.join(d, name), "rb") as f:
        for line in f:
            if line.startswith(b"POINTS"): return int(line.split()[1])
print(f"  map crispness (0.2 m voxels the same 154 scans occupy; fewer = sharper): at the OXTS poses {voxels('oxts-map.pcd')}, "
      f"LiDAR odometry {voxels('lidar-map.pcd')}, G-LOAM {voxels('gloam-map.pcd')}")
r = J("gloam-report.json")
pg = r.get("pose_graph", {})
print(f"  pose graph: {pg.get('keyframes')} keyframes, {pg.get('gps_edges')} GPS edges ({pg.get('gps_outliers')} outliers), "
      f"GPS residual RMS {pg.get('gps_rms_before_m', 0):.2f} -> {pg.get('gps_rms_after_m', 0):.2f} m; loops accepted {r.get('loops', {}).get('accepted')}")
print(f"  top view: {d}/top.svg")
PY
