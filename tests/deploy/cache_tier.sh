#!/usr/bin/env bash
# The cache tier in front of pl-server, as deployed: deploy/varnish/pointlocalization.vcl in a real
# varnishd and deploy/nginx/pointlocalization-cache.conf in a real nginx, each on loopback in front
# of a real pl-server serving a small map made here, and what a fleet relies on checked through it.
#   bash tests/deploy/cache_tier.sh BIN_DIR [varnish|nginx|both]
# BIN_DIR holds pl-server and pl-map. Prints "ok: ..." or "FAIL: ..." a check and a few figures;
# exit 0 when every check passed, 1 when one failed or varnishd or nginx is not installed (./pl test
# installs them), 2 on bad arguments or a setup that did not come up.
#
# The origin is reached through a small relay made here (python3), byte for byte, which can hold
# one URL's requests for a second (so that the concurrent requests of the coalescing check surely
# arrive while the first is still at the origin) and play an outage (503s, then refused
# connections). Origin requests are counted from pl-server's access log.
set -uo pipefail

usage() {
  echo "usage: bash $0 BIN_DIR [varnish|nginx|both]" >&2
  exit 2
}
[ $# -ge 1 ] && [ $# -le 2 ] || usage
BIN=$(cd "$1" 2>/dev/null && pwd) || { echo "cache_tier: no directory $1" >&2; exit 2; }
WHICH=${2:-both}
case $WHICH in varnish) TIERS=(varnish) ;; nginx) TIERS=(nginx) ;; both) TIERS=(varnish nginx) ;; *) usage ;; esac
SRC=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
VCL=$SRC/deploy/varnish/pointlocalization.vcl

for tool in "$BIN/pl-server" "$BIN/pl-map"; do
  [ -x "$tool" ] || { echo "cache_tier: $tool is missing: build it first" >&2; exit 2; }
done
PYTHON=/usr/bin/python3
[ -x $PYTHON ] || PYTHON=$(command -v python3) || { echo "cache_tier: python3 is missing: apt-get install python3" >&2; exit 2; }
for tool in curl wrk gzip; do
  command -v $tool >/dev/null || { echo "cache_tier: $tool is missing: apt-get install $tool" >&2; exit 2; }
done
VARNISHD=$(command -v varnishd || echo /usr/sbin/varnishd)
VARNISHSTAT=$(command -v varnishstat || echo /usr/bin/varnishstat)
NGINX=$(command -v nginx || echo /usr/sbin/nginx)
for tier in "${TIERS[@]}"; do
  if [ "$tier" = varnish ] && [ ! -x "$VARNISHD" ]; then
    echo "cache_tier: FAIL: varnishd is not installed: apt-get install varnish (Debian package varnish, 7.1 on Debian 12)"
    exit 1
  fi
  if [ "$tier" = nginx ]; then
    if [ ! -x "$NGINX" ]; then
      echo "cache_tier: FAIL: nginx is not installed: apt-get install nginx-light (Debian package nginx-light)"
      exit 1
    fi
    # Modules are in unless configure left them out; proxy (the cache) and gunzip are needed.
    if "$NGINX" -V 2>&1 | grep -q -e '--without-http_proxy_module' || ! "$NGINX" -V 2>&1 | grep -q -e '--with-http_gunzip_module'; then
      echo "cache_tier: FAIL: $NGINX lacks the proxy or gunzip module: apt-get install nginx-light (Debian package nginx-light)"
      exit 1
    fi
  fi
done

TMP=$(mktemp -d "${TMPDIR:-/tmp}/cache_tier.XXXXXX") || exit 2
PIDS=()
cleanup() {
  local p
  for p in "${PIDS[@]}"; do kill "$p" 2>/dev/null; done
  for p in "${PIDS[@]}"; do wait "$p" 2>/dev/null; done
  rm -rf "$TMP"
}
trap cleanup EXIT
trap 'exit 130' INT TERM
ROOT=0
[ "$(id -u)" = 0 ] && ROOT=1
# As root, varnishd's and nginx's workers run as their own users: they must get through to their
# folders in here.
[ $ROOT = 1 ] && chmod 711 "$TMP"

FAILS=0 PASSES=0 TIER=
ok() { PASSES=$((PASSES + 1)); echo "ok: [$TIER] $*"; }
fail() { FAILS=$((FAILS + 1)); echo "FAIL: [$TIER] $*"; }
check() {  # check CONDITION-STATUS MESSAGE [WHY-NOT]
  if [ "$1" = 0 ]; then ok "$2"; else fail "$2${3:+ -- $3}"; fi
}
die() {
  echo "cache_tier: $*" >&2
  exit 2
}
free_port() {
  $PYTHON -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}
