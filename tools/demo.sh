#!/usr/bin/env bash
# The main job of ./pl demo: everything the product does so far, run for real, then the result.
# So far: read a real drive (KITTI raw 2011_09_26_drive_0005, from ../shared/data), export its
# ground truth, prepare every scan as the localizer will (16 of 64 beams, 0.2 m voxels) and evaluate
# the preparation time with pl-eval.
#   tools/demo.sh BIN_DIR OUT_DIR
set -euo pipefail
bin=${1:?usage: tools/demo.sh BIN_DIR OUT_DIR}
out=${2:?usage: tools/demo.sh BIN_DIR OUT_DIR}
root=$(cd "$(dirname "$0")/.." && pwd)
mkdir -p "$out"
out=$(cd "$out" && pwd)

data=$("$root/tools/shared-data.sh")
drive="$data/kitti-raw-2011_09_26_drive_0005_sync"

step() { printf '\n\033[1m-- %s\033[0m\n' "$*"; }

step "pl-dataset info: what the drive holds"
"$bin/pl-dataset" info "$drive" --sample 154

step "pl-dataset poses: ground-truth LiDAR poses from the OXTS RTK/INS"
"$bin/pl-dataset" poses "$drive" --format tum --out "$out/ground_truth.tum"

step "pl-dataset scans: 16 of 64 beams, 2-100 m, 0.2 m voxels"
"$bin/pl-dataset" scans "$drive" --beams 16 --voxel 0.2 --timing "$out/prepare.csv"

step "pl-eval timing: per-scan preparation time"
"$bin/pl-eval" timing --csv "$out/prepare.csv" --column prepare_ms --plot "$out/plots"

step "result"
echo "ground truth: $out/ground_truth.tum"
echo "per-scan figures: $out/prepare.csv; plots in $out/plots"
