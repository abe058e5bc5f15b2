#!/usr/bin/env bash
# PointLocalization: set-up, build, demo, tests and benchmarks in one command.
#   ./pl demo    install what is missing, build Release, run the main job and print its result
#   ./pl test    install what is missing, build Debug with ASan+UBSan (clang), run every test, the
#                threaded ones again under ThreadSanitizer, fuzz the targets 120 s in all
#   ./pl bench   install what is missing, build Release, run every benchmark in bench/
#   ./pl build   install what is missing and build Release only
#   ./pl fuzz [TARGET...] [--seconds N]   build the libFuzzer targets (build/asan) and run each N s (60)
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
cd "$ROOT"
JOBS=${PL_JOBS:-$(nproc 2>/dev/null || echo 2)}

say() { printf '\033[1m==> %s\033[0m\n' "$*" >&2; }

usage() {
  sed -n '2,8s/^# \{0,1\}//p' "$0"
  exit "${1:-0}"
}

# Installs the Debian packages listed in the given files (default deploy/build-packages.txt) that
# are not installed yet.
ensure_packages() {
  local missing=() pkg list
  for list in "${@:-deploy/build-packages.txt}"; do
    while read -r pkg; do
      [[ -z "$pkg" || "$pkg" == \#* ]] && continue
      # "pkg cmd=NAME": satisfied by any NAME on the PATH (npm comes inside other Node.js builds).
      if [[ "$pkg" == *" cmd="* ]]; then
        command -v "${pkg##* cmd=}" >/dev/null 2>&1 && continue
        pkg=${pkg%% *}
      fi
      dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
    done <"$list"
  done
  [[ ${#missing[@]} -eq 0 ]] && return 0
  if [[ $(id -u) -eq 0 ]]; then
    say "installing ${#missing[@]} Debian packages: ${missing[*]}"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  else
    echo "These Debian packages are missing. Install them, then run ./pl again:" >&2
    echo "  sudo apt-get install -y --no-install-recommends ${missing[*]}" >&2
    exit 1
  fi
}

# build DIR CMAKE_ARGS... [-- TARGET...]: configure (again, cheaply, so that the arguments hold in an
# existing tree), then build incrementally.
build() {
  local dir=$1 args=() targets=()
  shift
  while [[ $# -gt 0 && "$1" != "--" ]]; do args+=("$1"); shift; done
  [[ "${1:-}" == "--" ]] && shift && targets=(--target "$@")
  [[ -f "$dir/build.ninja" ]] || say "configuring $dir"
  cmake -S . -B "$dir" -G Ninja "${args[@]}" >/dev/null
  say "building $dir"
  cmake --build "$dir" -j "$JOBS" "${targets[@]}"
}

# build/release: the tools, the servers and the viewer; no tests (./pl test builds its own trees).
build_release() { build build/release -DCMAKE_BUILD_TYPE=Release -DPL_BUILD_TESTS=OFF -DPL_BUILD_BENCH=OFF "$@"; }

# The demo builds only the five tools it runs (not the viewer, the ROS node or the other tools).
cmd_demo() {
  ensure_packages deploy/build-packages.txt
  build_release -- pl-sim pl-map pl-server pl-localize pl-eval
  bash tools/demo.sh build/release/bin build/demo
}

# warn_disk GB WHAT: a warning when the disk holding the repository has less than GB free (a build
# that fills the disk stops halfway with "No space left on device", far from the cause).
warn_disk() {
  local need=$1 what=$2 avail
  avail=$(df -Pk "$ROOT" | awk 'NR == 2 { print int($4 / 1048576) }')
  if [[ -n "$avail" ]] && (( avail < need )); then
    echo "warning: $avail GB free on the disk of $ROOT; $what writes about $need GB from a clean clone." >&2
    echo "         Free some space (old build/ folders, /tmp) if the build stops with 'No space left on device'." >&2
  fi
}

# phase NAME COMMAND...: runs one phase of ./pl test and keeps its wall time for the summary.
PHASES=()
phase() {
  local name=$1 t0=$SECONDS rc=0
  shift
  say "$name"
  "$@" || rc=$?
  PHASES+=("$(printf '%-34s %5d s' "$name" $((SECONDS - t0)))")
  return $rc
}

# The tests' own results, from ctest's JUnit files: "N passed, N failed, N skipped", then the skipped
# tests (what the machine lacks: an IPv6 loopback, /dev/full; never a dependency ./pl test installs)
# and the 15 slowest tests.
test_summary() {
  python3 tests/summary.py "$@"
}

cmd_test() {
  local t_all=$SECONDS rc=0
  phase "installing the packages" ensure_packages deploy/build-packages.txt deploy/viewer-packages.txt deploy/test-packages.txt deploy/fuzz-packages.txt
  # Measured from a clean clone (2026-12-06): build/asan 1.4 GB after its tests, build/tsan 0.25.
  warn_disk 3 "./pl test (build/asan, build/tsan)"
  phase "building build/asan (ASan+UBSan)" build_asan
  # The ThreadSanitizer build runs beside the tests, at low priority: it takes the CPU the tests leave
  # idle (servers starting, waits on sockets) and gives it back at once when a test wants it.
  mkdir -p build
  (renice -n 19 -p $BASHPID >/dev/null && build_tsan) >build/background-builds.log 2>&1 &
  local builds=$!
  trap "kill $builds 2>/dev/null || true" EXIT
  # Leak checking stays on; UBSan reports fail the test (-fno-sanitize-recover at build time).
  export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
  export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1}
  export PL_NO_PROGRESS=1
  rm -rf build/test-results && mkdir -p build/test-results
  # Twice as many tests as cores: many of them wait on servers and sockets more than they compute.
  phase "testing build/asan" ctest --test-dir build/asan --output-on-failure --no-tests=error -j $((2 * JOBS)) \
    --output-junit "$ROOT/build/test-results/asan.xml" || rc=1
  phase "finishing the TSan build" wait_for_builds $builds || rc=1
  # The fuzzers and the ThreadSanitizer tests (mostly waiting on their servers) side by side. The
  # fuzzers share 120 s of wall time on every core, at most 20 s and at least 10 s each: a new target
  # does not lengthen the run until there are 24.
  local targets=(build/asan/bin/fuzz_*) each
  each=$(( 120 * JOBS / ${#targets[@]} ))
  (( each > 20 )) && each=20
  (( each < 10 )) && each=10
  bash tests/fuzz/run.sh build/asan/bin $each >build/fuzz-run.log 2>&1 &
  local fuzzing=$!
  phase "testing build/tsan (ThreadSanitizer)" test_tsan || rc=1
  phase "fuzzing each target $each s" wait_for_fuzzing $fuzzing || rc=1
  PHASES+=("$(printf '%-34s %5d s' "all" $((SECONDS - t_all)))")
  echo
  printf '%s\n' "${PHASES[@]}"
  test_summary build/test-results/asan.xml build/test-results/tsan.xml || rc=1
  return $rc
}

wait_for_fuzzing() {
  local status=0
  wait "$1" || status=$?
  cat build/fuzz-run.log
  return $status
}

wait_for_builds() {
  if ! wait "$1"; then
    tail -n 40 build/background-builds.log >&2
    echo "the ThreadSanitizer build failed: build/background-builds.log" >&2
    return 1
  fi
}

# The threaded parts under ThreadSanitizer: the tile client (its fetch thread against a real
# pl-server), the vehicle localizer (input, worker and reader threads; moving to a new map version
# mid-drive with a second tile client) and the server (its io_context threads, in the pl-server
# processes the tests start; the viewer's event streams). A report fails the test. pl-map, which the
# tests only run to make stores, comes from build/asan.
build_tsan() {
  build build/tsan -DCMAKE_BUILD_TYPE=Debug -DPL_TSAN=ON -DPL_BUILD_BENCH=OFF -DPL_TOOLS_DIR="$ROOT/build/asan/bin" \
    -- test_client test_vehicle_localizer test_map_swap test_reports test_server test_viewer_routes pl-server
}

test_tsan() {
  TSAN_OPTIONS=${TSAN_OPTIONS:-halt_on_error=1:exitcode=66:second_deadlock_stack=1} \
    ctest --test-dir build/tsan --output-on-failure --no-tests=error -j $((2 * JOBS)) --output-junit "$ROOT/build/test-results/tsan.xml" \
    -R '^(TileClient|TileCache|VehicleLocalizer|MapSwap|Server|ViewerRoutes|Reports)\.'
}

# build/asan: the tests' build and the fuzzers' (clang: libFuzzer). A tree configured with another
# compiler (gcc, before 2026-12-07) is made again: CMake cannot change a tree's compiler.
ASAN_ARGS=(-DCMAKE_BUILD_TYPE=Debug -DPL_SANITIZE=ON -DPL_BUILD_BENCH=OFF -DPL_REQUIRE_ROS1=ON
           -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++)
build_asan() {
  if [[ -f build/asan/CMakeCache.txt ]] && ! grep -q '^CMAKE_CXX_COMPILER:[A-Z]*=.*clang++' build/asan/CMakeCache.txt; then
    say "build/asan was configured with another compiler: configuring it again with clang"
    rm -rf build/asan
  fi
  build build/asan "${ASAN_ARGS[@]}" "$@"
}

cmd_fuzz() {
  local seconds=60 targets=()
  while [[ $# -gt 0 ]]; do
    case "$1" in
      --seconds)
        [[ $# -ge 2 && "$2" =~ ^[0-9]+$ && "$2" -gt 0 ]] || { echo "--seconds takes a whole number of seconds, e.g. --seconds 600" >&2; exit 2; }
        seconds=$2
        shift 2 ;;
      -*) echo "unknown option $1 (./pl fuzz [TARGET...] [--seconds N])" >&2; exit 2 ;;
      *) targets+=("$1"); shift ;;
    esac
  done
  ensure_packages deploy/build-packages.txt deploy/viewer-packages.txt deploy/test-packages.txt deploy/fuzz-packages.txt
  build_asan -- fuzzers
  bash tests/fuzz/run.sh build/asan/bin "$seconds" "${targets[@]}"
}

cmd_bench() {
  ensure_packages deploy/build-packages.txt deploy/viewer-packages.txt deploy/test-packages.txt deploy/bench-packages.txt
  build build/release -DCMAKE_BUILD_TYPE=Release -DPL_BUILD_TESTS=OFF -DPL_BUILD_BENCH=ON
  bash bench/run.sh build/release/bin
}

case "${1:-}" in
  demo) cmd_demo ;;
  test) cmd_test ;;
  bench) cmd_bench ;;
  build) ensure_packages deploy/build-packages.txt deploy/viewer-packages.txt && build_release ;;
  fuzz) shift; cmd_fuzz "$@" ;;
  -h | --help | help) usage 0 ;;
  *) usage 2 ;;
esac
