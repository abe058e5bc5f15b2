#!/usr/bin/env bash
# The localizer on real data at one to four times the speed: drive 0005's odd scans (map from the
# even ones at their OXTS poses, 16 of 64 beams, LiDAR only, started from the first scan's pose with
# no velocity), keeping every k-th -- the same street driven k times faster, each of its k phases
# (every k-th from the first, from the second, ...) a drive of its own, their scans summed into one row -- with and without LiDAR
# odometry, with and without motion compensation (map and scans), and pcl::IterativeClosestPoint on
# the same scans from the same start (bench_localize --every K); then kidnappings (25 to 40 odd scans,
# 20 to 33 m, cut out; with the clock running on, and closed over the cut: no hint at all), and global
# starts (--init global, no pose) at 10 scans spread over the drive. Per run: APE mean / median / max (3D, as pl-eval ape), scans
# more than 0.5 m off and how many of them were reported ok (must be 0), status counts, the share of
# scans whose horizontal error exceeds their protection level (a horizontal bound), the median
# protection level, and the median registration time (LiDAR odometry and integrity checks included).
#   bench/localize_rates.sh BIN_DIR WORK_DIR
set -euo pipefail
bin=${1:?usage: localize_rates.sh BIN_DIR WORK_DIR}
work=${2:?usage: localize_rates.sh BIN_DIR WORK_DIR}
source "$(dirname "$0")/k05_map.sh"
k05_rates localize_rates "$bin" "$work" rates || exit 0

echo "| run | scans | APE mean | median | max | > 0.5 m | of them ok | ok / degraded / lost | error > PL | PL median | ms median (odometry + registration + checks) |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for lo in on off; do
  for k in 1 2 3 4; do
    rate_phases "every $k, odometry $lo" "$k" "$k05/gt_odd.txt" --lidar-odometry "$lo"
  done
done
# Motion compensation: a map merged with --deskew on, scans localized with --deskew on. (The map is
# named for the sweep's timing, counter-clockwise since 2026-12-03, so a work dir's older map is not
# reused.)
if [[ ! -f "$k05/deskew_ccw.sqlite" ]]; then
  "$bin/pl-map" build --dataset "$drive" --poses gt --every 2 --deskew on --out "$k05/deskew_ccw.pcd" >/dev/null
  rm -f "$k05/deskew_ccw.sqlite.partial"*
  "$bin/pl-map" tile --cloud "$k05/deskew_ccw.pcd" --db "$k05/deskew_ccw.sqlite.partial" --map k05 >/dev/null
  "$bin/pl-map" publish --db "$k05/deskew_ccw.sqlite.partial" --map k05 --version 1 >/dev/null
  mv "$k05/deskew_ccw.sqlite.partial" "$k05/deskew_ccw.sqlite"
fi
for k in 1 2 3 4; do
  db="$k05/deskew_ccw.sqlite" rate_phases "every $k, motion compensated" "$k" "$k05/gt_odd.txt" --deskew on
done
# Kidnappings: K scans, then N cut out.
for cut in 30,25 20,40 10,30; do
  k=${cut%,*} n=${cut#*,}
  awk -v k="$k" -v n="$n" '!((NR - 1) >= k && (NR - 1) < k + n)' "$k05/gt_odd.txt" >"$k05/rates/gt_cut.txt"
  run "cut $cut, clock on" "$k05/rates/gt_cut.txt" --cut "$cut"
  run "cut $cut, clock closed" "$k05/rates/gt_cut.txt" --cut "$cut" --cut-clock close
  # The first scan after the jump, and how many scans later the pose was back within 0.2 m (horizontal).
  awk -v k="$k" 'NR == k + 1 { printf "    first scan after the jump: %s, protection %.1f m; ", $4, $2 }
                 NR > k && !back && $5 < 0.2 { back = NR - k - 1; printf "back within 0.2 m %d scans later\n", back }
                 END { if (!back) print "not back" }' "$k05/rates/cut_${cut/,/}_clock_closed.scans"
done

# PCL's ICP on the same scans from the same start (no odometry: constant velocity of its own estimates).
echo
echo "| pcl::IterativeClosestPoint (bench_localize) | APE mean | median | max | within 0.5 m | converged |"
echo "|---|---|---|---|---|---|"
if [[ -x "$bin/bench_localize" ]]; then
  # Each phase in its own run; the row sums their scans (the median is each phase's, listed).
  for k in 1 2 3 4; do
    for ((p = 0; p < k; p++)); do
      "$bin/bench_localize" "$drive" "$k05/maps.sqlite" --map k05 --every "$k" --phase "$p" >"$k05/rates/pcl_${k}_$p.log"
    done
    awk -v k="$k" '/^drive / { for (i = 1; i <= NF; i++) if ($i == "odd") n = $(i - 1) }
      /^pcl ICP point-to-point/ { N += n; s += n * $(NF-9); med = med (med == "" ? "" : " / ") $(NF-8)
        if ($(NF-6) > m) m = $(NF-6); w += n * $(NF-4) / 100; c += n * $(NF-5) / 100 }
      END { printf "| every %d%s | %.3f | %s | %.3f | %.1f %% | %.1f %% |\n", k, (k > 1 ? sprintf(", phases 0-%d", k - 1) : ""), s / N, med, m, 100 * w / N, 100 * c / N }' \
      "$k05/rates/pcl_${k}_"*.log
  done
else
  echo "(bench_localize not built: PCL missing)"
fi

# Global starts: no pose, at 10 odd scans spread over the drive, three scans each. A start is found
# when a scan is ok; it must then be within 0.2 m. The time is that of the first scan's search.
echo
echo "| global start at odd scan | found | error when found (m) | first search ms |"
echo "|---|---|---|---|"
for first in 0 8 16 24 32 40 48 56 64 72; do
  head -n $((first + 3)) "$k05/gt_odd.txt" | tail -n 3 >"$k05/rates/gt_global.txt"
  run "global $first" "$k05/rates/gt_global.txt" --init global --first "$first" --count 3 >/dev/null
  awk -v f="$first" 'NR == 1 { ms = $3 } $4 == "ok" && !found { found = 1; e = $5 }
                     END { printf "| %d | %s | %s | %.0f |\n", f, found ? "yes" : "no", found ? sprintf("%.3f", e) : "-", ms }' \
    "$k05/rates/global_$first.scans"
done
