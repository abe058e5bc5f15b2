#!/usr/bin/env bash
# Prints the folder holding the expanded real data (../shared/data beside the repository, expanded
# once into build/data), or fails with what to do.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
data="$root/build/data"
shared="$root/../shared/data"
if [[ ! -d "$data/kitti-raw-2011_09_26_drive_0005_sync/velodyne_points/data" ]]; then
  if [[ ! -x "$shared/unpack.sh" ]]; then
    echo "no real data: expected ../shared/data beside the repository (with unpack.sh)" >&2
    exit 1
  fi
  echo "expanding ../shared/data into build/data (once)" >&2
  "$shared/unpack.sh" "$data" >/dev/null
fi
echo "$data"
