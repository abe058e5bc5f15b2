#!/usr/bin/env bash
# The simulator held against the street: the real drive 0005 (KITTI raw, 154 HDL-64E scans) beside
# pl-sim driving the same trajectory (its OXTS poses, LiDAR frame) through a procedural town, on the
# same protocol (map from the even scans at their ground-truth poses, the odd scans localized with
# 16 of 64 beams, LiDAR odometry, from the first odd scan's pose). Per drive: points a scan after
# preparation, inlier share at delta, point-to-plane residual RMS after registration, conditioning
# (from pl-localize's per-scan CSV), scan-to-scan agreement of the LiDAR odometry with the ground
# truth (pl-map build --poses lidar, all 64 beams, consecutive scans), and APE. Three simulated
# drives: today's simulator (swept, calibration errors) with its exact truth; the same with its
# truth written as an INS reports it (--truth-error 1: the real drive's truth is OXTS's estimate,
# and its map is built at it); and today's world seen by the first simulator's sensor (one pose a
# scan, a perfect sensor) for comparison.
#   bench/sim_vs_real.sh BIN_DIR WORK_DIR
set -euo pipefail
bin=${1:?usage: bench/sim_vs_real.sh BIN_DIR WORK_DIR}
work=${2:?usage: bench/sim_vs_real.sh BIN_DIR WORK_DIR}
source "$(dirname "$0")/k05_map.sh"
k05_map sim_vs_real "$bin" "$work" || exit 0
export PL_NO_PROGRESS=1
out="$work/sim_vs_real"
mkdir -p "$out"

# localize NAME DRIVE MAP_DB: the protocol's odd scans, per-scan CSV and APE.
localize() {
  local name=$1 drive=$2 db=$3
  "$bin/pl-dataset" poses "$drive" --out "$out/$name.gt.txt" >/dev/null
  grep -v '^#' "$out/$name.gt.txt" | awk 'NR % 2 == 0' >"$out/$name.gt_odd.txt"
  "$bin/pl-localize" --dataset "$drive" --db "$db" --map m --beams 16 --scans odd --odometry lidar --init gt \
    --out "$out/$name.tum" --kitti-out "$out/$name.odd.txt" --timing "$out/$name.csv" >"$out/$name.log"
  "$bin/pl-eval" ape --json --est "$out/$name.odd.txt" --gt "$out/$name.gt_odd.txt" >"$out/$name.ape.json"
  "$bin/pl-map" build --dataset "$drive" --poses lidar --traj-out "$out/$name.loam.txt" --out "$out/$name.loam.pcd" >/dev/null
}

# The real drive, on its own map (k05_map built it as map k05; a copy named m keeps the calls alike).
if [[ ! -f "$out/real.db" ]]; then
  "$bin/pl-map" tile --cloud "$k05/even.pcd" --db "$out/real.db.partial" --map m >/dev/null
  "$bin/pl-map" publish --db "$out/real.db.partial" --map m --version 1 >/dev/null
  mv "$out/real.db.partial" "$out/real.db"
fi
localize real "$drive" "$out/real.db"

# sim NAME PL_SIM_FLAGS...: the same trajectory simulated, its own even-scan map, the same protocol.
sim() {
  local name=$1
  shift
  "$bin/pl-dataset" poses "$drive" --out "$out/traj.txt" >/dev/null
  "$bin/pl-sim" --trajectory "$out/traj.txt" --lidar-poses --seed 3 --traffic 4 --out "$out/$name.drive" --force "$@" >/dev/null
  rm -f "$out/$name.db"*
  "$bin/pl-map" build --dataset "$out/$name.drive" --poses gt --every 2 --out "$out/$name.even.pcd" >/dev/null
  "$bin/pl-map" tile --cloud "$out/$name.even.pcd" --db "$out/$name.db" --map m >/dev/null
  "$bin/pl-map" publish --db "$out/$name.db" --map m --version 1 >/dev/null
  localize "$name" "$out/$name.drive" "$out/$name.db"
}
sim sim
sim sim-ins --truth-error 1
sim sim-first-wave --sweep off --calibration-error 0

