#!/usr/bin/env bash
# Global starts (--init global: no pose at all, no GPS, LiDAR only) on the simulated town loop: the
# map of the mapping drive (epoch 0, at its ground-truth poses, with its places), the drive to
# localize six months later (epoch 1: parked vehicles moved, 12 moving vehicles and pedestrians),
# swept scans with per-laser calibration errors, 16 of 64 beams. Ten starts spread over the loop,
# three scans each. A start is found when a scan is ok, and must then be within 0.2 m; a scan ok
# farther off is a wrong pose reported as found (must never happen). The time is that of the first
# scan's search over the whole map, one thread.
#   bench/global_town.sh BIN_DIR WORK_DIR
set -euo pipefail
bin=${1:?usage: global_town.sh BIN_DIR WORK_DIR}
work=${2:?usage: global_town.sh BIN_DIR WORK_DIR}
mkdir -p "$work/global_town"
dir=$(cd "$work/global_town" && pwd)
export PL_NO_PROGRESS=1 OMP_NUM_THREADS=1

# The drives and map of a simulator whose sweep turned the other way (before 2026-12-03) are made again.
if [[ ! -f "$dir/sweep-ccw" ]]; then rm -f "$dir/maps.sqlite"; fi
if [[ ! -f "$dir/maps.sqlite" ]]; then
  echo "preparing the town loop's drives and map in $dir (once)"
  "$bin/pl-sim" --route loop --seed 1 --epoch 0 --out "$dir/mapping" --force >/dev/null
  "$bin/pl-sim" --route loop --seed 1 --epoch 1 --traffic 12 --out "$dir/drive" --force >/dev/null
  "$bin/pl-map" build --dataset "$dir/mapping" --poses gt --out "$dir/map.pcd" >/dev/null
  rm -f "$dir/maps.sqlite.partial"*
  "$bin/pl-map" tile --cloud "$dir/map.pcd" --db "$dir/maps.sqlite.partial" --map town >/dev/null
  "$bin/pl-map" publish --db "$dir/maps.sqlite.partial" --map town --version 1 >/dev/null
  mv "$dir/maps.sqlite.partial" "$dir/maps.sqlite"
  touch "$dir/sweep-ccw"
fi
"$bin/pl-dataset" poses "$dir/drive" --out "$dir/gt.txt" >/dev/null
grep -v '^#' "$dir/gt.txt" | awk 'NR % 2 == 0' >"$dir/gt_odd.txt"
odd=$(wc -l <"$dir/gt_odd.txt")
echo "town loop, epoch 1 with traffic: $odd odd scans; map of epoch 0 at its true poses, with its places"

rates_drive="$dir/drive" rates_db="$dir/maps.sqlite" rates_map=town rates_out="$dir"
source "$(dirname "$0")/rates_run.sh"

echo "| global start at odd scan | found | error when found (m) | scans to find | ok farther than 0.2 m | first search ms |"
echo "|---|---|---|---|---|---|"
found_all=0 wrong_all=0
for i in $(seq 0 9); do
  first=$((i * (odd - 3) / 9))
  head -n $((first + 3)) "$dir/gt_odd.txt" | tail -n 3 >"$dir/gt_global.txt"
  run "global $first" "$dir/gt_global.txt" --init global --first "$first" --count 3 >/dev/null
  row=$(awk -v f="$first" 'NR == 1 { ms = $3 } $4 == "ok" && $5 > 0.2 { wrong++ }
                           $4 == "ok" && !found { found = NR; e = $5 }
                           END { printf "| %d | %s | %s | %s | %d | %.0f |", f, found ? "yes" : "no",
                                 found ? sprintf("%.3f", e) : "-", found ? found : "-", wrong, ms }' "$dir/global_$first.scans")
  echo "$row"
  IFS='|' read -r _ _ found _ _ wrong ms _ <<<"$row"
  echo "$ms" >>"$dir/first_ms.txt.new"
  [[ $found == " yes " ]] && found_all=$((found_all + 1))
  wrong_all=$((wrong_all + wrong))
done
mv "$dir/first_ms.txt.new" "$dir/first_ms.txt"
echo "found $found_all of 10; scans ok farther than 0.2 m: $wrong_all; first search median $(median <"$dir/first_ms.txt") ms"