now() { date +%s.%N; }
elapsed() { $PYTHON -c "import sys; print('%.2f' % (float(sys.argv[2]) - float(sys.argv[1])))" "$1" "$2"; }
le() { $PYTHON -c "import sys; sys.exit(0 if float(sys.argv[1]) <= float(sys.argv[2]) else 1)" "$1" "$2"; }

# ---------------------------------------------------------------------------------------------
# The map: a 60 m x 40 m ground grid at 0.5 m with a wall and posts (version 2 adds a post), places
# in pl-map's format, and the tokens pl-server is given.

$PYTHON - "$TMP" <<'EOF'
import math, random, struct, sys
d = sys.argv[1]
def cloud(path, extra_post):
    pts = [(ix * 0.5, iy * 0.5, 0.02 * math.sin(ix * 0.5) + 0.02 * math.cos(iy * 0.5))
           for iy in range(81) for ix in range(121)]
    pts += [(5 + ix * 0.5, 30.0, iz * 0.5) for iz in range(8) for ix in range(100)]
    posts = [(10, 10), (25, 12), (45, 8), (50, 25)] + ([(30, 20)] if extra_post else [])
    for px, py in posts:
        pts += [(px + 0.3 * math.cos(a * math.pi / 6), py + 0.3 * math.sin(a * math.pi / 6), iz * 0.25)
                for iz in range(12) for a in range(12)]
    with open(path, "w") as f:
        f.write("# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n")
        f.write("WIDTH %d\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS %d\nDATA ascii\n" % (len(pts), len(pts)))
        f.writelines("%.3f %.3f %.3f\n" % p for p in pts)
cloud(d + "/v1.pcd", False)
cloud(d + "/v2.pcd", True)
# "PLPL", format 1, rings, sectors, range, height offset, count; per place x y z yaw and a cell a byte
random.seed(1)
rings, sectors, count = 20, 60, 4
places = struct.pack("<4sIIIddI", b"PLPL", 1, rings, sectors, 80.0, 2.0, count)
for i in range(count):
    places += struct.pack("<dddd", 12.0 * i, 5.0, 0.0, 0.1 * i) + bytes(random.randrange(40) for _ in range(rings * sectors))
open(d + "/town.places", "wb").write(places)
EOF
[ -f "$TMP/town.places" ] || die "could not write the test map's cloud"
READ_TOKEN=cache-tier-read-token-0123456789
UPLOAD_TOKEN=cache-tier-upload-token-0123456789
printf 'read %s\nupload %s\n' "$READ_TOKEN" "$UPLOAD_TOKEN" >"$TMP/tokens.txt"
truncate -s 60M "$TMP/junk.bin"  # an upload near pl-server's 64 MiB limit, which it refuses as not Draco

# The relay between the cache and pl-server (see the top).
cat >"$TMP/relay.py" <<'EOF'
import asyncio, os, sys

origin_port, ctl, port_file = int(sys.argv[1]), sys.argv[2], sys.argv[3]
HOLD = 1.0
BODY = b'{"error":"the map store is unreachable just now (played by the test relay)","status":503}'
ANSWER_503 = (b"HTTP/1.1 503 Service Unavailable\r\nContent-Type: application/json\r\nRetry-After: 1\r\n"
              b"Content-Length: %d\r\nConnection: close\r\n\r\n" % len(BODY)) + BODY
conns = set()

def flag(name):
    return os.path.exists(os.path.join(ctl, name))

def held():
    try:
        with open(os.path.join(ctl, "hold"), "rb") as f:
            return f.read().strip()
    except OSError:
        return b""

def shut(w):
    try:
        w.close()
    except Exception:
        pass

async def to_client(ur, cw):
    try:
        while data := await ur.read(65536):
            cw.write(data)
            await cw.drain()
    except (ConnectionError, OSError):
        pass
    shut(cw)

async def serve(cr, cw):
    try:
        ur, uw = await asyncio.open_connection("127.0.0.1", origin_port)
    except OSError:
        shut(cw)
        return
    pair = (cw, uw)
    conns.add(pair)
    back = asyncio.ensure_future(to_client(ur, cw))
    try:
        while data := await cr.read(65536):
            if flag("503"):
                cw.write(ANSWER_503)
                await cw.drain()
                break
            hold = held()
            if hold and hold in data:
                await asyncio.sleep(HOLD)
            uw.write(data)
            await uw.drain()
    except (ConnectionError, OSError):
        pass
    conns.discard(pair)
    shut(uw)
    shut(cw)
    await asyncio.gather(back, return_exceptions=True)

