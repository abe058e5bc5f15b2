# Sourced by the benchmarks that cut real drive 0005 in two: its OXTS poses in DIR/oxts.txt, its GPS
# degraded to a consumer receiver (1 Hz, sigma 1.5 m) in DIR/consumer, and its scans 0-76 and 77-153
# as two drives DIR/first and DIR/second (links to the drive's files, each with the consumer GPS).
#   k05_halves BIN_DIR DRIVE DIR
k05_halves() {
  local bin=$1 drive=$2 d=$3
  "$bin/pl-dataset" poses "$drive" --out "$d/oxts.txt" >/dev/null
  "$bin/pl-dataset" degrade-gps "$drive" --out "$d/consumer" --rate 1 --sigma 1.5 --seed 1 >/dev/null
  k05_half "$drive" "$d" first 0 76
  k05_half "$drive" "$d" second 77 153
}

# k05_half DRIVE DIR NAME FIRST LAST: the consumer drive's scans FIRST..LAST (KITTI raw reads any
# subset of frames).
k05_half() {
  local drive=$1 d=$2 h="$2/$3" i f
  rm -rf "$h"
  mkdir -p "$h/velodyne_points/data" "$h/oxts/data"
  ln -s "$drive/calib_imu_to_velo.txt" "$h/"
  ln -s "$drive/oxts/timestamps.txt" "$drive/oxts/dataformat.txt" "$h/oxts/"
  [ -f "$drive/velodyne_points/timestamps.txt" ] && ln -s "$drive/velodyne_points/timestamps.txt" "$h/velodyne_points/"
  cp "$d/consumer/gps.csv" "$h/"
  for i in $(seq "$4" "$5"); do
    f=$(printf '%010d' "$i")
    ln -s "$drive/velodyne_points/data/$f.bin" "$h/velodyne_points/data/"
    ln -s "$drive/oxts/data/$f.txt" "$h/oxts/data/"
  done
}
