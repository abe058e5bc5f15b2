#!/usr/bin/env bash
# The map service under load, measured against nginx serving the very same tile bytes as static
# files, in the same run: wrk with 64 keep-alive connections on one thread (the other core serves),
# five alternating rounds of 4 s each, medians quoted.
#   bench/bench_server.sh BIN_DIR WORK_DIR
set -euo pipefail
bin=${1:?usage: bench_server.sh BIN_DIR WORK_DIR}
work=${2:?usage: bench_server.sh BIN_DIR WORK_DIR}
mkdir -p "$work"
work=$(cd "$work" && pwd)
for tool in nginx wrk curl; do
  command -v "$tool" >/dev/null || { echo "bench_server: $tool is missing (apt-get install nginx-light wrk curl)"; exit 0; }
done

# A map: one lap of the town loop, 64 beams, merged at the ground-truth poses, 0.2 m voxels.
bash "$(dirname "${BASH_SOURCE[0]}")/town_map.sh" "$bin" "$work"
# The same store also holds a map of small tiles (about 4 KB each: a few hundred points of sparse
# ground a tile), for the per-request cost that small answers expose.
if ! "$bin/pl-map" list --db "$work/maps.sqlite" 2>/dev/null | grep -q "^tiles4k"; then
  python3 - "$work/small.pcd" <<'PY'
import math, random, sys
random.seed(7)
pts = []
for tx in range(20):
    for ty in range(20):
        for _ in range(900):
            x, y = tx * 20 + random.uniform(0.1, 19.9), ty * 20 + random.uniform(0.1, 19.9)
            pts.append((x, y, 0.3 * math.sin(0.2 * x) + 0.2 * math.cos(0.3 * y) + random.uniform(0, 0.05)))
with open(sys.argv[1], "w") as f:
    f.write("# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n")
    f.write("WIDTH %d\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS %d\nDATA ascii\n" % (len(pts), len(pts)))
    f.writelines("%.3f %.3f %.3f\n" % p for p in pts)
PY
  "$bin/pl-map" tile --cloud "$work/small.pcd" --db "$work/maps.sqlite" --map tiles4k --origin 49.0,8.4,100 >/dev/null
  "$bin/pl-map" publish --db "$work/maps.sqlite" --map tiles4k --version 1 >/dev/null
fi
"$bin/bench_tiles" "$work/maps.sqlite" town

port_ours=18481
port_nginx=18482
"$bin/pl-server" --db "$work/maps.sqlite" --listen 127.0.0.1:$port_ours --threads 2 --quiet >"$work/server.log" 2>&1 &
server=$!
trap 'kill $server 2>/dev/null; [[ -f $work/nginx.pid ]] && kill $(cat $work/nginx.pid) 2>/dev/null; true' EXIT
for _ in $(seq 50); do curl -sf "http://127.0.0.1:$port_ours/healthz" >/dev/null && break; sleep 0.1; done

# The same bytes as static files under the same paths, for nginx.
rm -rf "$work/www"
for map in town tiles4k; do
  curl -sf "http://127.0.0.1:$port_ours/v1/maps/$map/roi?x=100&y=50&radius=2000" |
    python3 -c 'import json,sys; [print(t["url"]) for t in json.load(sys.stdin)["tiles"]]' >"$work/paths-$map.txt"
  while read -r p; do
    mkdir -p "$work/www$(dirname "$p")"
    curl -sf "http://127.0.0.1:$port_ours$p" -o "$work/www$p"
  done <"$work/paths-$map.txt"
done
cat >"$work/nginx.conf" <<CONF
worker_processes 2;
pid $work/nginx.pid;
error_log $work/nginx-error.log;
events { worker_connections 1024; }
http {
  access_log off;
  sendfile on;
  tcp_nopush on;
  keepalive_requests 1000000;
  default_type application/octet-stream;
  server { listen 127.0.0.1:$port_nginx; root $work/www; }
}
CONF
nginx -c "$work/nginx.conf" -p "$work"
sleep 0.3

# wrk walks the tile paths round robin.
for map in town tiles4k; do
  {
    echo "paths = {"
    sed 's/.*/  "&",/' "$work/paths-$map.txt"
    echo "}"
    echo 'i = 0'
    echo 'request = function() i = (i % #paths) + 1; return wrk.format("GET", paths[i]) end'
  } >"$work/tiles-$map.lua"
done
# ROI queries at points along the loop, with the client's current tiles unknown (worst case).
python3 - "$work/roi.lua" <<'PY'
import math, sys
pts = [(x, 0) for x in range(0, 210, 15)] + [(210, y) for y in range(0, 105, 15)] + [(x, 90) for x in range(0, 210, 15)]
with open(sys.argv[1], "w") as f:
    f.write("paths = {\n" + "".join('  "/v1/maps/town/roi?x=%d&y=%d&radius=60",\n' % p for p in pts) + "}\n")
    f.write('i = 0\nrequest = function() i = (i % #paths) + 1; return wrk.format("GET", paths[i]) end\n')
