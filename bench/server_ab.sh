#!/usr/bin/env bash
# Two pl-server builds against each other on bench/bench_server.sh's store and request lists (run
# that first, with the same WORK_DIR): alternating rounds of wrk -t1 -c64 for 4 s on each, per
# request list, and the ratio B / A of every round. For a change to the server, A is the build
# before it and B the build after, measured in the same minutes of the same machine.
#   bench/server_ab.sh A_PL_SERVER B_PL_SERVER WORK_DIR [ROUNDS]
set -euo pipefail
a_bin=${1:?usage: server_ab.sh A_PL_SERVER B_PL_SERVER WORK_DIR [ROUNDS]}
b_bin=${2:?usage: server_ab.sh A_PL_SERVER B_PL_SERVER WORK_DIR [ROUNDS]}
work=${3:?usage: server_ab.sh A_PL_SERVER B_PL_SERVER WORK_DIR [ROUNDS]}
rounds=${4:-5}
for f in maps.sqlite tiles-town.lua tiles-tiles4k.lua roi.lua; do
  [[ -f "$work/$f" ]] || { echo "server_ab: $work/$f is missing: run bench/bench_server.sh BIN_DIR $work first"; exit 2; }
done
command -v wrk >/dev/null || { echo "server_ab: wrk is missing (apt-get install wrk)"; exit 0; }

free_port() { python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }
pids=()
trap 'kill "${pids[@]}" 2>/dev/null || true' EXIT
start() {  # BIN THREADS -> port
  local port
  port=$(free_port)
  "$1" --db "$work/maps.sqlite" --listen 127.0.0.1:"$port" --threads "$2" --quiet >/dev/null 2>&1 &
  pids+=($!)
  for _ in $(seq 50); do curl -sf "http://127.0.0.1:$port/healthz" >/dev/null && break; sleep 0.1; done
  echo "$port"
}
rate() { wrk -t1 -c64 -d4s -s "$2" "http://127.0.0.1:$1" | awk '/Requests\/sec/ { print $2 }'; }

for case in "tiles-town.lua 2" "tiles-tiles4k.lua 2" "roi.lua 1"; do
  read -r script threads <<<"$case"
  pa=$(start "$a_bin" "$threads")
  pb=$(start "$b_bin" "$threads")
  line="" ratios=()
  for ((r = 0; r < rounds; r++)); do
    ra=$(rate "$pa" "$work/$script")
    rb=$(rate "$pb" "$work/$script")
    ratios+=("$(awk -v a="$ra" -v b="$rb" 'BEGIN { printf "%.2f", b / a }')")
    line+=" $(printf '%.0f/%.0f' "$ra" "$rb")"
  done
  med=$(printf '%s\n' "${ratios[@]}" | sort -n | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }')
  echo "${script%.lua}, $threads server thread(s): B / A median ${med}x (rounds A/B req/s:$line; ratios ${ratios[*]})"
  kill "${pids[@]}" 2>/dev/null || true
  wait 2>/dev/null || true
  pids=()
done
