#!/usr/bin/env bash
# The main job of ./pl demo: the whole product, run for real on generated data. Simulate the town
# loop twice -- the mapping drive (epoch 0, empty streets) and, six months later, the drive to
# localize (epoch 1: parked vehicles moved, 12 moving vehicles and pedestrians) -- build the map from
# the mapping drive with G-LOAM (LiDAR odometry + the drive's GPS + loop closures; no ground truth
# used), tile it into a versioned SQLite store, serve it with
# pl-server on 127.0.0.1, localize the second drive over HTTP with 16 of 64 beams and wheel-encoder
# odometry, evaluate against its ground truth, stop the server, print the table.
#   tools/demo.sh BIN_DIR OUT_DIR
set -euo pipefail
bin=${1:?usage: tools/demo.sh BIN_DIR OUT_DIR}
out=${2:?usage: tools/demo.sh BIN_DIR OUT_DIR}
mkdir -p "$out"
out=$(cd "$out" && pwd)
mapping="$out/mapping"
drive="$out/drive"

source "$(dirname "$0")/start-server.sh"
step() { printf '\n\033[1m-- %s\033[0m\n' "$*"; }

step "pl-sim: the mapping drive (town loop, HDL-64E, epoch 0, no traffic)"
"$bin/pl-sim" --route loop --seed 1 --epoch 0 --out "$mapping" --force --preview "$out/world.svg"

step "pl-sim: the drive to localize (same loop six months later: epoch 1, 12 moving vehicles and pedestrians)"
"$bin/pl-sim" --route loop --seed 1 --epoch 1 --traffic 12 --out "$drive" --force

step "pl-map build (G-LOAM: LiDAR odometry + GPS + loop closures) + tile + publish: the map, as Draco tiles in SQLite"
rm -f "$out/maps.sqlite" "$out/maps.sqlite-wal" "$out/maps.sqlite-shm"
"$bin/pl-map" build --dataset "$mapping" --poses lidar --gps --loops --out "$out/map.pcd" \
  --traj-out "$out/mapping-poses.txt" --report "$out/map-report.json"
"$bin/pl-eval" ape --json --est "$out/mapping-poses.txt" --gt "$mapping/poses.txt" >"$out/map-ape.json"
"$bin/pl-eval" topview --cloud "$out/map.pcd" --traj "$out/mapping-poses.txt:G-LOAM trajectory" --out "$out/map.svg" >/dev/null
"$bin/pl-map" tile --cloud "$out/map.pcd" --db "$out/maps.sqlite" --map town
"$bin/pl-map" publish --db "$out/maps.sqlite" --map town --version 1
"$bin/pl-map" info --db "$out/maps.sqlite" --map town

step "pl-server: the map over HTTP on 127.0.0.1"
start_server "$out/server.log" "$bin/pl-server" --db "$out/maps.sqlite" --listen 127.0.0.1:0 --threads 2
server=$SERVER_PID
trap 'kill $server 2>/dev/null || true' EXIT
url=$SERVER_URL
echo "manifest: $(curl -sf "$url/v1/maps/town")"

step "pl-localize: 16 of 64 beams, wheel encoders, tiles streamed from $url"
rm -f "$out/tiles-cache.sqlite"*
"$bin/pl-localize" --dataset "$drive" --server "$url" --map town --beams 16 --odometry encoder \
  --init gps --cache "$out/tiles-cache.sqlite" \
  --out "$out/poses.tum" --kitti-out "$out/poses.txt" --timing "$out/timing.csv" | tee "$out/localize.log"

kill -TERM $server && wait $server || true
trap - EXIT
echo "server: $(tail -1 "$out/server.log")"

step "pl-eval: accuracy against the ground truth, registration time"
"$bin/pl-eval" ape --est "$out/poses.txt" --gt "$drive/poses.txt" --plot "$out/plots"
"$bin/pl-eval" ape --json --est "$out/poses.txt" --gt "$drive/poses.txt" >"$out/ape.json"
"$bin/pl-eval" timing --csv "$out/timing.csv" --column registration_ms --plot "$out/plots" | head -3
"$bin/pl-eval" timing --json --csv "$out/timing.csv" --column registration_ms >"$out/timing.json"

step "result"
python3 - "$out" <<'PY'
import json, re, sys
out = sys.argv[1]
a = json.load(open(f"{out}/ape.json"))
m = json.load(open(f"{out}/map-ape.json"))
rep = json.load(open(f"{out}/map-report.json"))
t = json.load(open(f"{out}/timing.json"))
log = open(f"{out}/localize.log").read()
status = re.search(r"status: ([^;]*)", log)
hz = re.search(r"\(([\d.]+) Hz", log)
rows = [
    ("map: G-LOAM trajectory APE mean / max", f"{m['mean']:.3f} / {m['max']:.3f} m",
     f"LiDAR odometry alone {rep['mean_error_before_m']:.3f} m mean; {rep['loops']['accepted']} loops closed"),
    ("localized: APE mean / median / RMSE / max", f"{a['mean']:.3f} / {a['median']:.3f} / {a['rmse']:.3f} / {a['max']:.3f} m",
     "paper, KITTI 00: 0.228 / 0.142 / 0.325 m"),
    ("coverage", f"{100 * a['coverage']:.1f} % of {a['gt_poses']} scans", ""),
    ("scan status", status[1] if status else "?", ""),
    ("registration per scan, one thread", f"median {t['p50']:.2f} ms, p99 {t['p99']:.2f} ms", "paper: < 100 ms a scan"),
    ("fused poses", f"{hz[1] if hz else '?'} Hz (wheel encoders)", "paper: > 20 Hz"),
]
w = max(len(r[0]) for r in rows)
for r in rows:
    print(f"  {r[0]:<{w}}  {r[1]:<40} {r[2]}")
PY
echo
echo "world top view:   $out/world.svg"
echo "map:              $out/map.pcd (top view $out/map.svg, report $out/map-report.json), tiles in $out/maps.sqlite"
echo "poses:            $out/poses.tum (fused, odometry rate), $out/poses.txt (one per scan)"
echo "plots:            $out/plots/ (trajectory.svg, error_over_distance.svg, error_histogram.svg, timing_histogram.svg)"
