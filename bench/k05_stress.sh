#!/usr/bin/env bash
# Drive 0005 beyond the rates table: what a held-out drive or an integrator may bring. On the
# paper's protocol (odd scans on the even scans' map, LiDAR only, from the first scan's pose with no
# velocity) with a narrower field of view (180, 120, 90 deg, centred ahead) at 1-4 times the speed,
# other beam counts (8, 32, 64 of 64), faster than the issue asks (every 5th odd scan: 4.2 m between
# scans), and starts given as numbers off the truth: 3 m and 10 deg (searched), 8 and 12 m (beyond
# the 6 m search radius), heading reversed, and 1.5 m off with the search turned off. One row per
# run as localize_rates.sh prints them; the column that must stay 0 is "of them ok".
#   bench/k05_stress.sh BIN_DIR WORK_DIR
set -euo pipefail
bin=${1:?usage: k05_stress.sh BIN_DIR WORK_DIR}
work=${2:?usage: k05_stress.sh BIN_DIR WORK_DIR}
source "$(dirname "$0")/k05_map.sh"
k05_rates k05_stress "$bin" "$work" stress || exit 0
gt=$k05/gt_odd.txt

echo "| run | scans | APE mean | median | max | > 0.5 m | of them ok | ok / degraded / lost | error > PL | PL median | ms median (odometry + registration + checks) |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for fov in 180 120 90; do
  for k in 1 2 3 4; do rate_phases "field of view $fov, every $k" "$k" "$gt" --fov "$fov"; done
done
for beams in 8 32 64; do run "$beams beams" "$gt" --beams "$beams"; done
rate_phases "every 5" 5 "$gt"
# The first odd scan's truth as x,y,z,yaw (degrees), and starts given off it.
read -r x y z yaw < <(head -1 "$gt" | awk '{ printf "%.4f %.4f %.4f %.4f\n", $4, $8, $12, atan2($5, $1) * 57.29577951308232 }')
off() { awk -v x="$x" -v y="$y" -v z="$z" -v w="$yaw" -v dx="$1" -v dy="$2" -v dw="$3" 'BEGIN { printf "%.4f,%.4f,%.4f,%.4f", x + dx, y + dy, z, w + dw }'; }
run "start 3 m and 10 deg off" "$gt" --init "$(off 3 0 10)"
run "start 8 m across" "$gt" --init "$(off 0 8 0)"
run "start 12 m along" "$gt" --init "$(off 12 0 0)"
run "start heading reversed" "$gt" --init "$(off 0 0 180)"
run "start 1.5 m off, no search" "$gt" --init "$(off 1.5 0 0)" --init-search off
