#!/usr/bin/env bash
# The main job of ./pl demo: everything the product does so far, run for real on generated data,
# then the result. So far: simulate a drive round the built-in town loop (HDL-64E, wheel encoders,
# GPS, traffic), build the map from its ground-truth poses, tile it into a versioned SQLite store,
# serve it with pl-server on 127.0.0.1 and fetch a region of interest over HTTP, prepare every scan
# as the localizer will (16 of 64 beams, 0.2 m voxels), and evaluate the preparation time and the GPS
# receiver against the ground truth.
#   tools/demo.sh BIN_DIR OUT_DIR
set -euo pipefail
bin=${1:?usage: tools/demo.sh BIN_DIR OUT_DIR}
out=${2:?usage: tools/demo.sh BIN_DIR OUT_DIR}
mkdir -p "$out"
out=$(cd "$out" && pwd)
drive="$out/loop"

step() { printf '\n\033[1m-- %s\033[0m\n' "$*"; }

step "pl-sim: one lap of the town loop, HDL-64E, 12 moving vehicles and pedestrians"
"$bin/pl-sim" --route loop --traffic 12 --seed 1 --out "$drive" --force --preview "$out/world.svg"

step "pl-dataset info: what the drive holds"
"$bin/pl-dataset" info "$drive"

step "pl-map build + tile + publish: the map of the drive, as Draco tiles in SQLite"
rm -f "$out/maps.sqlite" "$out/maps.sqlite-wal" "$out/maps.sqlite-shm"
"$bin/pl-map" build --dataset "$drive" --poses gt --out "$out/map.pcd"
"$bin/pl-map" tile --cloud "$out/map.pcd" --db "$out/maps.sqlite" --map town
"$bin/pl-map" publish --db "$out/maps.sqlite" --map town --version 1
"$bin/pl-map" info --db "$out/maps.sqlite" --map town

step "pl-server: the map over HTTP on 127.0.0.1"
"$bin/pl-server" --db "$out/maps.sqlite" --listen 127.0.0.1:0 --threads 2 >"$out/server.log" 2>&1 &
server=$!
trap 'kill $server 2>/dev/null || true' EXIT
url=""
for _ in $(seq 100); do
  url=$(grep -o 'http://127.0.0.1:[0-9]*' "$out/server.log" | head -1 || true)
  [[ -n "$url" ]] && break
  sleep 0.1
done
[[ -n "$url" ]] || { cat "$out/server.log"; exit 1; }
echo "manifest:  $(curl -sf "$url/v1/maps/town")"
roi=$(curl -sf "$url/v1/maps/town/roi?x=100&y=0&radius=60")
count=$(python3 -c 'import json,sys; t=json.loads(sys.argv[1])["tiles"]; print(len(t), sum(x["bytes"] for x in t), sum(x["points"] for x in t))' "$roi")
read -r ntiles nbytes npoints <<<"$count"
echo "ROI 60 m around (100, 0): $ntiles tiles, $npoints points, $nbytes bytes"
first=$(python3 -c 'import json,sys; print(json.loads(sys.argv[1])["tiles"][0]["url"])' "$roi")
curl -sf "$url$first" -o "$out/tile.drc"
if command -v draco_decoder >/dev/null; then
  draco_decoder -i "$out/tile.drc" -o "$out/tile.ply" >/dev/null && echo "draco_decoder: $first -> $(grep -a 'element vertex' "$out/tile.ply")"
fi
kill -TERM $server && wait $server || true
trap - EXIT
tail -1 "$out/server.log"

step "pl-dataset poses: the ground-truth LiDAR poses"
"$bin/pl-dataset" poses "$drive" --format tum --out "$out/ground_truth.tum"

step "pl-dataset scans: 16 of 64 beams, 2-100 m, 0.2 m voxels"
"$bin/pl-dataset" scans "$drive" --beams 16 --voxel 0.2 --timing "$out/prepare.csv"

step "pl-eval timing: per-scan preparation time"
"$bin/pl-eval" timing --csv "$out/prepare.csv" --column prepare_ms --plot "$out/plots" | head -4

step "pl-eval ape: the GPS receiver against where its antenna really was"
"$bin/pl-dataset" gps "$drive" --out "$out/gps.tum" --truth "$out/gps_truth.tum"
"$bin/pl-eval" ape --est "$out/gps.tum" --gt "$out/gps_truth.tum" --up z --plot "$out/plots"
"$bin/pl-dataset" gps "$drive" --status rtk-fixed --out "$out/gps_fixed.tum" --truth "$out/gps_fixed_truth.tum" >/dev/null
printf '\nrtk-fixed fixes only:\n'
"$bin/pl-eval" ape --est "$out/gps_fixed.tum" --gt "$out/gps_fixed_truth.tum" --up z | sed -n '/mean/,/max/p' | head -2

step "result"
echo "simulated drive:  $drive (world top view: $out/world.svg)"
echo "map:              $out/map.pcd, tiles in $out/maps.sqlite"
echo "ground truth:     $out/ground_truth.tum"
echo "figures:          $out/plots/"
