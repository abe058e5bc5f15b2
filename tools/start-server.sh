# Sourced by the demo and the benchmarks: start_server LOG PL_SERVER ARGS... runs PL_SERVER ARGS on
# 127.0.0.1 (pass --listen 127.0.0.1:0 for a free port) in the background, its output in LOG, and sets
# SERVER_PID and SERVER_URL once it listens; if it has not within 10 s, or has stopped, stops it,
# prints LOG and exits 1.
start_server() {
  local log=$1
  shift
  "$@" >"$log" 2>&1 &
  SERVER_PID=$!
  SERVER_URL=""
  for _ in $(seq 100); do
    SERVER_URL=$(grep -o 'http://127.0.0.1:[0-9]*' "$log" | head -1 || true)
    [[ -n "$SERVER_URL" ]] && return 0
    kill -0 "$SERVER_PID" 2>/dev/null || break
    sleep 0.1
  done
  kill "$SERVER_PID" 2>/dev/null || true
  wait "$SERVER_PID" 2>/dev/null || true
  echo "pl-server did not start:" >&2
  cat "$log" >&2
  exit 1
}
