#!/usr/bin/env bash
# A fleet on one machine: a map of >= 25 km2 in PostgreSQL, two pl-server replicas on it, a cache
# tier in front (Varnish, then nginx, each from deploy/), and pl-fleet's virtual vehicles driving
# over it. Prints, with the commands that made them:
#   - the large map: made (bench_bigmap), imported into PostgreSQL (pl-map migrate: time), store
#     size, ROI answers straight from one replica (wrk: req/s, p99);
#   - per tier: stalls, origin share of the tile requests, tile and ROI latency (pl-fleet --json);
#   - through Varnish: one replica killed mid-run; PostgreSQL restarted mid-run while an upload is
#     tried (it must fail with a clear error, then succeed when tried again), and the store checked
#     whole afterwards.
#   bash bench/fleet.sh BIN_DIR WORK_DIR [VEHICLES=2000] [SECONDS=60] [TIERS="varnish nginx"] [FAULTS=on]
# (FAULTS=only: the fault and tamper runs alone; FAULTS=tamper: the tamper run alone; FAULT_SIGNED=on:
# the fault runs on signed maps.)
# WORK_DIR keeps the maps between runs (the large one takes minutes to make); the PostgreSQL
# database is made afresh each run so that the import is timed. Needs varnish, nginx-light, wrk,
# postgresql (deploy/test-packages.txt, which ./pl bench installs).
set -uo pipefail
BIN=$(cd "${1:?usage: fleet.sh BIN_DIR WORK_DIR [VEHICLES] [SECONDS] [TIERS] [FAULTS]}" && pwd)
WORK=${2:?usage: fleet.sh BIN_DIR WORK_DIR [VEHICLES] [SECONDS] [TIERS] [FAULTS]}
VEHICLES=${3:-2000}
SECONDS_RUN=${4:-60}
TIERS=${5:-varnish nginx}
FAULTS=${6:-on}
SRC=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
mkdir -p "$WORK"
WORK=$(cd "$WORK" && pwd)
PGBIN=${PL_PG_BINDIR:-/usr/lib/postgresql/15/bin}
PYTHON=/usr/bin/python3
for tool in "$BIN/pl-server" "$BIN/pl-map" "$BIN/pl-fleet" "$BIN/bench_bigmap" "$PGBIN/initdb" /usr/sbin/varnishd /usr/sbin/nginx; do
  [ -x "$tool" ] || { echo "fleet: $tool is missing (build it, or apt-get install postgresql varnish nginx-light)"; exit 0; }
done
command -v wrk >/dev/null || { echo "fleet: wrk is missing (apt-get install wrk)"; exit 0; }
ulimit -n 65536 2>/dev/null || ulimit -n "$(ulimit -Hn)"

PIDS=()
cleanup() {
  local p
  for p in "${PIDS[@]}"; do kill "$p" 2>/dev/null; done
  for p in "${PIDS[@]}"; do wait "$p" 2>/dev/null; done
  [ -n "${PGDATA_DIR:-}" ] && as_pg "$PGBIN/pg_ctl" -D "$PGDATA_DIR" -m fast -w stop >/dev/null 2>&1
  true
}
trap cleanup EXIT
trap 'exit 130' INT TERM
ROOT=0
[ "$(id -u)" = 0 ] && ROOT=1
as_pg() { if [ $ROOT = 1 ]; then runuser -u postgres -- "$@"; else "$@"; fi; }
free_port() { $PYTHON -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }
say() { echo "fleet: $*"; }
wait_url() {  # URL: until it answers 200 (15 s at most)
  local i
  for i in $(seq 150); do
    [ "$(curl -s -o /dev/null -w '%{http_code}' "$1")" = 200 ] && return 0
    sleep 0.1
  done
  return 1
}

