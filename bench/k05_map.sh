# Sourced by the drive-0005 benchmarks: finds the real drive and prepares, once, the paper's map of
# its even scans at their OXTS poses (0.2 m voxels, tiled into a SQLite map store) in WORK/k05, with
# the ground truth of every scan (gt.txt) and of the odd ones (gt_odd.txt). PL_K05_MOVING=remove
# builds that map with --moving remove (default keep); give it a WORK_DIR of its own (made once).
#   k05_map NAME BIN_DIR WORK_DIR  -> sets drive and k05; returns 1 (after saying so) without the data
k05_map() {
  local name=$1 bin=$2 work=$3 root data
  root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
  data=$("$root/tools/shared-data.sh" 2>/dev/null || true)
  drive="$data/kitti-raw-2011_09_26_drive_0005_sync"
  if [[ -z "$data" || ! -d "$drive/velodyne_points/data" ]]; then
    echo "$name: skipped, the real data is absent (tools/shared-data.sh finds no drive 0005)"
    return 1
  fi
  k05="$work/k05"
  mkdir -p "$k05"
  k05=$(cd "$k05" && pwd)
  if [[ ! -f "$k05/maps.sqlite" ]]; then
    echo "preparing the map of the even scans in $k05 (once)"
  fi
  k05_even_map "$bin" "$drive" "$k05"
}

# The protocol's map and truth for any KITTI raw drive folder: the even scans merged at their OXTS
# poses into DIR/maps.sqlite (map k05, version 1; made once), every scan's truth in DIR/gt.txt and
# the odd ones' in DIR/gt_odd.txt.
#   k05_even_map BIN_DIR DRIVE DIR
k05_even_map() {
  local bin=$1 d=$2 w=$3
  mkdir -p "$w"
  if [[ ! -f "$w/maps.sqlite" ]]; then
    rm -f "$w/maps.sqlite.partial"*
    "$bin/pl-map" build --dataset "$d" --poses gt --every 2 --moving "${PL_K05_MOVING:-keep}" --out "$w/even.pcd" >/dev/null
    "$bin/pl-map" tile --cloud "$w/even.pcd" --db "$w/maps.sqlite.partial" --map k05 >/dev/null
    "$bin/pl-map" publish --db "$w/maps.sqlite.partial" --map k05 --version 1 >/dev/null
    mv "$w/maps.sqlite.partial" "$w/maps.sqlite"
  fi
  "$bin/pl-dataset" poses "$d" --out "$w/gt.txt" >/dev/null
  grep -v '^#' "$w/gt.txt" | awk 'NR % 2 == 0' >"$w/gt_odd.txt"
}

# The rate benchmarks on the protocol: k05_map, then rates_run.sh's functions (run, rate_phases,
# summarize) writing to WORK/k05/SUBDIR; the caller sets bin.
#   k05_rates NAME BIN_DIR WORK_DIR SUBDIR  -> returns 1 (after saying so) without the data
k05_rates() {
  k05_map "$1" "$2" "$3" || return 1
  mkdir -p "$k05/$4"
  export PL_NO_PROGRESS=1 OMP_NUM_THREADS=1
  rates_drive=$drive rates_db=$k05/maps.sqlite rates_map=k05 rates_out=$k05/$4
  source "$(dirname "${BASH_SOURCE[0]}")/rates_run.sh"
}
