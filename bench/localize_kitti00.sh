#!/usr/bin/env bash
# The whole product on the real KITTI 00 trajectory (all 4,541 scans), simulated by pl-sim: the map
# from the epoch-0 drive's ground-truth poses -> tiles -> pl-server -> pl-localize over HTTP with 16
# of 64 beams and wheel-encoder odometry -> pl-eval ape. Three drives: the same epoch with 360 deg,
# with 180 deg (the rear half blocked), and six months later (epoch 1) with 30 moving trucks. Then the
# rates of bench/localize_rates.sh on the epoch-0 drive, on the paper's protocol: its odd scans on a map
# of its even ones, LiDAR only, from the first scan's pose with no velocity, every k-th for k = 1..4
# (the drive at 1-4 times its speed).
# The scans are swept over 0.1 s and carry per-laser calibration errors (pl-sim's defaults).
#   bench/localize_kitti00.sh BIN_DIR WORK_DIR [FRAMES]
set -euo pipefail
bin=${1:?usage: bench/localize_kitti00.sh BIN_DIR WORK_DIR [FRAMES]}
work=${2:?usage: bench/localize_kitti00.sh BIN_DIR WORK_DIR [FRAMES]}
frames=${3:-}
source "$(dirname "$0")/kitti00_trajectory.sh"
mkdir -p "$work"
work=$(cd "$work" && pwd)
tag="k00${frames:+-$frames}"
frame_flag=()
[[ -n "$frames" ]] && frame_flag=(--frames "$frames")

export PL_NO_PROGRESS=1
t0=$(date +%s)
# `done` names the simulator's sweep: drives swept the other way (before 2026-12-03) are made again.
if ! grep -qx "sweep ccw" "$work/$tag/done" 2>/dev/null; then
  rm -rf "$work/$tag"
  mkdir -p "$work/$tag"
  echo "simulating the epoch-0 drive and the epoch-1 drive with 30 trucks ($([[ -n "$frames" ]] && echo "$frames" || echo all) frames) ..."
  "$bin/pl-sim" --trajectory "$traj" "${frame_flag[@]}" --seed 1 --epoch 0 --out "$work/$tag/e0" >/dev/null
  "$bin/pl-sim" --trajectory "$traj" "${frame_flag[@]}" --seed 1 --epoch 1 --traffic 30 --truck-share 1.0 \
    --out "$work/$tag/e1" >/dev/null
  echo "building the map from the epoch-0 drive ..."
  "$bin/pl-map" build --dataset "$work/$tag/e0" --poses gt --out "$work/$tag/map.pcd" >/dev/null
  "$bin/pl-map" tile --cloud "$work/$tag/map.pcd" --db "$work/$tag/maps.sqlite" --map k00 >/dev/null
  "$bin/pl-map" publish --db "$work/$tag/maps.sqlite" --map k00 --version 1 >/dev/null
  echo "sweep ccw" >"$work/$tag/done"
fi
echo "data ready in $(( $(date +%s) - t0 )) s: $("$bin/pl-map" info --db "$work/$tag/maps.sqlite" --map k00 | head -1)"

source "$root/tools/start-server.sh"
start_server "$work/$tag/server.log" "$bin/pl-server" --db "$work/$tag/maps.sqlite" --listen 127.0.0.1:0 --threads 1
server=$SERVER_PID
trap 'kill $server 2>/dev/null || true' EXIT
url=$SERVER_URL

run() {  # name drive extra-flags...
  local name=$1 drive=$2
  shift 2
  rm -f "$work/$tag/cache-$name.sqlite"*
  "$bin/pl-localize" --dataset "$work/$tag/$drive" --server "$url" --map k00 --beams 16 --odometry encoder \
    --init gps --cache "$work/$tag/cache-$name.sqlite" "$@" \
    --out "$work/$tag/$name.tum" --kitti-out "$work/$tag/$name.txt" --timing "$work/$tag/$name.csv" >"$work/$tag/$name.log"
  "$bin/pl-eval" ape --json --est "$work/$tag/$name.txt" --gt "$work/$tag/$drive/poses.txt" >"$work/$tag/$name.json"
  "$bin/pl-eval" timing --json --csv "$work/$tag/$name.csv" --column registration_ms >"$work/$tag/$name-timing.json"
  python3 - "$name" "$work/$tag/$name" <<'PY'
import json, re, sys
name, base = sys.argv[1], sys.argv[2]
a = json.load(open(base + ".json"))
t = json.load(open(base + "-timing.json"))
log = open(base + ".log").read()
status = re.search(r"status: (.*);", log)
hz = re.search(r"\(([\d.]+) Hz", log)
print(f"  {name:<16} APE mean {a['mean']:.3f} / median {a['median']:.3f} / RMSE {a['rmse']:.3f} / max {a['max']:.3f} m, "
      f"coverage {100 * a['coverage']:.1f} %; registration median {t['p50']:.2f} ms, p99 {t['p99']:.2f} ms; "
      f"fused {hz[1] if hz else '?'} Hz; {status[1] if status else ''}")
PY
}

echo "pl-localize over HTTP, 16 of 64 beams, encoder odometry (paper, KITTI 00: 0.228 / 0.142 / 0.325 m):"
run same-epoch e0
run fov180 e0 --fov 180
run epoch1-trucks e1
kill -TERM $server && wait $server || true
trap - EXIT

echo
echo "LiDAR only, the paper's protocol: the odd scans every k-th on a map of the even ones (pl-localize --db, 16 beams, --odometry lidar --init gt):"
if [[ ! -f "$work/$tag/even.sqlite" ]]; then
  "$bin/pl-map" build --dataset "$work/$tag/e0" --poses gt --every 2 --out "$work/$tag/even.pcd" >/dev/null
  rm -f "$work/$tag/even.sqlite.partial"*
  "$bin/pl-map" tile --cloud "$work/$tag/even.pcd" --db "$work/$tag/even.sqlite.partial" --map k00 >/dev/null
  "$bin/pl-map" publish --db "$work/$tag/even.sqlite.partial" --map k00 --version 1 >/dev/null
  mv "$work/$tag/even.sqlite.partial" "$work/$tag/even.sqlite"
fi
rates_drive=$work/$tag/e0 rates_db=$work/$tag/even.sqlite rates_map=k00 rates_out=$work/$tag/rates-even
mkdir -p "$rates_out"
source "$root/bench/rates_run.sh"
awk 'NR % 2 == 0' "$rates_drive/poses.txt" >"$rates_out/gt_odd.txt"
echo "| run | scans | APE mean | median | max | > 0.5 m | of them ok | ok / degraded / lost | error > PL | PL median | ms median (odometry + registration + checks) |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for k in 1 2 3 4; do
  awk -v k="$k" '(NR - 1) % k == 0' "$rates_out/gt_odd.txt" >"$rates_out/gt_$k.txt"
  run "every $k" "$rates_out/gt_$k.txt" --every "$k"
done