# ---------------------------------------------------------------------------------------------
# The maps: the town loop, then >= 25 km2 of it side by side (SQLite), kept in WORK_DIR.
bash "$SRC/bench/town_map.sh" "$BIN" "$WORK"
# Signed with the fleet's key, as pl-map publish --signing-key signs.
[ -f "$WORK/fleet.key" ] || "$BIN/pl-map" key-gen --out "$WORK/fleet" >/dev/null || exit 1
# The replicas' timestamp key: they sign the current version fresh at each request (GET .../current).
[ -f "$WORK/timestamp.key" ] || "$BIN/pl-map" key-gen --out "$WORK/timestamp" >/dev/null || exit 1
if [ ! -f "$WORK/big.sqlite" ]; then
  say "making the large map (once; minutes): $BIN/bench_bigmap --from maps.sqlite --map town --to big.sqlite --name big --km2 25 --signing-key fleet.key"
  rm -f "$WORK/big.sqlite.partial"*
  "$BIN/bench_bigmap" --from "$WORK/maps.sqlite" --map town --to "$WORK/big.sqlite.partial" --name big --km2 25 \
    --signing-key "$WORK/fleet.key" || exit 1
  mv "$WORK/big.sqlite.partial" "$WORK/big.sqlite"
fi

# A small map to upload while PostgreSQL restarts (a 60 m x 40 m ground grid with posts).
if [ ! -f "$WORK/upload.sqlite" ]; then
  $PYTHON - "$WORK/upload.pcd" <<'EOF'
import math, sys
pts = [(ix * 0.5, iy * 0.5, 0.02 * math.sin(ix * 0.5)) for iy in range(81) for ix in range(121)]
for px, py in [(10, 10), (25, 12), (45, 8)]:
    pts += [(px + 0.3 * math.cos(a * math.pi / 6), py + 0.3 * math.sin(a * math.pi / 6), iz * 0.25) for iz in range(12) for a in range(12)]
with open(sys.argv[1], "w") as f:
    f.write("# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n")
    f.write("WIDTH %d\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS %d\nDATA ascii\n" % (len(pts), len(pts)))
    f.writelines("%.3f %.3f %.3f\n" % p for p in pts)
EOF
  "$BIN/pl-map" tile --cloud "$WORK/upload.pcd" --db "$WORK/upload.sqlite" --map yard --origin 49.0,8.4,100 >/dev/null || exit 1
fi

# ---------------------------------------------------------------------------------------------
# PostgreSQL: a cluster of its own in WORK_DIR (as the postgres user when run as root), the
# database made afresh, the large map imported with pl-map migrate.
PGDIR=$WORK/pg
PGDATA_DIR=
if [ ! -f "$PGDIR/data/PG_VERSION" ]; then
  rm -rf "$PGDIR"
  mkdir -p "$PGDIR"
  [ $ROOT = 1 ] && chown postgres "$PGDIR" && chmod 711 "$WORK"
  as_pg "$PGBIN/initdb" -D "$PGDIR/data" -U postgres -A trust -E UTF8 --locale=C --no-instructions >"$WORK/initdb.log" 2>&1 ||
    { say "initdb failed: $(cat "$WORK/initdb.log")"; exit 1; }
fi
PGPORT=$(free_port)
PGDATA_DIR=$PGDIR/data
pg_start() {
  as_pg "$PGBIN/pg_ctl" -D "$PGDATA_DIR" -l "$PGDIR/server.log" -w -t 60 \
    -o "-p $PGPORT -k $PGDIR -c listen_addresses=127.0.0.1 -c max_connections=300" start >/dev/null
}
pg_start || { say "PostgreSQL did not start: $(tail -5 "$PGDIR/server.log")"; exit 1; }
psql_do() { psql -h 127.0.0.1 -p "$PGPORT" -U postgres -d postgres -Atqc "$1"; }
DB=postgresql://postgres@127.0.0.1:$PGPORT/maps
# PL_FLEET_REIMPORT=off keeps the database of the last run (while working on this script).
if [ "${PL_FLEET_REIMPORT:-on}" = off ] && [ "$(psql_do "SELECT count(*) FROM pg_database WHERE datname = 'maps'")" = 1 ]; then
  say "import: kept from the last run (PL_FLEET_REIMPORT=off)"
else
  psql_do "DROP DATABASE IF EXISTS maps" && psql_do "CREATE DATABASE maps" || exit 1
  t0=$(date +%s.%N)
  "$BIN/pl-map" migrate --from "$WORK/big.sqlite" --to "$DB" >"$WORK/migrate.log" 2>&1 || { say "migrate failed: $(cat "$WORK/migrate.log")"; exit 1; }
  t1=$(date +%s.%N)
  say "import: pl-map migrate --from big.sqlite --to postgresql://...: $(head -1 "$WORK/migrate.log" | sed 's/^copied [^:]*: //')"
  $PYTHON -c "import sys; print('fleet: import time %.1f s' % (float(sys.argv[2]) - float(sys.argv[1])))" "$t0" "$t1"
