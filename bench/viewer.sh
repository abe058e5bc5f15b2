#!/usr/bin/env bash
# The map viewer (pl-server's /viewer/) in headless Chromium with software WebGL (ANGLE on
# SwiftShader: the CPU draws, so the frame rate is a floor, not a figure for a real GPU), on loopback,
# on the town loop's map (bench/town_map.sh: 201 tiles of 20 m, 1.75 M points):
#   - time to first rendered tiles: navigation start to the first frame with a tile, and to the frame
#     with all 201 tiles of the first view (the whole town), median of 3 loads in a fresh profile;
#   - frames per second with those 201 tiles in view, the view turning, 10 s.
# SCREENSHOTS=DIR also writes the map view and the diff view there, the diff against a version 2 of
# a copy of the store tiled from the town's cloud edited: a corner block cleared (tiles removed and
# changed), a kiosk built in a street (changed), a shed beyond the map's east edge (added).
#   bench/viewer.sh BIN_DIR WORK_DIR
set -euo pipefail
bin=${1:?usage: viewer.sh BIN_DIR WORK_DIR}
work=${2:?usage: viewer.sh BIN_DIR WORK_DIR}
root=$(cd "$(dirname "$0")/.." && pwd)
mkdir -p "$work"
work=$(cd "$work" && pwd)
if [[ ! -x "$bin/bench_viewer" ]]; then
  echo "viewer: skipped: $bin/bench_viewer is not built"
  exit 0
fi
if ! command -v chromium >/dev/null && ! command -v chromium-browser >/dev/null; then
  echo "viewer: skipped: chromium is not installed (apt-get install chromium; ./pl bench installs it)"
  exit 0
fi
bash "$(dirname "${BASH_SOURCE[0]}")/town_map.sh" "$bin" "$work"
db=$work/maps.sqlite
args=()
server_args=()
if [[ -n "${SCREENSHOTS:-}" ]]; then
  mkdir -p "$SCREENSHOTS" "$work/viewer"
  db=$work/viewer/maps.sqlite
  if [[ ! -f "$db" ]]; then
    cp "$work/maps.sqlite" "$db.partial"
    python3 - "$work/loop.pcd" "$work/viewer/edited.pcd" <<'PY'
import struct, sys
src, dst = sys.argv[1], sys.argv[2]
data = open(src, "rb").read()
head_end = data.index(b"DATA binary\n") + len(b"DATA binary\n")
head = data[:head_end].decode()
assert "FIELDS x y z intensity" in head and "SIZE 4 4 4 4" in head, "bench/viewer.sh expects pl-map build's x y z intensity floats"
body = data[head_end:]
points = [p for p in struct.iter_unpack("<4f", body) if not (40 <= p[0] <= 100 and -90 <= p[1] <= -45)]
box = lambda x0, x1, y0, y1, h: [(x0 + 0.2 * i, y0 + 0.2 * j, 0.2 * k, 0.5) for i in range(int((x1 - x0) / 0.2))
                                 for j in range(int((y1 - y0) / 0.2)) for k in range(int(h / 0.2))
                                 if i in (0, int((x1 - x0) / 0.2) - 1) or j in (0, int((y1 - y0) / 0.2) - 1) or k == int(h / 0.2) - 1]
points += box(100.1, 106.1, 40.1, 46.1, 3.0) + box(285.1, 295.1, 100.1, 106.1, 4.0)
lines = [l for l in head.splitlines() if not l.startswith(("WIDTH", "POINTS"))]
lines.insert(-1, "WIDTH %d" % len(points)); lines.insert(-1, "POINTS %d" % len(points))
with open(dst, "wb") as f:
    f.write(("\n".join(lines) + "\n").encode())
    f.write(b"".join(struct.pack("<4f", *p) for p in points))
PY
    "$bin/pl-map" tile --cloud "$work/viewer/edited.pcd" --db "$db.partial" --map town >/dev/null
    "$bin/pl-map" publish --db "$db.partial" --map town --version 2 >/dev/null
    mv "$db.partial" "$db"
  fi
  args=(--screenshots "$SCREENSHOTS")
  # Three vehicles on the loop for the screenshots (report token; kept an hour, past the loads).
  echo "report bench-viewer-token" >"$work/viewer/tokens.txt"
  server_args=(--tokens "$work/viewer/tokens.txt" --vehicle-timeout 3600)
fi

log=$work/viewer-server.log
source "$root/tools/start-server.sh"
start_server "$log" "$bin/pl-server" --db "$db" --listen 127.0.0.1:0 --quiet "${server_args[@]}"
server=$SERVER_PID
trap 'kill $server 2>/dev/null || true; wait $server 2>/dev/null || true' EXIT
url=$SERVER_URL
echo "pl-server $url on $(nproc) cores; $(chromium --version 2>/dev/null | head -1)"
if [[ -n "${SCREENSHOTS:-}" ]]; then
  # At the ground-truth poses of scans 150, 450 and 700 of the drive (KITTI rows: R | t).
  for spec in "van-1 150 ok" "car-2 450 degraded" "car-3 700 lost"; do
    read -r id scan health <<<"$spec"
    body=$(sed -n "${scan}p" "$work/loop/poses.txt" |
      awk -v h="$health" '{ printf "{\"x\": %.2f, \"y\": %.2f, \"z\": %.2f, \"yaw\": %.3f, \"health\": \"%s\"}", $4, $8, $12 - 1.73, atan2($5, $1), h }')
    curl -fsS -o /dev/null -H "Authorization: Bearer bench-viewer-token" -d "$body" "$url/v1/maps/town/vehicles/$id"
  done
fi
"$bin/bench_viewer" "$url" town --runs 3 --fps-seconds 10 --min-tiles 200 "${args[@]}"
