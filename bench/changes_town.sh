#!/usr/bin/env bash
# Map updates from the fleet's change reports, on the simulated town loop:
#   1. the map from the epoch-0 drive at its true poses;
#   2. pl-server serves it; three vehicles drive epoch 1 (15 % of the movable things changed), each
#      with its own traffic (12 moving vehicles and pedestrians), localize with 16 beams and wheel
#      encoders over HTTP, write their change reports and send them (pl-localize --report-spool);
#   3. pl-map changes aggregates the reports, pl-eval changes scores the candidate tiles against
#      pl-sim's changes.csv; pl-map update stages and publishes v2 from the reports the store holds,
#      and a fourth epoch-1 drive is localized on v1 and on v2, beside the same drive (its traffic)
#      in epoch 0 on v1: the level to get back to;
#   4. the same with no real change: three epoch-0 drives with 30 trucks each, and one of them alone.
# Usage: bench/changes_town.sh BIN DIR [SEED]   (SEED: the world; 1 is the town the other benchmarks use)
set -euo pipefail
bin=${1:?usage: changes_town.sh BIN DIR [SEED]}
dir=${2:?usage: changes_town.sh BIN DIR [SEED]}
seed=${3:-1}
root=$(cd "$(dirname "$0")/.." && pwd)
mkdir -p "$dir"
export PL_NO_PROGRESS=1 OMP_NUM_THREADS=1
cd "$dir"

echo "world seed $seed: the epoch-0 map"
"$bin/pl-sim" --route loop --seed "$seed" --epoch 0 --out e0 --force >/dev/null
"$bin/pl-map" build --dataset e0 --poses gt --out map.pcd >/dev/null
rm -f maps.sqlite*
"$bin/pl-map" tile --cloud map.pcd --db maps.sqlite --map town >/dev/null
"$bin/pl-map" publish --db maps.sqlite --map town --version 1 >/dev/null

# The map service: the vehicles localize against it and send their reports to it.
echo "report report-bench-token" > tokens.txt
source "$root/tools/start-server.sh"
start_server server.log "$bin/pl-server" --db maps.sqlite --listen 127.0.0.1:0 --tokens tokens.txt
server_pid=$SERVER_PID
trap 'kill $server_pid 2>/dev/null || true' EXIT
url=$SERVER_URL

# localize NAME: localize drive NAME on the map's current version, without a report.
localize() {
  local name=$1 tag=$2
  "$bin/pl-localize" --dataset "$name" --db maps.sqlite --map town --beams 16 --odometry encoder --init gt \
    --out "$name.$tag.tum" --kitti-out "$name.$tag.txt" >"$name.$tag.log"
  "$bin/pl-eval" ape --est "$name.$tag.txt" --gt "$name/poses.txt" >"$name.$tag.ape"
  printf '%s on %s: %s; APE mean %s m, RMSE %s m\n' "$name" "$(grep -o 'map town v[0-9]*' "$name.$tag.log")" \
    "$(grep -o '[0-9]* ok, [0-9]* degraded, [0-9]* lost.*' "$name.$tag.log")" \
    "$(awk '/error \[m\]/ {print $3; exit}' "$name.$tag.ape")" "$(awk '/error \[m\]/ {print $5; exit}' "$name.$tag.ape")"
}

# simulate NAME EPOCH DRIVE_SEED TRAFFIC TRUCK_SHARE: one vehicle's drive.
simulate() {
  "$bin/pl-sim" --route loop --seed "$seed" --drive-seed "$3" --epoch "$2" --traffic "$4" --truck-share "$5" --out "$1" --force >/dev/null
}

