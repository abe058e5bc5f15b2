#!/usr/bin/env bash
# Where drive 0005's 1x error comes from: the paper's protocol (map of the even scans at their OXTS
# poses, the odd scans localized with 16 beams, LiDAR only, from the first odd scan's pose) run on
# windows of the drive -- frames A..B copied as a drive of their own (links to the scans, the OXTS
# lines of those frames) -- so that the map holds only the even scans of the window. Prints each
# window's APE and the error of the odd scans of frames 49-57 (the left turn where the whole drive
# loses most), then the whole drive for comparison.
#   bench/k05_windows.sh BIN_DIR WORK_DIR [A-B ...]   (default windows: 44-66 40-66 36-66 30-66 20-90)
set -euo pipefail
bin=${1:?usage: k05_windows.sh BIN_DIR WORK_DIR [A-B ...]}
work=${2:?usage: k05_windows.sh BIN_DIR WORK_DIR [A-B ...]}
shift 2
windows=("$@")
[[ ${#windows[@]} -gt 0 ]] || windows=(44-66 40-66 36-66 30-66 20-90)
source "$(dirname "$0")/k05_map.sh"
k05_map k05_windows "$bin" "$work" || exit 0
export PL_NO_PROGRESS=1 OMP_NUM_THREADS=1

# protocol DRIVE DIR FIRST_FRAME: map, localization, "mean max | frame:error ..." for frames 49-57.
protocol() {
  local d=$1 w=$2 first=$3
  k05_even_map "$bin" "$d" "$w"
  "$bin/pl-localize" --dataset "$d" --db "$w/maps.sqlite" --map k05 --beams 16 --scans odd --odometry lidar \
    --init gt --out "$w/odd.tum" --kitti-out "$w/odd.txt" >/dev/null
  # Line i of the odd files is frame first + 1 + 2 i.
  grep -v '^#' "$w/odd.txt" | paste -d' ' - "$w/gt_odd.txt" | awk -v first="$first" '
    { e = sqrt(($4 - $16)^2 + ($8 - $20)^2 + ($12 - $24)^2); s += e; n++; if (e > m) m = e
      f = first + 1 + 2 * (NR - 1); if (f >= 49 && f <= 57) turn = turn sprintf(" %d:%.3f", f, e) }
    END { printf "%d odd scans, APE mean %.4f m, max %.3f m | frames 49-57:%s\n", n, s / n, m, turn }'
}

for win in "${windows[@]}"; do
  a=${win%-*} b=${win#*-}
  [[ $a =~ ^[0-9]+$ && $b =~ ^[0-9]+$ && $((a % 2)) -eq 0 && a -lt 49 && b -gt 57 ]] ||
    { echo "k05_windows: window $win: give A-B with A even, A < 49 and B > 57 (frames of drive 0005)"; exit 2; }
  d="$work/k05_windows/drive_$win"
  if [[ ! -f "$d/oxts/timestamps.txt" ]]; then
    rm -rf "$d"
    mkdir -p "$d/oxts/data" "$d/velodyne_points/data"
    cp "$drive/calib_imu_to_velo.txt" "$d/"
    cp "$drive/oxts/dataformat.txt" "$d/oxts/"
    for ((i = a; i <= b; i++)); do
      printf -v src '%010d' "$i"
      printf -v dst '%010d' $((i - a))
      ln -s "$drive/velodyne_points/data/$src.bin" "$d/velodyne_points/data/$dst.bin"
      ln -s "$drive/oxts/data/$src.txt" "$d/oxts/data/$dst.txt"
    done
    sed -n "$((a + 1)),$((b + 1))p" "$drive/oxts/timestamps.txt" >"$d/oxts/timestamps.txt"
  fi
  printf 'frames %s (map: even frames %d-%d): ' "$win" "$a" "$((b - b % 2))"
  protocol "$d" "$work/k05_windows/run_$win" "$a"
done
printf 'the whole drive (map: every even frame): '
protocol "$drive" "$work/k05_windows/run_all" 0