python3 - "$out" <<'PY'
import csv, json, math, statistics as st, sys
out = sys.argv[1]

def poses(path):
    rows = []
    for line in open(path):
        if line.startswith('#'):  # the header: what frame, which scans
            continue
        v = [float(x) for x in line.split()]
        if len(v) == 12:
            rows.append([v[0:4], v[4:8], v[8:12]])
    return rows

def inv_mul(a, b):  # a^-1 b for 3x4 rigid poses
    R = [[a[r][c] for c in range(3)] for r in range(3)]
    t = [a[r][3] for r in range(3)]
    Rt = [[R[c][r] for c in range(3)] for r in range(3)]
    out = []
    for r in range(3):
        row = [sum(Rt[r][k] * b[k][c] for k in range(3)) for c in range(3)]
        row.append(sum(Rt[r][k] * (b[k][3] - t[k]) for k in range(3)))
        out.append(row)
    return out

def step_errors(est, gt):
    te, re, along, steps = [], [], [], []
    for i in range(1, min(len(est), len(gt))):
        de, dg = inv_mul(est[i - 1], est[i]), inv_mul(gt[i - 1], gt[i])
        e = inv_mul(dg, de)
        te.append(math.sqrt(sum(e[r][3] ** 2 for r in range(3))))
        along.append(e[0][3])
        steps.append(math.sqrt(sum(dg[r][3] ** 2 for r in range(3))))
        tr = (e[0][0] + e[1][1] + e[2][2] - 1) / 2
        re.append(math.degrees(math.acos(max(-1.0, min(1.0, tr)))))
    return te, re, 100 * sum(along) / max(1e-9, sum(steps))

figures = {}
for name in ["real", "sim", "sim-ins", "sim-first-wave"]:
    rows = list(csv.DictReader(open(f"{out}/{name}.csv")))
    col = lambda c: st.median(float(r[c]) for r in rows)
    est, gt = poses(f"{out}/{name}.loam.txt"), poses(f"{out}/{name}.gt.txt")
    te, re, along_pct = step_errors(est, gt)
    # How far the truth's height departs from the LiDAR odometry's over the drive (both from the first scan).
    height = max(abs((e[2][3] - est[0][2][3]) - (g[2][3] - gt[0][2][3])) for e, g in zip(est, gt))
    ape = json.load(open(f"{out}/{name}.ape.json"))
    figures[name] = {
        "points a scan after preparation (median)": col("points"),
        "inlier share at delta (median)": col("inlier_share"),
        "residual RMS after registration, m (median)": col("rms_m"),
        "conditioning (median)": col("conditioning"),
        "scan-to-scan translation error, cm (median)": 100 * st.median(te),
        "scan-to-scan rotation error, deg (median)": st.median(re),
        "odometry's steps longer than the truth's, %": along_pct,
        "truth's height off the odometry's, m (max)": height,
        "APE mean, m": ape["mean"],
    }
print(f"{'':46} {'real 0005':>10} {'sim':>10} {'sim/real':>9} {'INS truth':>10} {'ins/real':>9} {'one pose':>11} {'op/real':>8}")
for k in figures["real"]:
    r, s, i, f = figures["real"][k], figures["sim"][k], figures["sim-ins"][k], figures["sim-first-wave"][k]
    ratio = lambda x: f"{x / r:.2f}" if r else "-"
    off = lambda x: r and abs(x / r - 1) > 0.3
    flag = "  <-- differs > 30 %" + ("" if off(s) else " (INS truth)") + ("" if off(i) else " (exact truth)") if off(s) or off(i) else ""
    print(f"{k:46} {r:10.4g} {s:10.4g} {ratio(s):>9} {i:10.4g} {ratio(i):>9} {f:11.4g} {ratio(f):>8}{flag}")
json.dump(figures, open(f"{out}/table.json", "w"), indent=1)
PY
