#!/usr/bin/env bash
# Drive 0005 beyond the rates table: what a held-out drive or an integrator may bring. On the
# paper's protocol (odd scans on the even scans' map, LiDAR only, from the first scan's pose with no
# velocity) with a narrower field of view (180, 120, 90 deg, centred ahead) at 1-4 times the speed,
# other beam counts (8, 32, 64 of 64), faster than the issue asks (every 5th odd scan: 4.2 m between
# scans), and starts given as numbers off the truth: 3 m and 10 deg (searched), 8 and 12 m (beyond
# the 6 m search radius), heading reversed, and 1.5 m off with the search turned off. One row per
# run as localize_rates.sh prints them; the column that must stay 0 is "of them ok". Then the drive
# driven backwards (the vehicle reversing), at 1-4x and at 180 deg.
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

# The drive driven backwards: the scans and OXTS records in reverse order, the times mirrored (the
# same intervals), made once in WORK as links to the drive's scans. The protocol again on it: its
# even scans (the drive's odd ones) are the map, its odd ones are localized, the vehicle reversing.
rev="$work/k05_reversed/$(basename "$drive")"
if [[ ! -f "$rev/oxts/timestamps.txt" ]]; then
  rm -rf "$work/k05_reversed"
  mkdir -p "$rev/oxts/data" "$rev/velodyne_points/data"
  cp "$drive/calib_imu_to_velo.txt" "$rev/"
  cp "$drive/oxts/dataformat.txt" "$rev/oxts/" 2>/dev/null || true
  n=$(ls "$drive/velodyne_points/data" | wc -l)
  for ((i = 0; i < n; i++)); do
    src=$(printf %010d $((n - 1 - i))) dst=$(printf %010d "$i")
    ln -s "$drive/velodyne_points/data/$src.bin" "$rev/velodyne_points/data/$dst.bin"
    cp "$drive/oxts/data/$src.txt" "$rev/oxts/data/$dst.txt"
  done
  /usr/bin/python3 - "$drive/oxts/timestamps.txt" "$rev/oxts/timestamps.txt" <<'PYEOF'
import calendar, sys, time
ns = []
for line in open(sys.argv[1]):
    if not line.strip():
        continue
    day, clock = line.split()
    hms, frac = clock.split('.')
    ns.append(calendar.timegm(time.strptime(day + ' ' + hms, '%Y-%m-%d %H:%M:%S')) * 10**9 + int(frac.ljust(9, '0')))
with open(sys.argv[2], 'w') as out:
    for i in range(len(ns)):
        sec, frac = divmod(ns[0] + ns[-1] - ns[len(ns) - 1 - i], 10**9)
        out.write(time.strftime('%Y-%m-%d %H:%M:%S', time.gmtime(sec)) + '.%09d\n' % frac)
PYEOF
fi
k05_even_map "$bin" "$rev" "$work/k05_reversed/map"
rates_drive=$rev rates_db=$work/k05_reversed/map/maps.sqlite
for k in 1 2 3 4; do rate_phases "driven backwards, every $k" "$k" "$work/k05_reversed/map/gt_odd.txt"; done
for k in 1 2; do rate_phases "driven backwards, field of view 180, every $k" "$k" "$work/k05_reversed/map/gt_odd.txt" --fov 180; done
