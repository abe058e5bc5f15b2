#!/usr/bin/env bash
# G-LOAM on the real KITTI 00 trajectory simulated by pl-sim (64 beams, all 4,541 scans, or a prefix):
#   1. LiDAR odometry alone          -> KITTI relative translation error (target <= 1.0 %)
#   2. odometry + noisy GPS + loops  -> APE against the ground truth (target <= 0.10 m), loops, speed
#   3. the G-LOAM map against the simulator's reference cloud at 0.1 m spacing (target: 95 % of the
#      points within 5 cm of its surface),
#      beside the map merged at ground-truth poses (the floor of the voxel merge)
#   4. the localizer (16 beams, encoders, epoch 1 with 30 trucks) on the G-LOAM map and on the
#      ground-truth map, same run (target: <= 0.02 m more mean APE)
#   bench/gloam_kitti00.sh BIN_DIR WORK_DIR [FRAMES]
set -euo pipefail
bin=${1:?usage: bench/gloam_kitti00.sh BIN_DIR WORK_DIR [FRAMES]}
work=${2:?usage: bench/gloam_kitti00.sh BIN_DIR WORK_DIR [FRAMES]}
frames=${3:-}
source "$(dirname "$0")/kitti00_trajectory.sh"
mkdir -p "$work"
work=$(cd "$work" && pwd)
d="$work/gloam-k00${frames:+-$frames}"
frame_flag=()
[[ -n "$frames" ]] && frame_flag=(--frames "$frames")
export PL_NO_PROGRESS=1
mkdir -p "$d"

t0=$(date +%s)
# The drives are the localizer benchmark's (bench/localize_kitti00.sh: same seed and options, same
# bytes): linked when it has made them, simulated here otherwise.
shared="$work/k00${frames:+-$frames}"
# `done` names the simulator's sweep: drives swept the other way (before 2026-12-03) are made again.
if ! grep -qx "sweep ccw" "$d/done" 2>/dev/null; then
  rm -rf "$d/e0" "$d/e1"
  if grep -qx "sweep ccw" "$shared/done" 2>/dev/null; then
    ln -s "$shared/e0" "$d/e0"
    ln -s "$shared/e1" "$d/e1"
  else
    echo "simulating the epoch-0 drive and the epoch-1 drive with 30 trucks ..."
    "$bin/pl-sim" --trajectory "$traj" "${frame_flag[@]}" --seed 1 --epoch 0 --out "$d/e0" >/dev/null
    "$bin/pl-sim" --trajectory "$traj" "${frame_flag[@]}" --seed 1 --epoch 1 --traffic 30 --truck-share 1.0 --out "$d/e1" >/dev/null
  fi
  echo "the map at ground-truth poses ..."
  "$bin/pl-map" build --dataset "$d/e0" --poses gt --out "$d/gt-map.pcd" >/dev/null
  rm -f "$d/gt-maps.sqlite"*
  "$bin/pl-map" tile --cloud "$d/gt-map.pcd" --db "$d/gt-maps.sqlite" --map k00 >/dev/null
  "$bin/pl-map" publish --db "$d/gt-maps.sqlite" --map k00 --version 1 >/dev/null
  echo "sweep ccw" >"$d/done"
fi
if [[ ! -f "$d/reference-0.1.pcd" ]]; then
  # The world of the epoch-0 drive sampled every 0.1 m (pl-sim builds it along the frames simulated,
  # so the drive is simulated again, into a scratch folder).
  echo "the simulator's reference cloud of the world (0.1 m spacing) ..."
  "$bin/pl-sim" --trajectory "$traj" "${frame_flag[@]}" --seed 1 --epoch 0 --out "$d/scratch" --force \
    --map-out "$d/reference-0.1.pcd.tmp" --map-spacing 0.1 >/dev/null
  rm -rf "$d/scratch"
  mv "$d/reference-0.1.pcd.tmp" "$d/reference-0.1.pcd"
fi
echo "data ready in $(( $(date +%s) - t0 )) s"

echo "LiDAR odometry alone ..."
"$bin/pl-map" build --dataset "$d/e0" --poses lidar --out "$d/lidar-map.pcd" --traj-out "$d/lidar.txt" \
  --report "$d/lidar-report.json" >"$d/lidar.log"
"$bin/pl-eval" kitti --json --est "$d/lidar.txt" --gt "$d/e0/poses.txt" >"$d/lidar-kitti.json" 2>/dev/null || echo '{}' >"$d/lidar-kitti.json"
"$bin/pl-eval" ape --json --est "$d/lidar.txt" --gt "$d/e0/poses.txt" >"$d/lidar-ape.json"

echo "G-LOAM: odometry + GPS + loop closures ..."
/usr/bin/time -f "%e s wall, %M KiB peak" -o "$d/gloam.time" \
  "$bin/pl-map" build --dataset "$d/e0" --poses lidar --gps --loops --out "$d/gloam-map.pcd" --traj-out "$d/gloam.txt" \
  --report "$d/gloam-report.json" >"$d/gloam.log"
"$bin/pl-eval" ape --json --est "$d/gloam.txt" --gt "$d/e0/poses.txt" >"$d/gloam-ape.json"
"$bin/pl-eval" kitti --json --est "$d/gloam.txt" --gt "$d/e0/poses.txt" >"$d/gloam-kitti.json" 2>/dev/null || echo '{}' >"$d/gloam-kitti.json"

