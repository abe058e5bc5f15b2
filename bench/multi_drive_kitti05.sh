#!/usr/bin/env bash
# Two drives built into one map, on real data: KITTI raw drive 0005 cut in two (scans 0-76 and
# 77-153), its GPS degraded to a consumer receiver (1 Hz, sigma 1.5 m), built together with
# pl-map build --poses lidar --gps --loops, against the whole drive built alone; APE against OXTS
# for each. Then the map at OXTS poses with every return merged and with the moving things removed:
# points removed, the localizer's figures unchanged or not (even scans map, odd scans localize),
# and top views of both maps.
#   bench/multi_drive_kitti05.sh BIN_DIR WORK_DIR
set -euo pipefail
bin=${1:?usage: bench/multi_drive_kitti05.sh BIN_DIR WORK_DIR}
work=${2:?usage: bench/multi_drive_kitti05.sh BIN_DIR WORK_DIR}
root=$(cd "$(dirname "$0")/.." && pwd)
data=$("$root/tools/shared-data.sh" || true)
drive="$data/kitti-raw-2011_09_26_drive_0005_sync"
if [[ -z "$data" || ! -d "$drive" ]]; then
  echo "(skipped: drive 0005 is not beside the repository)"
  exit 0
fi
mkdir -p "$work/multi-k05"
d=$(cd "$work/multi-k05" && pwd)
export PL_NO_PROGRESS=1

source "$root/bench/k05_halves.sh"
k05_halves "$bin" "$drive" "$d"

ape() {
  "$bin/pl-eval" ape --json --est "$1" --gt "$2" |
    python3 -c 'import json,sys; r=json.load(sys.stdin); print("mean %.4f m, RMSE %.4f m, max %.3f m" % (r["mean"], r["rmse"], r["max"]))'
}
"$bin/pl-map" build --dataset "$d/consumer" --poses lidar --gps --loops --out "$d/one.pcd" --traj-out "$d/one.txt" >"$d/one.log"
"$bin/pl-map" build --dataset "$d/first" --dataset "$d/second" --poses lidar --gps --loops --out "$d/two.pcd" \
  --traj-out "$d/first.txt" --traj-out "$d/second.txt" --report "$d/two.json" >"$d/two.log"
cat "$d/first.txt" "$d/second.txt" >"$d/two.txt"
echo "one drive (154 scans):            $(ape "$d/one.txt" "$d/oxts.txt")"
echo "two halves built together:        $(ape "$d/two.txt" "$d/oxts.txt")"
python3 -c 'import json,sys; r=json.load(open(sys.argv[1])); print("  loops between the halves:", [x.get("loops_to") for x in r["drives"]])' "$d/two.json"
# The second half without GPS: joined by its loops to the first alone.
rm -f "$d/second/gps.csv"
"$bin/pl-map" build --dataset "$d/first" --dataset "$d/second" --poses lidar --gps --loops --out "$d/two-nogps.pcd" \
  --traj-out "$d/first-n.txt" --traj-out "$d/second-n.txt" >"$d/two-nogps.log"
cat "$d/first-n.txt" "$d/second-n.txt" >"$d/two-nogps.txt"
echo "second half without GPS:          $(ape "$d/two-nogps.txt" "$d/oxts.txt")"

# Moving things: the whole drive at OXTS poses, every return merged against the moving ones removed.
"$bin/pl-map" build --dataset "$drive" --poses gt --moving keep --out "$d/kept.pcd" >/dev/null
"$bin/pl-map" build --dataset "$drive" --poses gt --moving remove --out "$d/cleaned.pcd" | grep "moving things"
# The top views of docs/figures/k05-moving-*.png: the streets around the drive, the removed points in red.
box=-25,-30,95,35
"$bin/pl-eval" topview --cloud "$d/kept.pcd" --traj "$d/oxts.txt:OXTS" --cell 0.2 --bounds=$box \
  --title "KITTI raw 2011_09_26 drive 0005 at OXTS poses: every return merged (pl-map build --moving keep)" \
  --out "$d/k05-moving-kept.png" >/dev/null
"$bin/pl-eval" topview --cloud "$d/cleaned.pcd" --removed-from "$d/kept.pcd" --traj "$d/oxts.txt:OXTS" --cell 0.2 --bounds=$box \
  --title "KITTI raw 2011_09_26 drive 0005 at OXTS poses: pl-map build --moving remove, the points it removed in red" \
  --out "$d/k05-moving-removed.png" | grep "are not in"
echo "top views: $d/k05-moving-kept.png $d/k05-moving-removed.png"