fi
bytes=$(psql_do "SELECT pg_database_size('maps')")
$PYTHON -c "import sys; print('fleet: store size (pg_database_size) %.1f MB' % (int(sys.argv[1]) / 1e6))" "$bytes"
"$BIN/pl-map" info --db "$DB" --map big | sed -n 's/^tiles */fleet: map big: /p'

# Tokens: an admin token for the upload of the fault run.
ADMIN_TOKEN=fleet-bench-admin-token-0123456789abcdef
printf 'admin %s\n' "$ADMIN_TOKEN" >"$WORK/tokens.txt"

# ---------------------------------------------------------------------------------------------
# Two replicas on the database, two threads each (the machine has two cores, which the cache, the
# database and the vehicles share; a second thread keeps a replica's /readyz answering the cache's
# probe while the other serves).
declare -A RPID RPORT
start_replica() {  # N
  RPORT[$1]=${RPORT[$1]:-$(free_port)}
  "$BIN/pl-server" --db "$DB" --listen "127.0.0.1:${RPORT[$1]}" --threads 2 --quiet --tokens "$WORK/tokens.txt" \
    --timestamp-key "$WORK/timestamp.key" >"$WORK/replica$1.log" 2>&1 &
  RPID[$1]=$!
  PIDS+=($!)
  wait_url "http://127.0.0.1:${RPORT[$1]}/readyz" || { say "replica $1 did not come up: $(cat "$WORK/replica$1.log")"; exit 1; }
}
start_replica 1
start_replica 2
METRICS=(--origin-metrics "http://127.0.0.1:${RPORT[1]}/metrics" --origin-metrics "http://127.0.0.1:${RPORT[2]}/metrics")

# ROI answers straight from replica 1: 60 m discs at 400 tiles of the map, no have= (a vehicle's
# first query, the largest answer), wrk with 64 connections for 10 s.
curl -s "http://127.0.0.1:${RPORT[1]}/v1/maps/big/versions/1/tiles" | $PYTHON -c '
import json, random, sys
tiles = json.load(sys.stdin)["tiles"]
random.seed(5)
pick = random.sample(tiles, 400)
with open(sys.argv[1], "w") as f:
    f.write("paths = {\n" + "".join("  \"/v1/maps/big/roi?x=%.1f&y=%.1f&radius=60\",\n" % (t["tx"] * 20 + 10, t["ty"] * 20 + 10) for t in pick) + "}\n")
    f.write("i = 0\nrequest = function()\n  i = i % #paths + 1\n  return wrk.format(\"GET\", paths[i])\nend\n")
' "$WORK/roi.lua"
wrk_out=$(wrk -t1 -c64 -d10s --latency -s "$WORK/roi.lua" "http://127.0.0.1:${RPORT[1]}")
say "ROI straight from one replica on PostgreSQL (wrk -t1 -c64 -d10s, 400 places, 60 m, no have=): $(sed -n 's/^Requests\/sec: *//p' <<<"$wrk_out") req/s, p50 $(awk '/ 50%/ {print $2}' <<<"$wrk_out"), p99 $(awk '/ 99%/ {print $2}' <<<"$wrk_out")"

