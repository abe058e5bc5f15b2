#!/usr/bin/env bash
# The main job of ./pl demo: everything the product does so far, run for real on generated data,
# then the result. So far: simulate a drive round the built-in town loop (HDL-64E, wheel encoders,
# GPS, traffic), read it back, prepare every scan as the localizer will (16 of 64 beams, 0.2 m
# voxels), and evaluate the preparation time and the GPS receiver against the ground truth.
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
echo "ground truth:     $out/ground_truth.tum"
echo "figures:          $out/plots/"
