#!/usr/bin/env bash
# G-LOAM's speed, this build beside an earlier one, in one run: `pl-map build --poses lidar --gps
# --loops` on the first FRAMES (1,200) scans of the KITTI 00 trajectory simulated by pl-sim (64
# beams, per-point times, so motion compensation is on), whole process, and the demo's town loop.
# Prints, per build: the odometry's median a scan, the trajectory (odometry + graph + loops, reading
# included) a scan, the merge and writing a scan, the whole process a scan and its peak memory, and
# the trajectory's APE against the simulator's truth.
#   bench/gloam_speed.sh BEFORE_BIN_DIR BIN_DIR WORK_DIR [FRAMES]
set -euo pipefail
usage="usage: bench/gloam_speed.sh BEFORE_BIN_DIR BIN_DIR WORK_DIR [FRAMES]"
before=${1:?$usage}
bin=${2:?$usage}
work=${3:?$usage}
frames=${4:-1200}
source "$(dirname "$0")/kitti00_trajectory.sh"
export PL_NO_PROGRESS=1
before=$(cd "$before" && pwd)
bin=$(cd "$bin" && pwd)
mkdir -p "$work"
cd "$work"
if [[ ! -f k00/done ]]; then
  echo "simulating $frames scans of KITTI 00 ..."
  "$bin/pl-sim" --trajectory "$traj" --frames "$frames" --seed 1 --epoch 0 --out k00 --force >/dev/null
  touch k00/done
fi
if [[ ! -f town/done ]]; then
  "$bin/pl-sim" --route loop --out town --force >/dev/null
  touch town/done
fi

run() {  # NAME BIN DATASET
  local name=$1 b=$2 ds=$3
  /usr/bin/time -f "%e %M" -o "$name.time" "$b/pl-map" build --dataset "$ds" --poses lidar --gps --loops \
    --out "$name.pcd" --traj-out "$name.txt" --report "$name.json" >"$name.log"
  "$bin/pl-eval" ape --json --est "$name.txt" --gt "$ds/poses.txt" >"$name-ape.json"
}
for ds in k00 town; do
  run "$ds-before" "$before" "$ds"
  run "$ds-after" "$bin" "$ds"
done

python3 - <<'PY'
import json
def row(name):
    rep = json.load(open(f"{name}.json"))
    ape = json.load(open(f"{name}-ape.json"))
    wall, peak_kib = open(f"{name}.time").read().split()
    n = rep["scans"]
    whole = 1000 * float(wall) / n
    traj = rep["trajectory_ms_per_scan"]
    return n, rep["odometry"]["median_ms"], traj, whole - traj, whole, int(peak_kib) / 1024, ape["mean"], ape["max"]
for ds, what in (("k00", "KITTI 00 (pl-sim, 64 beams)"), ("town", "the demo's town loop (pl-sim, 64 beams)")):
    print(f"{what}")
    print(f"  {'build':8} {'scans':>6} {'odometry':>10} {'trajectory':>11} {'merge+write':>12} {'whole':>9} {'peak':>8} {'APE mean':>9} {'APE max':>8}")
    print(f"  {'':8} {'':>6} {'median ms':>10} {'ms a scan':>11} {'ms a scan':>12} {'ms/scan':>9} {'MiB':>8} {'m':>9} {'m':>8}")
    for b in ("before", "after"):
        n, odo, traj, merge, whole, peak, mean, mx = row(f"{ds}-{b}")
        print(f"  {b:8} {n:6d} {odo:10.1f} {traj:11.1f} {merge:12.1f} {whole:9.1f} {peak:8.0f} {mean:9.4f} {mx:8.4f}")
    (_, _, _, _, w0, *_), (_, _, _, _, w1, *_) = row(f"{ds}-before"), row(f"{ds}-after")
    print(f"  whole process: {w0 / w1:.2f} times as fast")
PY
