#!/usr/bin/env bash
# A town mapped from three drives with traffic, against the simulator's truth, in one run:
#   1. three 64-beam drives through one world (seed SEED): forward, back the other way, forward
#      again, each with its own traffic (30 moving vehicles and pedestrians) and noise; their
#      traffic-free twins (same drive seeds); the world's own surfaces (pl-sim --map-out);
#   2. at true poses: the plain merge (--moving keep), the cleaned one (--moving remove), and the
#      traffic-free merge: (a) points off the world's surfaces (> 0.3 m), the ghosts; (b) the
#      traffic-free merge's points kept (a cleaned point within 0.21 m: one voxel);
#   3. a fourth drive (the other way, its own traffic) localized with 16 of its 64 beams on the
#      cleaned, the traffic-free and the plain map;
#   4. the whole build (LiDAR odometry + GPS at 1.5 m, consumer grade + loops) of 1, 2 and 3 drives:
#      time a scan and each drive's APE, with and without the loops between the drives.
# Usage: bench/multi_drive_town.sh BIN DIR [FRAMES] [SEED]
set -euo pipefail
bin=${1:?usage: multi_drive_town.sh BIN DIR [FRAMES] [SEED]}
dir=${2:?usage: multi_drive_town.sh BIN DIR [FRAMES] [SEED]}
frames=${3:-300}
seed=${4:-1}
mkdir -p "$dir"
export PL_NO_PROGRESS=1 OMP_NUM_THREADS=1
cd "$dir"

sim() {  # NAME DRIVE_SEED TRAFFIC [more pl-sim options]
  local name=$1 dseed=$2 traffic=$3
  shift 3
  [ -f "$name/done" ] && return
  "$bin/pl-sim" --route loop --seed "$seed" --frames "$frames" --drive-seed "$dseed" --traffic "$traffic" --out "$name" --force "$@" >/dev/null
  touch "$name/done"
}
echo "== $frames scans a drive, world seed $seed"
sim a 1 30
sim b 2 30 --reverse
sim c 3 30
sim a0 1 0
sim b0 2 0 --reverse
sim c0 3 0
sim probe 4 30 --reverse
[ -f world.pcd ] || "$bin/pl-sim" --route loop --seed "$seed" --frames "$frames" --out world-drive --force --map-out world.pcd >/dev/null

echo "== the merges at true poses"
three="--dataset a --dataset b --dataset c"
# (A map already in DIR is kept: delete DIR to measure again from scratch.)
[ -f plain.pcd ] || "$bin/pl-map" build $three --poses gt --moving keep --out plain.pcd >/dev/null
[ -f cleaned.pcd ] || "$bin/pl-map" build $three --poses gt --moving remove --report cleaned.json --out cleaned.pcd >cleaned.log
grep "moving things" cleaned.log
[ -f free.pcd ] || "$bin/pl-map" build --dataset a0 --dataset b0 --dataset c0 --poses gt --moving keep --out free.pcd >/dev/null

off() {  # MAP: points farther than 0.3 m from the world's surfaces
  "$bin/pl-eval" map --map "$1" --ref world.pcd --within 0.3 --json |
    python3 -c 'import json,sys; r=json.load(sys.stdin); print(r["map_points"], round(r["map_points"]*(1-r["share_within"])))'
}
kept() {  # MAP: share of the traffic-free merge's points with a MAP point within one voxel
  "$bin/pl-eval" map --map "$1" --ref free.pcd --coverage-radius 0.21 --json |
    python3 -c 'import json,sys; r=json.load(sys.stdin); print(r["reference_coverage"])'
}
read -r plain_n plain_off <<<"$(off plain.pcd)"
read -r clean_n clean_off <<<"$(off cleaned.pcd)"
read -r free_n free_off <<<"$(off free.pcd)"
plain_kept=$(kept plain.pcd)
clean_kept=$(kept cleaned.pcd)
python3 - "$plain_n" "$plain_off" "$clean_n" "$clean_off" "$free_n" "$free_off" "$plain_kept" "$clean_kept" <<'EOF'
import sys
pn, po, cn, co, fn, fo = map(int, sys.argv[1:7])
pk, ck = map(float, sys.argv[7:9])
print("| map | points | off the world's surfaces (> 0.3 m) | traffic-free merge kept (within 0.21 m) |")
print("|---|---|---|---|")
print(f"| plain merge | {pn} | {po} ({100*po/pn:.2f} %) | {100*pk:.2f} % |")
print(f"| cleaned | {cn} | {co} ({100*co/cn:.2f} %) | {100*ck:.2f} % |")
print(f"| traffic-free merge | {fn} | {fo} ({100*fo/fn:.2f} %) | 100 % |")
ghosts_plain, ghosts_clean = po - fo, co - fo
print(f"ghosts (off-surface points beyond the traffic-free merge's): plain {ghosts_plain}, cleaned {ghosts_clean}: "
      f"{100*ghosts_clean/max(ghosts_plain,1):.1f} % of the plain merge's (goal <= 2 %)")