# drive NAME EPOCH DRIVE_SEED TRAFFIC TRUCK_SHARE START: simulate and localize one vehicle's drive.
drive() {
  local name=$1 epoch=$2 dseed=$3 traffic=$4 trucks=$5 start=$6
  simulate "$name" "$epoch" "$dseed" "$traffic" "$trucks"
  "$bin/pl-localize" --dataset "$name" --server "$url" --map town --map-version 1 --beams 16 --odometry encoder --init gt \
    --out "$name.tum" --kitti-out "$name.txt" --change-report "$name.json" --vehicle "vehicle-$dseed" \
    --drive-id "$name" --drive-start "$start" --report-spool "spool-$dseed" --report-token report-bench-token >"$name.log"
  "$bin/pl-eval" ape --est "$name.txt" --gt "$name/poses.txt" >"$name.ape"
  local km bytes
  km=$(awk '{ if (NR > 1) d += sqrt(($4 - x) ^ 2 + ($8 - y) ^ 2); x = $4; y = $8 } END { printf "%.3f", d / 1000 }' "$name/poses.txt")
  bytes=$(stat -c %s "$name.json")
  local sent
  sent=$(grep -o 'report spool: [0-9]* sent ([0-9.]* kB gzipped)' "$name.log" | grep -o '[0-9.]* kB' | grep -o '[0-9.]*')
  printf '%s: %s km, report %d bytes = %.0f kB per vehicle-km; sent to the service gzipped: %s kB = %.0f kB per vehicle-km\n' \
    "$name" "$km" "$bytes" "$(awk -v b="$bytes" -v k="$km" 'BEGIN { print b / 1000 / k }')" "$sent" \
    "$(awk -v b="$sent" -v k="$km" 'BEGIN { print b / k }')"
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

echo "the update: epoch 0 and a fourth epoch-1 drive (its own traffic) localized on v1, then v2 staged from the three reports"
simulate e0_ref 0 104 12 0.2
simulate e1_d 1 104 12 0.2
localize e0_ref v1
localize e1_d v1
echo "(the reports as the service holds them, sent by the vehicles; pl-map update reads them from the store)"
"$bin/pl-map" update --db maps.sqlite --map town --publish | grep -v '^~'
"$bin/pl-map" diff --db maps.sqlite --map town --from 1 --to 2 | tail -1
python3 - <<'PY'
import sqlite3
db = sqlite3.connect("maps.sqlite")
rows = {v: dict(((tx, ty), h) for tx, ty, h in db.execute(
    "SELECT t.tx, t.ty, t.hash FROM tiles t JOIN maps m ON m.id = t.map_id WHERE m.name = 'town' AND t.version = ?", (v,)))
    for v in (1, 2)}
same = sum(1 for k, h in rows[2].items() if rows[1].get(k) == h)
print(f"v2 keeps {same} of {len(rows[1])} v1 tiles byte-identical (same SHA-256, the same stored blob)")
PY
localize e1_d v2

echo "no real change: epoch 0, three vehicles with 30 trucks each"
drive e0_a 0 201 30 1.0 $t0
drive e0_b 0 202 30 1.0 $((t0 + 86400))
drive e0_c 0 203 30 1.0 $((t0 + 2 * 86400))
"$bin/pl-map" changes --reports e0_a.json e0_b.json e0_c.json --version 1 --out e0_candidates.csv
echo "one of them alone:"
"$bin/pl-map" changes --reports e0_a.json --version 1 --min-drives 1 --window 1 --out e0_single.csv

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
echo "the same 1,000 reports sent to pl-server (gzipped, as the vehicles send them), then aggregated there"
python3 - "$url" <<'PY'
import glob, gzip, json, sys, time, urllib.request
url = sys.argv[1]
t0 = time.time()
sent = 0
for f in sorted(glob.glob("many/*.json")):
    body = gzip.compress(open(f, "rb").read())
    sent += len(body)
    req = urllib.request.Request(url + "/v1/maps/town/reports", data=body, method="POST",
                                 headers={"Authorization": "Bearer report-bench-token", "Content-Type": "application/json",
                                          "Content-Encoding": "gzip"})
    urllib.request.urlopen(req).read()
t1 = time.time()
print(f"1,000 reports posted: {sent / 1e6:.1f} MB gzipped in {t1 - t0:.1f} s")
t0 = time.time()
answer = json.load(urllib.request.urlopen(url + "/v1/maps/town/changes?version=1", timeout=600))
t1 = time.time()
print(f"GET /v1/maps/town/changes over {answer['reports']} stored reports ({answer['passes']} passes): {t1 - t0:.1f} s, "
      f"{sum(t['candidate'] for t in answer['tiles'])} candidates")
PY