async def main():
    server = await asyncio.start_server(serve, "127.0.0.1", 0, reuse_address=True)
    port = server.sockets[0].getsockname()[1]
    with open(port_file + ".new", "w") as f:
        f.write("%d\n" % port)
    os.rename(port_file + ".new", port_file)
    while True:  # "down": nothing listens (connections refused) and open ones are cut
        await asyncio.sleep(0.05)
        if flag("down") and server is not None:
            server.close()
            server = None
            for pair in list(conns):
                for w in pair:
                    shut(w)
        elif not flag("down") and server is None:
            server = await asyncio.start_server(serve, "127.0.0.1", port, reuse_address=True)

asyncio.run(main())
EOF

if "$BIN/pl-server" --help 2>&1 | grep -q -e '--fleet-key'; then
  BUILD="a build with --fleet-key (caching headers on map answers)"
else
  BUILD="a build without --fleet-key (older: no caching headers on map answers)"
fi
echo "cache_tier: $("$BIN/pl-server" --version 2>&1 | head -n 1), $BUILD"

# ---------------------------------------------------------------------------------------------
# Helpers over one tier's setup: $D its folder, $CACHE and $ORIGIN base URLs, $OLOG pl-server's log.

# get URL-PATH OUT [curl options...]: the answer's body in OUT, its headers in OUT.h; sets CODE and XC.
get() {
  local path=$1 out=$2
  shift 2
  local w
  w=$(curl -s -o "$out" -D "$out.h" -w '%{http_code} %header{x-cache}' "$@" "$CACHE$path")
  CODE=${w%% *}
  XC=${w#* }
}
# direct URL-PATH OUT: what the origin itself answers (no Accept-Encoding: the plain body).
direct() {
  curl -s -o "$2" -w '%{http_code}' "$ORIGIN$1"
}
mark() { wc -l <"$OLOG"; }
# origin_count MARK METHOD TARGET [STATUS]: requests pl-server logged since MARK.
origin_count() {
  sleep 0.2  # pl-server writes its line once the answer is out
  tail -n +$(($1 + 1)) "$OLOG" | grep -c -F "\"$2 $3\" ${4:-}"
}
origin_statuses() {  # origin_statuses MARK METHOD TARGET: the statuses logged, in order
  tail -n +$(($1 + 1)) "$OLOG" | grep -F "\"$2 $3\" " | awk '{print $(NF-2)}' | tr '\n' ' '
}
json_field() {  # json_field FILE KEY
  $PYTHON -c 'import json, sys; print(json.load(open(sys.argv[1])).get(sys.argv[2]))' "$1" "$2" 2>/dev/null
}
same() { cmp -s "$1" "$2"; }

start_origin() {
  "$BIN/pl-map" tile --cloud "$TMP/v1.pcd" --db "$D/maps.sqlite" --map town --origin 49.0,8.4,100 --places "$TMP/town.places" >"$D/pl-map.log" 2>&1 &&
    "$BIN/pl-map" publish --db "$D/maps.sqlite" --map town --version 1 >>"$D/pl-map.log" 2>&1 &&
    "$BIN/pl-map" tile --cloud "$TMP/v2.pcd" --db "$D/maps.sqlite" --map town --origin 49.0,8.4,100 --places "$TMP/town.places" >>"$D/pl-map.log" 2>&1 ||
    die "pl-map could not make the store: $(cat "$D/pl-map.log")"
  OLOG=$D/origin.log
  "$BIN/pl-server" --db "$D/maps.sqlite" --listen 127.0.0.1:0 --threads 4 --tokens "$TMP/tokens.txt" >"$OLOG" 2>"$D/origin.err" &
  PIDS+=($!)
  local i port=
  for i in $(seq 100); do
    port=$(sed -n 's|.*listening on http://127\.0\.0\.1:\([0-9]*\).*|\1|p' "$OLOG" | head -n 1)
    [ -n "$port" ] && break
    sleep 0.05
  done
  [ -n "$port" ] || die "pl-server did not start: $(cat "$D/origin.err")"
  ORIGIN=http://127.0.0.1:$port
  mkdir -p "$D/relay"
  $PYTHON "$TMP/relay.py" "$port" "$D/relay" "$D/relay.port" 2>"$D/relay.err" &
  PIDS+=($!)
  for i in $(seq 100); do
    [ -s "$D/relay.port" ] && break
    sleep 0.05
  done
  [ -s "$D/relay.port" ] || die "the relay did not start: $(cat "$D/relay.err")"
  RELAY_PORT=$(cat "$D/relay.port")
}

start_varnish() {
  local port
  port=$(free_port)
  sed -e "s/@ORIGIN_HOST@/127.0.0.1/" -e "s/@ORIGIN_PORT@/$RELAY_PORT/" "$VCL" >"$D/pointlocalization.vcl"
  # As root varnishd hands its compiler and its cache process to its own users (its jail); anyone
  # else runs it all as themselves.
  local jail=()
  [ $ROOT = 1 ] || jail=(-j none)
  "$VARNISHD" -F "${jail[@]}" -n "$D/varnish" -a "127.0.0.1:$port" -f "$D/pointlocalization.vcl" \
    -s malloc,256m -T none >"$D/varnishd.log" 2>&1 &
  PIDS+=($!)
  CACHE=http://127.0.0.1:$port
  STAT=("$VARNISHSTAT" -n "$D/varnish" -1)
}

start_nginx() {
  local port
  port=$(free_port)
  "$SRC/deploy/nginx/local-cache.sh" "$D/nginx" "127.0.0.1:$port" "server 127.0.0.1:$RELAY_PORT;" 1024
  "$NGINX" -t -q -p "$D/nginx" -c "$D/nginx/nginx.conf" -e "$D/nginx/error.log" 2>"$D/nginx/t.log" ||
    die "nginx refuses the configuration: $(cat "$D/nginx/t.log" "$D/nginx/error.log" 2>/dev/null)"
  "$NGINX" -p "$D/nginx" -c "$D/nginx/nginx.conf" -e "$D/nginx/error.log" >"$D/nginx/stdout.log" 2>&1 &
  PIDS+=($!)
  CACHE=http://127.0.0.1:$port
}

wait_cache() {
  local i
  for i in $(seq 150); do
    [ "$(curl -s -o /dev/null -w '%{http_code}' "$CACHE/healthz")" = 200 ] && return 0
    sleep 0.1
  done
  return 1
}

# ---------------------------------------------------------------------------------------------
# The checks, one tier.

run_tier() {
  TIER=$1
  D=$TMP/$TIER
  mkdir -p "$D/b"
  [ $ROOT = 1 ] && chmod 711 "$D"
  local B=$D/b  # bodies
  # How long a one-second answer may stay fresh, and so how long to wait before it must have been
  # revalidated. nginx counts lifetimes in whole seconds, so its max-age=1 lasts until the end of the
  # next second: up to 2 s.
  case $TIER in
    varnish) EXPIRE=1.2 ;;
    nginx) EXPIRE=2.2 ;;
  esac
  start_origin
  case $TIER in
    varnish) start_varnish ;;
    nginx) start_nginx ;;
  esac
  if ! wait_cache; then
    fail "the cache did not come up in front of pl-server"
    cat "$D/varnishd.log" "$D/nginx/error.log" 2>/dev/null | tail -n 20
    return
  fi
  echo "cache_tier: [$TIER] cache $CACHE -> relay 127.0.0.1:$RELAY_PORT -> pl-server $ORIGIN"

  # The map's tiles (key and content hash), from the origin. Objects used once each below, so
  # that every check starts from an object nobody asked the cache for yet.
  direct /v1/maps/town/versions/1/tiles "$B/tiles.json" >/dev/null
  mapfile -t TILES < <($PYTHON -c '
import json, sys
seen = set()
for t in json.load(open(sys.argv[1]))["tiles"]:
    if t["hash"] not in seen:
        seen.add(t["hash"])
        print(t["tx"], t["ty"], t["hash"])' "$B/tiles.json")
  if [ ${#TILES[@]} -lt 6 ]; then
    fail "the test map has ${#TILES[@]} distinct tiles, 6 needed"
    return
  fi
  local t1 t2 h_blob h_collapse h_auth h_wrk tile_key
  read -r _ _ h_blob <<<"${TILES[0]}"
  read -r t1 t2 _ <<<"${TILES[1]}"
  tile_key=/v1/maps/town/versions/1/tiles/$t1/$t2
  read -r _ _ h_collapse <<<"${TILES[2]}"
  read -r _ _ h_auth <<<"${TILES[3]}"
  read -r _ _ h_wrk <<<"${TILES[4]}"
  local put_tx put_ty put_hash
  read -r put_tx put_ty put_hash <<<"${TILES[5]}"

  # 1. Immutable objects: one origin request, and none when asked again after their neighbours'
  #    one-second lifetime has long passed (never revalidated).
  local names=(blob tile places manifest)
  local paths=("/v1/blobs/$h_blob" "$tile_key" /v1/maps/town/versions/1/places /v1/maps/town/versions/1/manifest)
  local i m codes
  for i in 0 1 2 3; do
    direct "${paths[$i]}" "$B/imm$i.want" >"$B/imm$i.dcode"
  done
  m=$(mark)
  for i in 0 1 2 3; do
    get "${paths[$i]}" "$B/imm$i.1"
    echo "$CODE" >"$B/imm$i.codes"
    get "${paths[$i]}" "$B/imm$i.2"
    echo "$CODE" >>"$B/imm$i.codes"
  done
  sleep 2.5
  for i in 0 1 2 3; do
    get "${paths[$i]}" "$B/imm$i.3"
    echo "$CODE" >>"$B/imm$i.codes"
  done
  for i in 0 1 2 3; do
    local dcode n
    dcode=$(cat "$B/imm$i.dcode")
    codes=$(tr '\n' ' ' <"$B/imm$i.codes")
    n=$(origin_count "$m" GET "${paths[$i]}")
    if [ "$dcode" != 200 ]; then
      fail "immutable ${names[$i]} (${paths[$i]}): the origin itself answers $dcode, so there is nothing to cache (this pl-server lacks the route?)"
    elif [ "$codes" = "200 200 200 " ] && same "$B/imm$i.1" "$B/imm$i.want" && same "$B/imm$i.3" "$B/imm$i.want" && [ "$n" = 1 ]; then
      ok "immutable ${names[$i]}: 3 GETs over 2.5 s, origin requests: 1 (never revalidated)"
    else
      fail "immutable ${names[$i]} (${paths[$i]}): client statuses $codes, origin requests $n (want 200 200 200, 1, the origin's bytes)"
    fi
  done

  # 2. Map answers: kept one second, then revalidated (If-None-Match -> 304), the client getting the
  #    whole body each time.
  local jnames=(manifest roi)
  local jpaths=(/v1/maps/town "/v1/maps/town/roi?x=10&y=10&radius=30")
  local etag
  for i in 0 1; do
    curl -s -o "$B/json$i.want" -D "$B/json$i.want.h" "$ORIGIN${jpaths[$i]}"
  done
  etag=$(grep -i '^etag:' "$B/json0.want.h" | tr -d '\r' | cut -d' ' -f2)
  m=$(mark)
  local t0 t_second
  t0=$(now)
  for i in 0 1; do get "${jpaths[$i]}" "$B/json$i.1"; echo "$CODE" >"$B/json$i.codes"; done
  for i in 0 1; do get "${jpaths[$i]}" "$B/json$i.2"; echo "$CODE" >>"$B/json$i.codes"; done
  t_second=$(elapsed "$t0" "$(now)")
  local n1=() 
  for i in 0 1; do n1[$i]=$(origin_count "$m" GET "${jpaths[$i]}"); done
  sleep "$EXPIRE"
  for i in 0 1; do get "${jpaths[$i]}" "$B/json$i.3"; echo "$CODE" >>"$B/json$i.codes"; done
  for i in 0 1; do
    local n2 st
    n2=$(origin_count "$m" GET "${jpaths[$i]}")
    st=$(origin_statuses "$m" GET "${jpaths[$i]}")
    codes=$(tr '\n' ' ' <"$B/json$i.codes")
    if [ "${n1[$i]}" = 1 ] && same "$B/json$i.2" "$B/json$i.want"; then
      ok "${jnames[$i]}: second GET ${t_second}s after the first answered from the cache (origin requests: 1)"
    else
      fail "${jnames[$i]}: second GET within ${t_second}s made ${n1[$i]} origin requests in all (want 1)"
    fi
    if [ "$n2" = 2 ] && [ "$st" = "200 304 " ] && [ "$codes" = "200 200 200 " ] && same "$B/json$i.3" "$B/json$i.want"; then
      ok "${jnames[$i]}: after $EXPIRE s revalidated (origin: 200 then 304), client got 200 and the whole body"
    elif [ -z "$etag" ]; then
      fail "${jnames[$i]}: after $EXPIRE s: origin statuses $st-- want 200 304: this pl-server sends no ETag on map answers, so a cache can only fetch them again"
    else
      fail "${jnames[$i]}: after $EXPIRE s: origin statuses $st(want 200 304), client statuses $codes(want 200s), body $(same "$B/json$i.3" "$B/json$i.want" && echo same || echo differs)"
    fi
  done

  # 3. Coalescing: 100 clients at once for a blob not cached yet, while the origin takes a second
  #    to answer the first: one origin request.
  local before_sleep=
  [ "$TIER" = varnish ] && before_sleep=$("${STAT[@]}" -f MAIN.busy_sleep 2>/dev/null | awk '{print $2}')
  printf 'GET /v1/blobs/%s ' "$h_collapse" >"$D/relay/hold"
  direct "/v1/blobs/$h_collapse" "$B/collapse.want" >/dev/null
  m=$(mark)
  seq 100 | xargs -P 100 -I{} curl -s -o /dev/null -w '%{http_code} %{size_download} %header{x-cache}\n' \
    "$CACHE/v1/blobs/$h_collapse" >"$B/collapse.out"
  rm -f "$D/relay/hold"
  local n want_size good tally waited=
  n=$(origin_count "$m" GET "/v1/blobs/$h_collapse")
  want_size=$(stat -c %s "$B/collapse.want")
  good=$(grep -c "^200 $want_size " "$B/collapse.out")
  tally=$(awk '{print $3}' "$B/collapse.out" | sort | uniq -c | awk '{printf "%s%s x%s", (NR > 1 ? ", " : ""), ($2 == "" ? "-" : $2), $1}')
  if [ "$TIER" = varnish ] && [ -n "$before_sleep" ]; then
    waited=", $(($("${STAT[@]}" -f MAIN.busy_sleep | awk '{print $2}') - before_sleep)) waited on the fetch in flight"
  fi
  check $([ "$good" = 100 ] && [ "$n" = 1 ] && echo 0 || echo 1) \
    "coalescing: 100 concurrent GETs of an uncached blob -> $good x 200 with its bytes, origin requests: $n (X-Cache: $tally$waited)" \
    "want 100 x 200 and exactly 1 origin request"

  # 4. Authorization: never answered from the cache nor stored in it.
  direct "/v1/blobs/$h_auth" "$B/auth.want" >/dev/null
  m=$(mark)
  codes=
  for i in 1 2 3; do
    get "/v1/blobs/$h_auth" "$B/auth.$i" -H "Authorization: Bearer $READ_TOKEN"
    codes+="$CODE "
    same "$B/auth.$i" "$B/auth.want" || codes+="(other bytes) "
  done
  n=$(origin_count "$m" GET "/v1/blobs/$h_auth")
  check $([ "$codes" = "200 200 200 " ] && [ "$n" = 3 ] && echo 0 || echo 1) \
    "authorization: 3 GETs with a bearer token -> ${codes% }, origin requests: $n" "want 200 200 200 and 3"
  get "/v1/blobs/$h_auth" "$B/auth.4"
  codes="$CODE "
  get "/v1/blobs/$h_auth" "$B/auth.5"
  codes+="$CODE"
  n=$(origin_count "$m" GET "/v1/blobs/$h_auth")
  check $([ "$codes" = "200 200" ] && [ "$n" = 4 ] && same "$B/auth.5" "$B/auth.want" && echo 0 || echo 1) \
    "authorization: nothing stored: then 2 GETs without a token -> $codes, origin requests: $((n - 3)) more" "want 1: the first one fetches, the second is a hit"

  # 4b. Writes pass through, bodies included: open a staged version, put and delete a tile, send an
  #     upload of 60 MiB (refused by pl-server as not Draco, not by the cache as too large).
  m=$(mark)
  local wcodes v
  curl -s -o "$B/open.json" -w '%{http_code} ' -X POST -H "Authorization: Bearer $UPLOAD_TOKEN" \
    -H 'Content-Type: application/json' --data '{"note":"through the cache"}' "$CACHE/v1/maps/town/versions" >"$B/w.codes"
  v=$(json_field "$B/open.json" version)
  direct "/v1/blobs/$put_hash" "$B/put.bytes" >/dev/null
  curl -s -o /dev/null -w '%{http_code} ' -X PUT -H "Authorization: Bearer $UPLOAD_TOKEN" \
    -H 'Content-Type: application/vnd.google.draco' --data-binary "@$B/put.bytes" \
    "$CACHE/v1/maps/town/versions/$v/tiles/$put_tx/$put_ty" >>"$B/w.codes"
  curl -s -o /dev/null -w '%{http_code} ' -X PUT -H "Authorization: Bearer $UPLOAD_TOKEN" \
    -H 'Content-Type: application/vnd.google.draco' --data-binary "@$TMP/junk.bin" \
    "$CACHE/v1/maps/town/versions/$v/tiles/0/0" >>"$B/w.codes"
  curl -s -o /dev/null -w '%{http_code}' -X DELETE -H "Authorization: Bearer $UPLOAD_TOKEN" \
    "$CACHE/v1/maps/town/versions/$v/tiles/$put_tx/$put_ty" >>"$B/w.codes"
  wcodes=$(cat "$B/w.codes")
  local nw
  nw=$(($(origin_count "$m" POST /v1/maps/town/versions) + $(origin_count "$m" PUT "/v1/maps/town/versions/$v/tiles/$put_tx/$put_ty") +
    $(origin_count "$m" PUT "/v1/maps/town/versions/$v/tiles/0/0") + $(origin_count "$m" DELETE "/v1/maps/town/versions/$v/tiles/$put_tx/$put_ty")))
  check $([ "$wcodes" = "201 200 422 200" ] && [ "$nw" = 4 ] && echo 0 || echo 1) \
    "writes pass: POST version, PUT tile, PUT 60 MiB, DELETE tile -> $wcodes, origin requests: $nw" "want 201 200 422 200 and 4"

  # 5. Freshness: a publish on the store shows through the cache. What bounds how stale the cache may
  #    be is the lifetime the map answer carries through it (max-age=1), checked here; the wait for
  #    version 2 is a hang guard, not a time bound, and the seconds it took are printed.
  get /v1/maps/town "$B/fresh.0"
  local was lifetime
  was=$(json_field "$B/fresh.0" current_version)
  lifetime=$(grep -i '^cache-control:' "$B/fresh.0.h" | grep -o 'max-age=[0-9]*' | head -1)
  "$BIN/pl-map" publish --db "$D/maps.sqlite" --map town --version 2 >>"$D/pl-map.log" 2>&1 || fail "pl-map publish of version 2 failed"
  t0=$(now)
  local seen= took
  while :; do
    get /v1/maps/town "$B/fresh.1"
    took=$(elapsed "$t0" "$(now)")
    [ "$(json_field "$B/fresh.1" current_version)" = 2 ] && { seen=1; break; }
    le "$took" 60 || break
    sleep 0.05
  done
  check $([ -n "$seen" ] && [ "$lifetime" = max-age=1 ] && echo 0 || echo 1) \
    "freshness: the map answer lives ${lifetime:-?} through the cache; current_version $was -> 2 ${took}s after pl-map publish" \
    "want max-age=1 and version 2 served after the publish"

  # 6. Keys and encodings: other ROI queries are other objects; gzip or not, the same JSON.
  local qa="/v1/maps/town/roi?x=10&y=10&radius=5" qb="/v1/maps/town/roi?x=50&y=30&radius=5"
  local qg="/v1/maps/town/roi?x=30&y=20&radius=100" qp="/v1/maps/town/roi?x=31&y=20&radius=100"
  for q in qa qb qg qp; do direct "${!q}" "$B/$q.want" >/dev/null; done
  get "$qa" "$B/qa.1"
  get "$qb" "$B/qb.1"
  if same "$B/qa.1" "$B/qa.want" && same "$B/qb.1" "$B/qb.want" && ! same "$B/qa.1" "$B/qb.1"; then
    ok "ROI keys: two queries, two answers, each the origin's"
  else
    fail "ROI keys: the answers to x=10 and x=50 are not each the origin's ($(same "$B/qa.1" "$B/qb.1" && echo "they are the same"))"
  fi
  # gzip first then plain on one URL, plain first then gzip on another
  get "$qg" "$B/qg.gz" -H 'Accept-Encoding: gzip'
  local ce1 ce2 ce3 ce4
  ce1=$(grep -i -c '^content-encoding: *gzip' "$B/qg.gz.h")
  get "$qg" "$B/qg.plain"
  ce2=$(grep -i -c '^content-encoding' "$B/qg.plain.h")
  get "$qp" "$B/qp.plain"
  ce3=$(grep -i -c '^content-encoding' "$B/qp.plain.h")
  get "$qp" "$B/qp.gz" -H 'Accept-Encoding: gzip'
  ce4=$(grep -i -c '^content-encoding: *gzip' "$B/qp.gz.h")
  gzip -dc <"$B/qg.gz" >"$B/qg.gunzipped" 2>/dev/null
  gzip -dc <"$B/qp.gz" >"$B/qp.gunzipped" 2>/dev/null
  if [ "$ce1$ce2$ce3$ce4" = 1001 ] && same "$B/qg.gunzipped" "$B/qg.want" && same "$B/qg.plain" "$B/qg.want" &&
    same "$B/qp.gunzipped" "$B/qp.want" && same "$B/qp.plain" "$B/qp.want"; then
    ok "encodings: Accept-Encoding gzip gets gzip, none gets plain JSON, both the origin's JSON (either order)"
  else
    fail "encodings: gzip/plain/plain/gzip answers had Content-Encoding $ce1/$ce2/$ce3/$ce4 (want 1/0/0/1) or other JSON than the origin's"
  fi

  # 7. Figures: wrk through the cache, client requests against origin requests.
  local url label wrk_out reqs rps secs=4
  for label in blob roi; do
    case $label in
      blob) url="/v1/blobs/$h_wrk" ;;
      roi) url="/v1/maps/town/roi?x=20&y=20&radius=25" ;;
    esac
    m=$(mark)
    wrk_out=$(wrk -t 2 -c 32 -d ${secs}s "$CACHE$url" 2>&1)
    reqs=$(sed -n 's/^ *\([0-9]*\) requests in.*/\1/p' <<<"$wrk_out")
    rps=$(sed -n 's/^Requests\/sec: *\([0-9.]*\).*/\1/p' <<<"$wrk_out")
    local non2xx
    non2xx=$(sed -n 's/^ *Non-2xx or 3xx responses: *\([0-9]*\).*/\1/p' <<<"$wrk_out")
    n=$(origin_count "$m" GET "$url")
    local st
    st=$(origin_statuses "$m" GET "$url" | tr ' ' '\n' | sort | uniq -c | awk '{printf "%s%s x%s", (NR > 1 ? ", " : ""), $2, $1}')
    echo "figures: [$TIER] $label, wrk ${secs} s, 32 connections: ${reqs:-?} client requests (${rps:-?}/s), origin requests: $n${st:+ ($st)}, hit ratio $($PYTHON -c "import sys; r, o = int(sys.argv[1] or 0), int(sys.argv[2]); print('%.4f%%' % (100.0 * (r - o) / r) if r else '?')" "${reqs:-0}" "$n")"
    local limit=1
    [ $label = roi ] && limit=$((secs + 2))  # the first fetch, then a revalidation a second at most
    check $([ -n "$reqs" ] && [ -z "$non2xx" ] && [ "$n" -le $limit ] && echo 0 || echo 1) \
      "figures: $label under wrk: origin requests: $n for ${reqs:-?} client requests (at most $limit)" "${non2xx:+$non2xx non-2xx answers; }want at most $limit"
  done

  # 8. The origin failing, then unreachable: cached objects still served, stale map answers too.
  local qc="/v1/maps/town/roi?x=40&y=10&radius=20"
  direct /v1/maps/town "$B/out.manifest.want" >/dev/null
  direct "$qc" "$B/out.qc.want" >/dev/null
  get /v1/maps/town "$B/out.0"
  get "$qc" "$B/out.1"
  sleep "$EXPIRE"  # both expired now
  touch "$D/relay/503"
  get /v1/maps/town "$B/out.2"
  local r1="$CODE/$XC"
  same "$B/out.2" "$B/out.manifest.want" || r1+="/other-body"
  get "/v1/blobs/$h_blob" "$B/out.3"
  local r2="$CODE/$XC"
  get "/v1/maps/town/roi?x=41&y=10&radius=20" "$B/out.4"
  local r3=$CODE
  check $([ "${r1%%/*}" = 200 ] && [ "$r1" = "${r1%/other-body}" ] && [ "${r2%%/*}" = 200 ] && [ "${r3:0:1}" = 5 ] && echo 0 || echo 1) \
    "origin answering 503: expired manifest -> $r1, cached blob -> $r2, uncached ROI -> $r3" \
    "want the stale manifest (200), the blob (200) and a 5xx for what was never cached"
  rm -f "$D/relay/503"
  touch "$D/relay/down"
  sleep 0.3
  get "$qc" "$B/out.5"
  r1="$CODE/$XC"
  same "$B/out.5" "$B/out.qc.want" || r1+="/other-body"
  get "$tile_key" "$B/out.6"
  r2="$CODE/$XC"
  get "/v1/maps/town/roi?x=42&y=10&radius=20" "$B/out.7"
  r3=$CODE
  check $([ "${r1%%/*}" = 200 ] && [ "$r1" = "${r1%/other-body}" ] && [ "${r2%%/*}" = 200 ] && [ "${r3:0:1}" = 5 ] && echo 0 || echo 1) \
    "origin unreachable: expired ROI -> $r1, cached tile -> $r2, uncached ROI -> $r3" \
    "want the stale ROI answer (200), the tile (200) and a 5xx for what was never cached"
  rm -f "$D/relay/down"
  t0=$(now)
  local back= seq=
  while :; do
    get "/v1/maps/town/roi?x=43&y=10&radius=20" "$B/out.8"
    took=$(elapsed "$t0" "$(now)")
    seq+="$CODE/$XC "
    [ "$CODE" = 200 ] && { back=1; break; }
    le "$took" 60 || break  # a hang guard, not a time bound
    sleep 0.2
  done
  check $([ -n "$back" ] && echo 0 || echo 1) "origin back: a new ROI query answered ${took}s after (answers: $seq)" "want an answer once the origin is back"
}

for tier in "${TIERS[@]}"; do
  first=${#PIDS[@]}
  run_tier "$tier"
  # This tier's cache, relay and pl-server stop before the next tier starts.
  for p in "${PIDS[@]:$first}"; do kill "$p" 2>/dev/null; done
  for p in "${PIDS[@]:$first}"; do wait "$p" 2>/dev/null; done
done

echo "cache_tier: $PASSES checks passed, $FAILS failed ($WHICH; pl-server: $BUILD)"
[ $FAILS = 0 ]