# ---------------------------------------------------------------------------------------------
# The cache tiers, each in front of both replicas.
CACHE=
start_varnish() {
  local port jail=()
  port=$(free_port)
  mkdir -p "$WORK/varnish"
  sed -e "s/@ORIGIN_HOST@/127.0.0.1/" -e "s/@ORIGIN_PORT@/${RPORT[1]}/" \
    -e '/^# backend pl2 {/,/^# }/s/^# \{0,1\}//' -e 's/^  # origin.add_backend(pl2);/  origin.add_backend(pl2);/' \
    -e 's/10\.0\.0\.12/127.0.0.1/' -e "s/\"8080\"/\"${RPORT[2]}\"/" "$SRC/deploy/varnish/pointlocalization.vcl" >"$WORK/varnish/pl.vcl"
  grep -q 'origin.add_backend(pl2);' "$WORK/varnish/pl.vcl" || { say "could not add the second replica to the VCL"; exit 1; }
  local jail=()
  [ $ROOT = 1 ] || jail=(-j none)
  rm -rf "$WORK/varnish/n"
  /usr/sbin/varnishd -F "${jail[@]}" -n "$WORK/varnish/n" -a "127.0.0.1:$port" -f "$WORK/varnish/pl.vcl" -s malloc,3g -T none \
    -p thread_pool_max=5000 >"$WORK/varnish/varnishd.log" 2>&1 &
  CACHE_PID=$!
  PIDS+=($!)
  CACHE=http://127.0.0.1:$port
  wait_url "$CACHE/healthz" || { say "varnishd did not come up: $(cat "$WORK/varnish/varnishd.log")"; exit 1; }
}
start_nginx() {
  local port
  port=$(free_port)
  rm -rf "$WORK/nginx"
  "$SRC/deploy/nginx/local-cache.sh" "$WORK/nginx" "127.0.0.1:$port" \
    "server 127.0.0.1:${RPORT[1]}; server 127.0.0.1:${RPORT[2]};" 16384 65536
  /usr/sbin/nginx -p "$WORK/nginx" -c "$WORK/nginx/nginx.conf" -e "$WORK/nginx/error.log" >"$WORK/nginx/stdout.log" 2>&1 &
  CACHE_PID=$!
  PIDS+=($!)
  CACHE=http://127.0.0.1:$port
  wait_url "$CACHE/healthz" || { say "nginx did not come up: $(cat "$WORK/nginx/error.log")"; exit 1; }
}
stop_cache() {
  kill "$CACHE_PID" 2>/dev/null
  wait "$CACHE_PID" 2>/dev/null
}

# A fleet's cache in steady state holds the map's tiles: every tile of the map asked for once
# through it (wrk, 16 connections, each blob URL in turn) before a measured run.
curl -s "http://127.0.0.1:${RPORT[1]}/v1/maps/big/versions/1/tiles" | $PYTHON -c '
import json, sys
tiles = json.load(sys.stdin)["tiles"]
with open(sys.argv[1], "w") as f:
    f.write("paths = {\n" + "".join("  \"/v1/blobs/%s\",\n" % t["hash"] for t in tiles) + "}\n")
    f.write("i = 0\nrequest = function()\n  i = i % #paths + 1\n  return wrk.format(\"GET\", paths[i])\nend\n")
' "$WORK/all-blobs.lua"
TILE_COUNT=$(grep -c '/v1/blobs/' "$WORK/all-blobs.lua")
origin_blobs() {  # blob answers (200) both replicas have given so far
  curl -s "http://127.0.0.1:${RPORT[1]}/metrics" "http://127.0.0.1:${RPORT[2]}/metrics" |
    awk '/^pl_requests_total\{route="\/v1\/blobs\/\{hash\}",status="200"\}/ {s += $2} END {print s + 0}'
}
warm_cache() {  # TIER: until the origin has answered each blob once more
  local t0 t1 until wrk_pid
  until=$(( $(origin_blobs) + TILE_COUNT ))
  t0=$(date +%s.%N)
  wrk -t1 -c16 -d900s -s "$WORK/all-blobs.lua" "$CACHE" >/dev/null 2>&1 &
  wrk_pid=$!
  while [ "$(origin_blobs)" -lt "$until" ] && kill -0 $wrk_pid 2>/dev/null; do sleep 1; done
  kill $wrk_pid 2>/dev/null
  wait $wrk_pid 2>/dev/null
  t1=$(date +%s.%N)
  $PYTHON -c "import sys; print('fleet: [%s] cache warmed: the %s tiles of the map asked for through it in %.0f s' % (sys.argv[1], sys.argv[2], float(sys.argv[4]) - float(sys.argv[3])))" "$1" "$TILE_COUNT" "$t0" "$t1"
}