print(f"static structure kept: {100*ck:.2f} % of the traffic-free merge (goal >= 98 %); the plain merge keeps {100*pk:.2f} %")
EOF

echo "== a fourth drive (16 of 64 beams, its own traffic) localized on each map"
localize() {  # MAP NAME
  rm -f "$2.sqlite"*
  "$bin/pl-map" tile --cloud "$1" --db "$2.sqlite" --map town >/dev/null
  "$bin/pl-map" publish --db "$2.sqlite" --map town --version 1 >/dev/null
  "$bin/pl-localize" --dataset probe --db "$2.sqlite" --map town --beams 16 --odometry encoder --init gt \
    --out "probe.$2.tum" --kitti-out "probe.$2.txt" >"probe.$2.log"
  "$bin/pl-eval" ape --est "probe.$2.txt" --gt probe/poses.txt --json >"probe.$2.ape"
  printf '%-14s APE mean %.4f m, RMSE %.4f m, max %.3f m; %s\n' "$2" \
    "$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["mean"])' "probe.$2.ape")" \
    "$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["rmse"])' "probe.$2.ape")" \
    "$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["max"])' "probe.$2.ape")" \
    "$(grep -o '[0-9]* ok, [0-9]* degraded, [0-9]* lost' "probe.$2.log")"
}
localize cleaned.pcd cleaned
localize free.pcd traffic-free
localize plain.pcd plain

echo "== the whole build, GPS at 1.5 m (consumer grade)"
for d in a b c; do
  [ -d "$d-gps" ] || "$bin/pl-dataset" degrade-gps "$d" --out "$d-gps" --sigma 1.5 --seed 7 >/dev/null
done
build() {  # TAG DRIVES... : LiDAR odometry + GPS + loops
  local tag=$1
  shift
  local args=() trajs=()
  for d in "$@"; do args+=(--dataset "$d-gps"); trajs+=(--traj-out "$tag.$d.txt"); done
  local t0 t1
  t0=$(date +%s.%N)
  "$bin/pl-map" build "${args[@]}" "${trajs[@]}" --poses lidar --gps --loops ${LOOPS_BETWEEN:-} --report "$tag.json" \
    --out "$tag.pcd" >"$tag.log"
  t1=$(date +%s.%N)
  local scans=$(( $# * frames ))
  local row="$tag: $# drives, $(python3 -c "print('%.1f' % (1000 * ($t1 - $t0) / $scans))") ms a scan (whole process)"
  for d in "$@"; do
    "$bin/pl-eval" ape --est "$tag.$d.txt" --gt "$d/poses.txt" --json >"$tag.$d.ape"
    row+="; $d APE mean $(python3 -c 'import json,sys; print("%.3f" % json.load(open(sys.argv[1]))["mean"])' "$tag.$d.ape") m"
  done
  echo "$row; loops $(python3 -c 'import json,sys; r=json.load(open(sys.argv[1])); print([d.get("loops_to") for d in r["drives"]])' "$tag.json")"
}
build one a
build two a b
build three a b c
LOOPS_BETWEEN="--loops-between off" build three-within a b c