PY

run_wrk() {  # URL SCRIPT SECONDS -> "requests/s p99_ms" (a run that printed no figures is run again, once)
  local out
  out=$(wrk_once "$@")
  [[ $out == *" "?* ]] || out=$(wrk_once "$@")
  echo "$out"
}
wrk_once() {
  wrk -t1 -c64 -d"$3"s --latency -s "$2" "$1" 2>&1 | awk '
    /Requests\/sec/ {rps=$2}
    / 99%/ {v=$2; if (v ~ /us$/) {sub(/us/,"",v); v=v/1000} else if (v ~ /ms$/) {sub(/ms/,"",v)} else if (v ~ /s$/) {sub(/s/,"",v); v=v*1000}; p99=v}
    END {printf "%s %s\n", rps, p99}'
}
# Alternate short rounds, ours then nginx, so that a ratio holds when the shared machine's speed drifts;
# quote medians.
rounds=5
for map in town tiles4k; do
  : >"$work/rounds-$map.txt"
  for r in $(seq $rounds); do
    read -r a ap < <(run_wrk "http://127.0.0.1:$port_ours" "$work/tiles-$map.lua" 4)
    read -r b bp < <(run_wrk "http://127.0.0.1:$port_nginx" "$work/tiles-$map.lua" 4)
    echo "$a $ap $b $bp" >>"$work/rounds-$map.txt"
  done
done
# ROI queries on the same server (2 threads), then on one with a single thread: one origin core.
port_one=18483
"$bin/pl-server" --db "$work/maps.sqlite" --listen 127.0.0.1:$port_one --threads 1 --quiet >"$work/server1.log" 2>&1 &
server_one=$!
trap 'kill $server $server_one 2>/dev/null; [[ -f $work/nginx.pid ]] && kill $(cat $work/nginx.pid) 2>/dev/null; true' EXIT
for _ in $(seq 50); do curl -sf "http://127.0.0.1:$port_one/healthz" >/dev/null && break; sleep 0.1; done
: >"$work/roi_rounds.txt"
for r in 1 2 3; do
  read -r a ap < <(run_wrk "http://127.0.0.1:$port_ours" "$work/roi.lua" 4)
  read -r b bp < <(run_wrk "http://127.0.0.1:$port_one" "$work/roi.lua" 4)
  echo "$a $ap $b $bp" >>"$work/roi_rounds.txt"
done
for map in town tiles4k; do
tiles=$(wc -l <"$work/paths-$map.txt")
mean_kb=$(du -sb --apparent-size "$work/www/v1/maps/$map" | awk -v n="$tiles" '{printf "%.1f", $1 / n / 1024}')
echo "tile GET, map $map: $tiles distinct tiles of $mean_kb KB on average round robin, wrk -t1 -c64 (keep-alive), 2 server threads, $rounds alternating rounds of 4 s:"
python3 - "$work/rounds-$map.txt" <<'PY'
import statistics, sys
rows = [list(map(float, l.split())) for l in open(sys.argv[1]) if len(l.split()) == 4]
if not rows:
    sys.exit("bench_server: wrk printed no figures in any round (see wrk's own output by running it by hand)")
med = lambda k: statistics.median(r[k] for r in rows)
ratios = [r[0] / r[2] for r in rows]
print("  pl-server  %8.0f requests/s  p99 %5.2f ms  (median; rounds: %s)" % (med(0), med(1), ", ".join("%.0f" % r[0] for r in rows)))
print("  nginx      %8.0f requests/s  p99 %5.2f ms  (static files of the same bytes; rounds: %s)" % (med(2), med(3), ", ".join("%.0f" % r[2] for r in rows)))
print("  pl-server / nginx: median %.2fx (rounds: %s); target >= 0.8x, p99 <= 5 ms" % (statistics.median(ratios), ", ".join("%.2f" % x for x in ratios)))
PY
done
python3 - "$work/roi_rounds.txt" <<'PY'
import statistics, sys
rows = [list(map(float, l.split())) for l in open(sys.argv[1]) if len(l.split()) == 4]
if not rows:
    sys.exit("bench_server: wrk printed no ROI figures")
med = lambda k: statistics.median(r[k] for r in rows)
print("ROI queries (60 m radius, 36 places on the loop, no have=), 3 alternating rounds of 4 s, medians:")
print("  2 server threads  %8.0f requests/s  p99 %5.2f ms" % (med(0), med(1)))
print("  1 server thread   %8.0f requests/s  p99 %5.2f ms  (one origin core; target >= 20,000)" % (med(2), med(3)))
PY