# One pl-fleet run: NAME, then extra arguments. Prints the figures the issue asks for.
fleet_run() {
  local name=$1
  shift
  "$BIN/pl-fleet" --server "$CACHE" --map big --vehicles "$VEHICLES" --duration "$SECONDS_RUN" --ramp 5 "${METRICS[@]}" \
    --json "$WORK/fleet-$name.json" "$@" >"$WORK/fleet-$name.txt" 2>"$WORK/fleet-$name.err"
  local rc=$?
  $PYTHON - "$WORK/fleet-$name.json" "$name" "$rc" <<'EOF'
import json, sys
path, name, rc = sys.argv[1], sys.argv[2], int(sys.argv[3])
try:
    r = json.load(open(path))
except Exception as e:
    sys.exit("fleet: [%s] pl-fleet wrote no figures (exit %d): %s" % (name, rc, e))
t, o = r["totals"] if "totals" in r else r, r["origin"]
def g(k):
    return t.get(k, r.get(k))
print("fleet: [%s] %d vehicles, %.0f s: %d driving, stalled scans %d of %d (vehicles stalled %d), missing tiles %d" %
      (name, r["vehicles"], r["duration_s"], g("vehicles_driving"), g("stalled_scans"), g("scans"), g("vehicles_stalled"), g("missing_tiles")))
tl, rl = r["tile_latency"], r["roi_latency"]
print("fleet: [%s] tile requests %d, origin tiles %d = %.2f %% (ROI %d, origin %d = %.1f %%); cache hit ratio tiles %.3f, ROI %.3f" %
      (name, g("tile_requests"), o["tiles"], 100 * o["tile_share"], g("roi_queries"), o["roi"], 100 * o["roi_share"],
       r["cache"]["tiles"]["hit_ratio"], r["cache"]["roi"]["hit_ratio"]))
print("fleet: [%s] tile latency p50 %.1f / p99 %.1f / max %.1f ms; ROI p50 %.1f / p99 %.1f ms; failures %d %s; rejected %d; %.1f MB; pl-fleet CPU %.0f s" %
      (name, tl["p50_ms"], tl["p99_ms"], tl["max_ms"], rl["p50_ms"], rl["p99_ms"], g("failures"), json.dumps(r.get("failure_kinds", {})),
       g("rejected"), g("bytes") / 1e6, r.get("fleet_cpu_s", 0)))
EOF
}

{ [ "$FAULTS" = only ] || [ "$FAULTS" = tamper ]; } && TIERS=""
for tier in $TIERS; do
  case $tier in
    varnish) start_varnish ;;
    nginx) start_nginx ;;
    *) say "unknown tier $tier (varnish or nginx)"; exit 2 ;;
  esac
  warm_cache "$tier"
  say "[$tier] $BIN/pl-fleet --server $CACHE --map big --vehicles $VEHICLES --duration $SECONDS_RUN --ramp 5 --origin-metrics (both replicas)"
  fleet_run "$tier"
  stop_cache
done

[ "$FAULTS" = on ] || [ "$FAULTS" = only ] || [ "$FAULTS" = tamper ] || exit 0

# The fault runs' vehicles: as above, or with FAULT_SIGNED=on on signed maps (--fleet-keys: the
# version's signed manifest names every tile, so no ROI query is made and every read can come from
# the cache).
FAULT_ARGS=()
[ "${FAULT_SIGNED:-off}" = on ] && FAULT_ARGS=(--fleet-keys "$WORK/fleet.pub")

# ---------------------------------------------------------------------------------------------
# Faults, through Varnish (a cache filled afresh, then warmed as above).
if [ "$FAULTS" != tamper ]; then
start_varnish
warm_cache "kill a replica"
# One replica killed a third of the way through (and not brought back during the run).
( sleep "$(( SECONDS_RUN / 3 ))"; kill -9 "${RPID[2]}" 2>/dev/null; echo "killed replica 2 at $(date +%T)" >"$WORK/kill.log" ) &
say "[kill a replica] the same run; replica 2 killed (SIGKILL) at a third of it"
fleet_run kill-replica "${FAULT_ARGS[@]}"
wait "${RPID[2]}" 2>/dev/null
start_replica 2
stop_cache

