#!/usr/bin/env bash
# The packet decoders against the makers' decoder, on the real captures in ../shared/data/sensor-packets:
# for each Velodyne, Hesai and RoboSense capture, bench_lidar_reference's row (points on each side,
# reference points matched within 1 mm, the largest position and azimuth errors, channels and returns
# agreeing); for each Ouster pcap, its beams against its metadata (bench_lidar_ouster_check); then
# pl-dataset info's sensor line for each recording. Each capture is decoded with the parameters the
# reference decoder's tests used for it (tier4/nebula).
#   bench/lidar_decoders.sh BIN_DIR
set -uo pipefail
bin=${1:?usage: lidar_decoders.sh BIN_DIR}
root=$(cd "$(dirname "$0")/.." && pwd)
data=$("$root/tools/shared-data.sh") || exit 0
nebula=$data/sensor-packets/nebula
cal=$nebula/calibration
export PL_NO_PROGRESS=1

# The Helios-16P of the capture: its angle file is not in the shared data. These are its 16 lines
# (vertical, horizontal correction in degrees) as tier4/nebula has them (RobosenseHelios16P.csv at
# c60082d5); without it the decoder takes the angles from the capture's DIFOP packets.
helios=$root/build/RobosenseHelios16P.csv
mkdir -p "$root/build"
cat >"$helios" <<'CSV'
14.94,-4.05
13.03,3.61
10.92,-4.00
8.90,3.58
6.96,-3.97
5.46,3.56
3.98,-3.96
2.67,3.55
1.33,-3.95
0,3.55
-1.33,-3.95
-2.67,3.55
-3.96,-3.96
-5.23,3.56
-6.63,-3.97
-8.01,3.57
CSV

# capture folder | vendor | calibration file | options (the reference decoder's test parameters)
captures=(
  "vlp16|velodyne|$cal/VLP16.yaml|"
  "vlp32|velodyne|$cal/VLP32.yaml|--min-range 0.4 --max-range 50 --cut-azimuth 180"
  "vls128|velodyne|$cal/VLS128.yaml|"
  "xt16|hesai|$cal/PandarXT16.csv|--min-range 0.05 --max-range 120"
  "xt32|hesai|$cal/PandarXT32.csv|--min-range 0.05 --max-range 120"
  "xt32m|hesai|$cal/PandarXT32M.csv|--min-range 0.5 --max-range 300"
  "qt64|hesai|$cal/PandarQT64.csv|--min-range 0.1 --max-range 60"
  "qt128|hesai|$cal/PandarQT128.csv|--min-range 0.3 --max-range 300"
  "40p|hesai|$cal/Pandar40P.csv|--min-range 0.3 --max-range 200"
  "64|hesai|$cal/Pandar64.csv|--min-range 0.3 --max-range 200"
  "robosense/helios16P|robosense|$helios|--model Helios-16P --min-range 0.2 --max-range 200"
)
failed=0
echo "| capture | model | points (ours) | points (reference) | matched within 1 mm | max position error | max azimuth error | channels agreeing | returns agreeing |"
echo "|---|---|---|---|---|---|---|---|---|"
for c in "${captures[@]}"; do
  IFS='|' read -r dir vendor calibration extra <<<"$c"
  bag=$(find "$nebula/$dir" -mindepth 1 -maxdepth 2 -name '*.db3' -not -path '*/all_points/*' -printf '%h\n' | head -1)
  for pcd in "$nebula/$dir"/*.pcd; do
    args=(--vendor "$vendor" --recording "$bag" --reference "$pcd")
    [[ -n "$calibration" ]] && args+=(--lidar-calibration "$calibration")
    # shellcheck disable=SC2206
    [[ -n "$extra" ]] && args+=($extra)
    row=$("$bin/bench_lidar_reference" "${args[@]}" 2>"$root/build/lidar_decoders.log") || failed=1
    echo "| $dir/$(basename "$pcd" .pcd) |${row#|}"
  done
done

echo
o=$data/sensor-packets/ouster
"$bin/bench_lidar_ouster_check" "$o/OS-0-128-U1_v2.3.0_1024x10.pcap=$o/OS-0-128-U1_v2.3.0_1024x10.json" \
  "$o/OS-0-32-U1_v2.2.0_1024x10.pcap=$o/OS-0-32-U1_v2.2.0_1024x10.json" "$o/OS-1-32-G_v2.1.1_1024x10.pcap=$o/OS-1-32-G_v2.1.1_1024x10.json" \
  "$o/OS-1-64_1024x10_fw20.pcap=$o/OS-1-64_sensor_config_reduced.json=OS-1-64" \
  "$o/OS-2-128-U1_v2.3.0_1024x10.pcap=$o/OS-2-128-U1_v2.3.0_1024x10.json" "$o/512x10_raw.bag" || failed=1

echo
echo "pl-dataset info on each recording of packets:"
for c in "${captures[@]}"; do
  IFS='|' read -r dir vendor calibration extra <<<"$c"
  bag=$(find "$nebula/$dir" -mindepth 1 -maxdepth 2 -name '*.db3' -not -path '*/all_points/*' -printf '%h\n' | head -1)
  args=()
  [[ -n "$calibration" ]] && args+=(--lidar-calibration "$calibration")
  printf '%-22s ' "$dir"
  "$bin/pl-dataset" info "$bag" "${args[@]}" 2>&1 | grep -E '^lidar packets|^Error|error' | sed 's/^lidar packets *//' || failed=1
done
printf '%-22s ' "ouster 512x10 bag"
"$bin/pl-dataset" info "$data/sensor-packets/ouster/512x10_raw.bag" 2>&1 | grep -E '^lidar packets|rror' | sed 's/^lidar packets *//'
for pcap in "$data"/sensor-packets/ouster/*.pcap; do
  json=${pcap%.pcap}.json
  [[ -f "$json" ]] || json=$data/sensor-packets/ouster/OS-1-64_sensor_config_reduced.json
  model=()
  [[ $pcap == *OS-1-64_1024x10_fw20* ]] && model=(--lidar-model OS-1-64)  # its reduced metadata names no model
  printf '%-22s ' "$(basename "$pcap" .pcap)"
  "$bin/pl-dataset" info "$pcap" --lidar-calibration "$json" "${model[@]}" 2>&1 | grep -E '^lidar packets|rror' | sed 's/^lidar packets *//'
done
exit $failed
