#!/usr/bin/env bash
# The benchmarks' map of the town: one lap of pl-sim's town loop, 64 beams, merged at the
# ground-truth poses, 0.2 m voxels, 20 m tiles, published as map "town" (version 1) in
# WORK_DIR/maps.sqlite. Made once: a store already there is kept.
#   bash bench/town_map.sh BIN_DIR WORK_DIR
set -euo pipefail
bin=${1:?usage: town_map.sh BIN_DIR WORK_DIR}
work=${2:?usage: town_map.sh BIN_DIR WORK_DIR}
if [[ ! -f "$work/maps.sqlite" ]]; then
  "$bin/pl-sim" --route loop --out "$work/loop" --force >/dev/null
  "$bin/pl-map" build --dataset "$work/loop" --poses gt --out "$work/loop.pcd" >/dev/null
  "$bin/pl-map" tile --cloud "$work/loop.pcd" --db "$work/maps.sqlite.partial" --map town >/dev/null
  "$bin/pl-map" publish --db "$work/maps.sqlite.partial" --map town --version 1 >/dev/null
  mv "$work/maps.sqlite.partial" "$work/maps.sqlite"
fi
