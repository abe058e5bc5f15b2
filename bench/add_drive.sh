#!/usr/bin/env bash
# Adding a drive to a published map (pl-map build --base-map) against building the map anew with it,
# in one run, on the simulator and on real data:
#   town: FRAMES scans of the town loop (64 beams, traffic) mapped with LiDAR odometry + GPS + loops,
#   tiled and published; then a second drive over the first third of that stretch, its own traffic.
#   real: drive 0005's first half (scans 0-76, consumer GPS) mapped the same way; its second half added.
# For each: the new version's tiles against the published one (rebuilt / byte-identical), the bytes a
# vehicle downloads to update, the whole build's time, and the new drive's error against its truth.
#   bench/add_drive.sh BIN_DIR WORK_DIR [FRAMES]
set -euo pipefail
bin=${1:?usage: bench/add_drive.sh BIN_DIR WORK_DIR [FRAMES]}
work=${2:?usage: bench/add_drive.sh BIN_DIR WORK_DIR [FRAMES]}
frames=${3:-300}
root=$(cd "$(dirname "$0")/.." && pwd)
mkdir -p "$work/add-drive"
d=$(cd "$work/add-drive" && pwd)
export PL_NO_PROGRESS=1 OMP_NUM_THREADS=1

# tiles DB: the staged version's tiles against the published one, and the bytes that differ.
tiles() {
  python3 - "$1" <<'EOF'
import sqlite3, sys
db = sqlite3.connect(sys.argv[1])
cur = db.execute("SELECT max(number) FROM versions").fetchone()[0]
old = dict(((tx, ty), h) for tx, ty, h in db.execute("SELECT tx, ty, hash FROM tiles WHERE version = ?", (cur - 1,)))
new = list(db.execute("SELECT tx, ty, hash, bytes FROM tiles WHERE version = ?", (cur,)))
same = [t for t in new if old.get((t[0], t[1])) == t[2]]
fetch = sum(t[3] for t in new if old.get((t[0], t[1])) != t[2])
total = sum(t[3] for t in new)
print(f"{len(new)} tiles: {len(new) - len(same)} rebuilt, {len(same)} byte-identical; "
      f"a vehicle downloads {fetch / 1e6:.2f} of {total / 1e6:.2f} MB ({100 * fetch / total:.0f} %)")
EOF
}
# seconds LOG CMD...: runs it (its output to LOG), prints its wall time.
seconds() {
  local log=$1 t0 t1
  shift
  t0=$(date +%s.%N)
  "$@" >"$log"
  t1=$(date +%s.%N)
  python3 -c "print(f'{$t1 - $t0:.1f}')"
}
error() {  # REPORT DRIVE: the drive's mean error against its truth (from the build's report)
  python3 -c 'import json,sys; r=json.load(open(sys.argv[1])); print("%.3f m" % r["drives"][int(sys.argv[2])]["mean_error_after_m"])' "$1" "$2"
}

# case ID TITLE BASE NEW: BASE mapped, tiled, published; NEW added with --base-map, and both built anew.
case_() {
  local c="$d/$1" name=$2 base=$3 new=$4
  mkdir -p "$c"
  rm -f "$c"/*.sqlite*
  local build=("$bin/pl-map" build --poses lidar --gps --loops)
  "${build[@]}" --dataset "$base" --out "$c/base.pcd" --report "$c/base.json" >"$c/base.log"
  "$bin/pl-map" tile --cloud "$c/base.pcd" --db "$c/added.sqlite" --map m >/dev/null
  "$bin/pl-map" publish --db "$c/added.sqlite" --map m --version 1 >/dev/null
  cp "$c/added.sqlite" "$c/anew.sqlite"
  local s_added s_anew
  s_added=$(seconds "$c/added.log" "${build[@]}" --base-map "$c/base.pcd" --dataset "$new" --out "$c/added.pcd" --report "$c/added.json")
  s_anew=$(seconds "$c/anew.log" "${build[@]}" --dataset "$base" --dataset "$new" --out "$c/anew.pcd" --report "$c/anew.json")
  "$bin/pl-map" tile --cloud "$c/added.pcd" --db "$c/added.sqlite" --map m >/dev/null
  "$bin/pl-map" tile --cloud "$c/anew.pcd" --db "$c/anew.sqlite" --map m >/dev/null
  echo "== $name"
  echo "  --base-map: $(tiles "$c/added.sqlite"); build ${s_added} s; drives off their truth by $(error "$c/base.json" 0) (base, as published), $(error "$c/added.json" 1) (new)"
  echo "  anew:       $(tiles "$c/anew.sqlite"); build ${s_anew} s; drives off their truth by $(error "$c/anew.json" 0), $(error "$c/anew.json" 1)"
}

# first_scans DRIVE N OUT: the first N scans of a pl-sim drive (linked; times, poses, GPS and encoders
# cut): part of the stretch through the same world (pl-sim builds its world for the whole stretch).
first_scans() {
  local src=$1 n=$2 out=$3 i f end
  rm -rf "$out"
  mkdir -p "$out/velodyne" "$out/point_times"
  for ((i = 0; i < n; i++)); do
    f=$(printf '%06d.bin' "$i")
    ln -s "$src/velodyne/$f" "$out/velodyne/$f"
    ln -s "$src/point_times/$f" "$out/point_times/$f"
  done
  cp "$src/meta.json" "$out/"
  head -n "$n" "$src/times.txt" >"$out/times.txt"
  head -n "$n" "$src/poses.txt" >"$out/poses.txt"
  end=$(sed -n "${n}p" "$src/times.txt")
  for f in gps.csv encoder.csv; do awk -F, -v end="$end" 'NR == 1 || $1 <= end + 0.05' "$src/$f" >"$out/$f"; done
}

if [[ ! -f "$d/town/done" ]]; then
  sim=("$bin/pl-sim" --route loop --seed 1 --traffic 30 --frames "$frames" --force)
  "${sim[@]}" --drive-seed 1 --out "$d/town/base" >/dev/null
  "${sim[@]}" --drive-seed 2 --out "$d/town/day2" >/dev/null
  first_scans "$d/town/day2" $((frames / 3)) "$d/town/new"
  touch "$d/town/done"
fi
case_ town-case "town, $frames scans, then $((frames / 3)) over its start on another day" "$d/town/base" "$d/town/new"

data=$("$root/tools/shared-data.sh" 2>/dev/null || true)
drive="$data/kitti-raw-2011_09_26_drive_0005_sync"
if [[ -z "$data" || ! -d "$drive" ]]; then
  echo "(real data skipped: drive 0005 is not beside the repository)"
  exit 0
fi
source "$root/bench/k05_halves.sh"
mkdir -p "$d/k05"
k05_halves "$bin" "$drive" "$d/k05"
case_ k05-case "drive 0005: scans 0-76, then 77-153 (consumer GPS)" "$d/k05/first" "$d/k05/second"
