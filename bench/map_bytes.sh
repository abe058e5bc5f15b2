#!/usr/bin/env bash
# Map bytes before and after a codec change, with the localizer's accuracy on each map. Two maps,
# each tiled by BEFORE_BIN's pl-map and by BIN's:
#   town: one lap of pl-sim's town loop (seed 1, epoch 0, the demo's mapping drive) at its true
#     poses; localized: the demo's second drive (epoch 1, 12 moving things), 16 beams, wheel
#     encoders, from the first GPS fix.
#   0005: drive 0005's paper map (its even scans at their OXTS poses); localized: the paper
#     protocol (odd scans, 16 beams, LiDAR only, from the first odd scan's truth).
# Three tilings: "before" (BEFORE_BIN's pl-map; main's of 2026-12-07: 5 mm, 8-bit normals and
# intensity), "normals" (BIN's pl-map with 6-bit normals and 4-bit intensity stored, the tiles of
# 2026-12-07 evening) and "after" (BIN's defaults: positions only, the vehicle estimates normals).
# Bytes by attribute come from BIN's bench_map_bytes (each map split with the settings it was tiled
# with). Each side localizes with its own build's pl-localize. Road length: the drive's OXTS path.
#   bash bench/map_bytes.sh BEFORE_BIN_DIR BIN_DIR WORK_DIR
set -euo pipefail
before=${1:?usage: map_bytes.sh BEFORE_BIN_DIR BIN_DIR WORK_DIR}
after=${2:?usage: map_bytes.sh BEFORE_BIN_DIR BIN_DIR WORK_DIR}
work=${3:?usage: map_bytes.sh BEFORE_BIN_DIR BIN_DIR WORK_DIR}
before=$(cd "$before" && pwd) after=$(cd "$after" && pwd)
mkdir -p "$work"
work=$(cd "$work" && pwd)
source "$(dirname "$0")/k05_map.sh"
source "$(dirname "$0")/rates_run.sh"
export PL_NO_PROGRESS=1 OMP_NUM_THREADS=1
old_settings=(--max-error 0.005 --normal-bits 8 --intensity-bits 8 --speed 5)
normals_settings=(--normal-bits 6 --intensity-bits 4)

# The clouds, made once with BIN (the codec does not touch them).
# (pl-map build writes town.places, which pl-map tile stores with the map, then town.drives.json.)
[[ -f "$work/mapping/poses.txt" ]] || "$after/pl-sim" --route loop --seed 1 --epoch 0 --out "$work/mapping" --force >/dev/null
[[ -f "$work/drive/poses.txt" ]] || "$after/pl-sim" --route loop --seed 1 --epoch 1 --traffic 12 --out "$work/drive" --force >/dev/null
[[ -f "$work/town.drives.json" ]] || "$after/pl-map" build --dataset "$work/mapping" --poses gt --out "$work/town.pcd" >/dev/null
k05=""
if k05_map map_bytes "$after" "$work" >/dev/null; then
  [[ -f "$k05/even.pcd" ]] || { echo "map_bytes: $k05/even.pcd is missing (remove $k05 to rebuild it)"; exit 1; }
  km=$(grep -v '^#' "$k05/gt.txt" | awk 'NR > 1 { d += sqrt(($4 - x) ^ 2 + ($8 - y) ^ 2 + ($12 - z) ^ 2) } { x = $4; y = $8; z = $12 } END { printf "%.4f", d / 1000 }')
else
  echo "map_bytes: drive 0005 is absent; the town alone follows"
fi

# tile SIDE BIN CLOUD MAP [FLAGS...]: SIDE/MAP.sqlite, published (made once).
tile() {
  local db="$work/$1/$4.sqlite"
  mkdir -p "$work/$1"
  if [[ ! -f "$db" ]]; then
    rm -f "$db.partial.sqlite"*
    "$2/pl-map" tile --cloud "$3" --db "$db.partial.sqlite" --map "$4" "${@:5}" >/dev/null
    "$2/pl-map" publish --db "$db.partial.sqlite" --map "$4" --version 1 >/dev/null
    mv "$db.partial.sqlite" "$db"
  fi
  echo "$db"
}

# One row: side, map, the split, MB per km2, bytes per km of road (0005), APE of the run in $rates_out.
row() {
  local side=$1 map=$2 split=$3 scans=$4
  awk -v side="$side" -v map="$map" -v km="${km:-0}" -v kvs="$split" '
    BEGIN { n = split(kvs, kv, " "); for (i = 1; i <= n; i++) { split(kv[i], p, "="); v[p[1]] = p[2] } }
    { e++; sum += $1; if ($1 > m) m = $1; if ($1 > 0.5 && $4 == "ok") lie++ }
    END {
      per_km = map == "0005" ? sprintf("%.2f MB", v["stored"] / 1e6 / km) : "-"
      printf "| %s | %s | %d | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.1f | %s | %.0f + %.0f (%.1f + %.1f) | %.4f / %.4f | %d |\n", map, side,
        v["points"], v["stored"] / 1e6, v["positions"] / 1e6, v["normals"] / 1e6, v["intensity"] / 1e6,
        (v["header"] + v["rest"]) / 1e6, v["stored"] / v["points"], v["stored"] / 1e6 / v["km2"], per_km,
        v["decode_ms"], v["normals_ms"], v["decode_max_ms"], v["normals_max_ms"], sum / e, m, lie }' "$scans"
}

echo "| map | build | points | MB | positions | normals | intensity | header, rest | B/point | MB/km2 of tiles | per km of road | vehicle ms: decode + normals, all tiles (slowest tile) | APE mean / max (m) | ok > 0.5 m |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
for side in before normals after; do
  bin=$after settings=() flags=()
  [[ $side == before ]] && bin=$before settings=("${old_settings[@]}")
  [[ $side == normals ]] && settings=("${normals_settings[@]}") flags=("${normals_settings[@]}")
  rates_out="$work/$side" rates_drive="$work/drive"
  db=$(tile "$side" "$bin" "$work/town.pcd" town "${flags[@]}")
  split=$("$after/bench_map_bytes" "$db" town "${settings[@]}")
  out=$(scans_stem town)
  "$bin/pl-localize" --dataset "$work/drive" --db "$db" --map town --beams 16 --odometry encoder --init gps \
    --out "$out.tum" --kitti-out "$out.txt" --timing "$out.csv" >"$out.log"
  scan_rows "$out.txt" "$work/drive/poses.txt" "$out.csv" >"$out.scans"
  town_rows+=("$(row "$side" town "$split" "$out.scans")")
  if [[ -n "$k05" ]]; then
    db=$(tile "$side" "$bin" "$k05/even.pcd" k05 "${flags[@]}")
    split=$("$after/bench_map_bytes" "$db" k05 "${settings[@]}")
    rates_drive=$drive rates_db=$db rates_map=k05
    localize k05 "$k05/gt_odd.txt"
    k05_rows+=("$(row "$side" 0005 "$split" "$(scans_stem k05).scans")")
  fi
done
printf '%s\n' "${town_rows[@]}" "${k05_rows[@]}"
