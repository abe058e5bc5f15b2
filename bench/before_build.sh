#!/usr/bin/env bash
# Builds the tools of an earlier revision (Release), for benchmarks that set this build beside it,
# and prints the folder of its binaries. Made once per revision: a finished build is reused.
#   bench/before_build.sh REV WORK_DIR        (REV: a commit, tag or branch of this repository)
set -euo pipefail
rev=${1:?usage: bench/before_build.sh REV WORK_DIR}
work=${2:?usage: bench/before_build.sh REV WORK_DIR}
root=$(cd "$(dirname "$0")/.." && pwd)
commit=$(git -C "$root" rev-parse --verify --quiet "$rev^{commit}") || {
  echo "bench/before_build.sh: $rev is not a commit of $root (a shallow clone may lack it: git fetch --unshallow)" >&2
  exit 1
}
mkdir -p "$work"
src="$work/before-${commit:0:12}"
if [[ ! -f "$src/build/done" ]]; then
  rm -rf "$src"
  git -C "$root" archive --format=tar --prefix=src/ "$commit" | tar -x -C "$work" && mv "$work/src" "$src"
  cmake -S "$src" -B "$src/build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPL_BUILD_TESTS=OFF -DPL_BUILD_BENCH=OFF \
    -DPL_BUILD_VIEWER=OFF >/dev/null
  cmake --build "$src/build" -j "$(nproc)" --target pl-map pl-localize pl-sim pl-eval >&2
  touch "$src/build/done"
fi
echo "$src/build/bin"