# PostgreSQL restarted a third of the way through; an upload tried while it is down, then again.
start_varnish
warm_cache "restart PostgreSQL"
(
  sleep "$(( SECONDS_RUN / 3 ))"
  as_pg "$PGBIN/pg_ctl" -D "$PGDATA_DIR" -m fast -w stop >/dev/null 2>&1
  echo "PostgreSQL stopped at $(date +%T)" >"$WORK/pg-restart.log"
  "$BIN/pl-map" push --db "$WORK/upload.sqlite" --map yard --version 1 --server "$CACHE" --token "$ADMIN_TOKEN" \
    >"$WORK/push-down.log" 2>&1
  echo "push while down: exit $?" >>"$WORK/pg-restart.log"
  sleep 5
  pg_start
  echo "PostgreSQL started at $(date +%T)" >>"$WORK/pg-restart.log"
  sleep 2
  "$BIN/pl-map" push --db "$WORK/upload.sqlite" --map yard --version 1 --server "$CACHE" --token "$ADMIN_TOKEN" \
    >"$WORK/push-up.log" 2>&1
  echo "push again: exit $?" >>"$WORK/pg-restart.log"
) &
restarter=$!
say "[restart PostgreSQL] the same run; PostgreSQL stopped at a third of it for 5 s, an upload (pl-map push) tried meanwhile and again after"
fleet_run pg-restart "${FAULT_ARGS[@]}"
wait $restarter
sed 's/^/fleet: [restart PostgreSQL] /' "$WORK/pg-restart.log"
say "[restart PostgreSQL] the upload while down said: $(tail -1 "$WORK/push-down.log")"
say "[restart PostgreSQL] the upload again said: $(tail -1 "$WORK/push-up.log")"
"$BIN/pl-map" list --db "$DB" --map yard | sed 's/^/fleet: [restart PostgreSQL] store: /'
"$BIN/pl-map" check --db "$DB" 2>&1 | sed 's/^/fleet: [restart PostgreSQL] /'
stop_cache
fi

# A tampered tile and a tampered manifest injected at the cache: nginx keeps its cache in files, so
# after the objects are cached their bytes are altered there, in place (same length), as a
# poisoned cache would hold them. The vehicles check signatures (--fleet-keys) and take the current
# version from the replicas' signed statement (--timestamp-keys): they must refuse the altered
# manifest and tiles, never use them, and drive on (the client asks by another URL).
TAMPER_VEHICLES=${TAMPER_VEHICLES:-$VEHICLES}
start_nginx
warm_cache tamper
manifest_url=/v1/maps/big/versions/1/manifest
curl -s -o /dev/null "$CACHE$manifest_url"
curl -s "http://127.0.0.1:${RPORT[1]}/v1/maps/big/versions/1/tiles" | $PYTHON -c '
import json, random, sys
random.seed(11)
for t in random.sample(json.load(sys.stdin)["tiles"], 20):
    print("/v1/blobs/" + t["hash"])' >"$WORK/tampered-blobs.txt"
while read -r u; do curl -s -o /dev/null "$CACHE$u"; done <"$WORK/tampered-blobs.txt"
sleep 1
$PYTHON - "$WORK/nginx/cache" "$manifest_url" "$WORK/tampered-blobs.txt" <<'PYEOF'
import hashlib, os, sys
cache, manifest, blobs = sys.argv[1], sys.argv[2], open(sys.argv[3]).read().split()
def path(uri):  # proxy_cache_key $request_uri, levels=1:2
    h = hashlib.md5(uri.encode()).hexdigest()
    return os.path.join(cache, h[-1], h[-3:-1], h)
done = 0
for uri in [manifest] + blobs:
    p = path(uri)
    data = bytearray(open(p, "rb").read())
    if uri == manifest:
        i = len(data) // 2  # inside the body: change one hex digit of a tile's hash to another
        while chr(data[i]) not in "0123456789abcdef":
            i += 1
        data[i] = ord("1") if data[i] != ord("1") else ord("2")
    else:
        data[-1] ^= 0x5A  # the last byte of the tile's bytes
    with open(p, "r+b") as f:
        f.write(data)
    done += 1
print("fleet: [tamper] altered in nginx's cache files: the signed manifest and %d tiles" % (done - 1))
PYEOF
altered=$(curl -s "$CACHE$manifest_url" | sha256sum | cut -c1-64)
real=$(curl -s "http://127.0.0.1:${RPORT[1]}$manifest_url" | sha256sum | cut -c1-64)
[ "$altered" != "$real" ] && say "[tamper] the cache now serves an altered manifest (sha256 ${altered:0:12}… against the origin's ${real:0:12}…)" ||
  say "[tamper] FAILED to alter the cached manifest"
saved=$VEHICLES
VEHICLES=$TAMPER_VEHICLES
say "[tamper] $BIN/pl-fleet --server (nginx) --map big --vehicles $VEHICLES --fleet-keys fleet.pub --timestamp-keys timestamp.pub ..."
fleet_run tamper --fleet-keys "$WORK/fleet.pub" --timestamp-keys "$WORK/timestamp.pub"
VEHICLES=$saved
stop_cache