echo "map accuracy against the reference cloud ..."
"$bin/pl-eval" map --json --map "$d/gloam-map.pcd" --ref "$d/reference-0.1.pcd" >"$d/gloam-map-accuracy.json"
"$bin/pl-eval" map --json --metric point --map "$d/gloam-map.pcd" --ref "$d/reference-0.1.pcd" >"$d/gloam-map-accuracy-point.json"
"$bin/pl-eval" map --json --map "$d/gt-map.pcd" --ref "$d/reference-0.1.pcd" >"$d/gt-map-accuracy.json"

echo "the localizer on both maps (epoch 1, 30 trucks, 16 beams, encoders) ..."
rm -f "$d/gloam-maps.sqlite"*
"$bin/pl-map" tile --cloud "$d/gloam-map.pcd" --db "$d/gloam-maps.sqlite" --map k00 >/dev/null
"$bin/pl-map" publish --db "$d/gloam-maps.sqlite" --map k00 --version 1 >/dev/null
for m in gt gloam; do
  "$bin/pl-localize" --dataset "$d/e1" --db "$d/$m-maps.sqlite" --map k00 --beams 16 --odometry encoder --init gps \
    --out "$d/localize-$m.tum" --kitti-out "$d/localize-$m.txt" >"$d/localize-$m.log"
  "$bin/pl-eval" ape --json --est "$d/localize-$m.txt" --gt "$d/e1/poses.txt" >"$d/localize-$m.json"
done

python3 - "$d" <<'PY'
import json, os, sys, re
d = sys.argv[1]
J = lambda n: json.load(open(os.path.join(d, n)))
def num(j, *keys):
    for k in keys:
        if isinstance(j, dict) and k in j: j = j[k]
        else: return float("nan")
    return j
lk, gk = J("lidar-kitti.json"), J("gloam-kitti.json")
la, ga = J("lidar-ape.json"), J("gloam-ape.json")
rep = J("gloam-report.json")
loops, pg = rep.get("loops", {}), rep.get("pose_graph", {})
acc, gacc, pacc = J("gloam-map-accuracy.json"), J("gt-map-accuracy.json"), J("gloam-map-accuracy-point.json")
lg, lt = J("localize-gloam.json"), J("localize-gt.json")
def share(a, dist=0.05):
    for s in a.get("shares", []):
        if abs(s["distance_m"] - dist) < 1e-9: return 100 * s["share"]
    return float("nan")
tm = open(os.path.join(d, "gloam.time")).read().strip()
print(f"  scans {rep['scans']}")
print(f"  odometry alone      KITTI t_err {num(lk, 'translation_pct'):.3f} % (target <= 1.0), r_err {num(lk, 'rotation_deg_per_100m'):.4f} deg/100 m; "
      f"APE mean {la['mean']:.3f} m, max {la['max']:.3f} m")
print(f"  G-LOAM              APE mean {ga['mean']:.4f} / median {ga['median']:.4f} / RMSE {ga['rmse']:.4f} / max {ga['max']:.4f} m (target mean <= 0.10); "
      f"KITTI t_err {num(gk, 'translation_pct'):.4f} %")
print(f"  pose graph          {pg.get('keyframes')} keyframes, {pg.get('gps_edges')} GPS edges ({pg.get('gps_outliers')} outliers), "
      f"GPS residual RMS {pg.get('gps_rms_before_m', 0):.3f} -> {pg.get('gps_rms_after_m', 0):.3f} m; {pg.get('solves')} solves, {pg.get('solve_ms', 0):.0f} ms")
print(f"  loops               {loops.get('queries')} queries, proposed {loops.get('proposed_by_position')} by position + {loops.get('proposed_by_place')} by place; "
      f"{loops.get('accepted')} accepted, {loops.get('rejected')} rejected {loops.get('rejected_by_reason')}; "
      f"loop residual median {loops.get('residual_before_m', 0):.3f} -> {loops.get('residual_after_m', 0):.4f} m; verifying {loops.get('verify_ms', 0) / 1000:.1f} s")
print(f"  error vs truth      odometry {rep.get('mean_error_before_m', 0):.3f} m -> + GPS {rep.get('mean_error_gps_m', 0):.4f} m -> + loops {rep.get('mean_error_after_m', 0):.4f} m (mean)")
print(f"  speed               odometry median {rep['odometry']['median_ms']:.1f} ms a scan (target <= 50); whole trajectory "
      f"{rep['trajectory_ms_per_scan']:.1f} ms a scan (odometry + graph + loops, one thread); pl-map build {tm}")
print(f"  map accuracy        G-LOAM map: {share(acc):.1f} % of {acc['map_points']} points within 5 cm of the reference (target >= 95), "
      f"median {num(acc, 'median') * 100:.1f} cm, p95 {acc['p95'] * 100:.1f} cm; ground-truth-pose map: {share(gacc):.1f} %, "
      f"median {num(gacc, 'median') * 100:.1f} cm; by the point metric (bounded below by the reference's "
      f"{acc.get('reference_spacing_m', 0) * 100:.0f} cm spacing) the G-LOAM map has {share(pacc):.1f} % within 5 cm")
print(f"  localizer           on the G-LOAM map APE mean {lg['mean']:.4f} m, on the ground-truth map {lt['mean']:.4f} m: "
      f"{lg['mean'] - lt['mean']:+.4f} m (target <= +0.02)")
PY
