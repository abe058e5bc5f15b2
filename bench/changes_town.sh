#!/usr/bin/env bash
# Map updates from the fleet's change reports, on the simulated town loop:
#   1. the map from the epoch-0 drive at its true poses;
#   2. three vehicles drive epoch 1 (15 % of the movable things changed), each with its own traffic
#      (12 moving vehicles and pedestrians), localize with 16 beams and wheel encoders and write a
#      change report (pl-localize --change-report);
#   3. pl-map changes aggregates the reports, pl-eval changes scores the candidate tiles against
#      pl-sim's changes.csv;
#   4. the same with no real change: three epoch-0 drives with 30 trucks each, and one of them alone.
# Usage: bench/changes_town.sh BIN DIR [SEED]   (SEED: the world; 1 is the town the other benchmarks use)
set -euo pipefail
bin=${1:?usage: changes_town.sh BIN DIR [SEED]}
dir=${2:?usage: changes_town.sh BIN DIR [SEED]}
seed=${3:-1}
mkdir -p "$dir"
export PL_NO_PROGRESS=1 OMP_NUM_THREADS=1
cd "$dir"

echo "world seed $seed: the epoch-0 map"
"$bin/pl-sim" --route loop --seed "$seed" --epoch 0 --out e0 --force >/dev/null
"$bin/pl-map" build --dataset e0 --poses gt --out map.pcd >/dev/null
rm -f maps.sqlite*
"$bin/pl-map" tile --cloud map.pcd --db maps.sqlite --map town >/dev/null
"$bin/pl-map" publish --db maps.sqlite --map town --version 1 >/dev/null

# drive NAME EPOCH DRIVE_SEED TRAFFIC TRUCK_SHARE START: simulate and localize one vehicle's drive.
drive() {
  local name=$1 epoch=$2 dseed=$3 traffic=$4 trucks=$5 start=$6
  "$bin/pl-sim" --route loop --seed "$seed" --drive-seed "$dseed" --epoch "$epoch" --traffic "$traffic" \
    --truck-share "$trucks" --out "$name" --force >/dev/null
  "$bin/pl-localize" --dataset "$name" --db maps.sqlite --map town --beams 16 --odometry encoder --init gt \
    --out "$name.tum" --kitti-out "$name.txt" --change-report "$name.json" --vehicle "vehicle-$dseed" \
    --drive-id "$name" --drive-start "$start" >"$name.log"
  "$bin/pl-eval" ape --est "$name.txt" --gt "$name/poses.txt" >"$name.ape"
  local km bytes
  km=$(awk '{ if (NR > 1) d += sqrt(($4 - x) ^ 2 + ($8 - y) ^ 2); x = $4; y = $8 } END { printf "%.3f", d / 1000 }' "$name/poses.txt")
  bytes=$(stat -c %s "$name.json")
  printf '%s: %s km, report %d bytes = %.0f kB per vehicle-km\n' "$name" "$km" "$bytes" "$(awk -v b="$bytes" -v k="$km" 'BEGIN { print b / 1000 / k }')"
  printf '%s: %s; APE mean %s m; %s\n' "$name" "$(grep -o '[0-9]* ok, [0-9]* degraded, [0-9]* lost' "$name.log")" \
    "$(awk '/error \[m\]/ {print $3; exit}' "$name.ape")" "$(grep -o 'evidence from.*kB' "$name.log")"
}

t0=1800000000
echo "epoch 1, three vehicles, each with its own traffic"
drive e1_a 1 101 12 0.2 $t0
drive e1_b 1 102 12 0.2 $((t0 + 86400))
drive e1_c 1 103 12 0.2 $((t0 + 2 * 86400))
"$bin/pl-map" changes --reports e1_a.json e1_b.json e1_c.json --out e1_candidates.csv
"$bin/pl-eval" changes --truth e1_a/changes.csv --candidates e1_candidates.csv

echo "no real change: epoch 0, three vehicles with 30 trucks each"
drive e0_a 0 201 30 1.0 $t0
drive e0_b 0 202 30 1.0 $((t0 + 86400))
drive e0_c 0 203 30 1.0 $((t0 + 2 * 86400))
"$bin/pl-map" changes --reports e0_a.json e0_b.json e0_c.json --out e0_candidates.csv
echo "one of them alone:"
"$bin/pl-map" changes --reports e0_a.json --min-drives 1 --window 1 --out e0_single.csv

echo "aggregation: 1,000 reports (the three epoch-1 reports as 1,000 vehicles' drives)"
mkdir -p many
python3 - <<'PY'
import json
src = [json.load(open(f"e1_{x}.json")) for x in "abc"]
for i in range(1000):
    r = dict(src[i % 3])
    r["vehicle"] = f"vehicle-{i}"
    r["drive"] = f"drive-{i}"
    r["start"] = r["start"] + 3600 * i
    r["end"] = r["start"] + 90
    json.dump(r, open(f"many/{i:04d}.json", "w"), separators=(",", ":"))
PY
du -sh many | awk '{print "1,000 reports: " $1}'
/usr/bin/time -f "pl-map changes over 1,000 reports: %e s wall, %M kB peak memory" "$bin/pl-map" changes --reports many/*.json --out many.csv
