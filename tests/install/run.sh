#!/usr/bin/env bash
# The installed package as another project uses it: cmake --install this build into a fresh prefix,
# configure and build tests/install/consumer against it with find_package, run its program.
#   tests/install/run.sh BUILD_DIR SOURCE_DIR WORK_DIR "CXX_FLAGS" "LINKER_FLAGS"
set -euo pipefail
build=$1 src=$2 work=$3 cxx_flags=${4:-} link_flags=${5:-}
rm -rf "$work"
mkdir -p "$work"
cmake --install "$build" --prefix "$work/prefix" >"$work/install.log"
test -f "$work/prefix/lib/cmake/PointLocalization/PointLocalizationConfig.cmake"
for tool in pl-map pl-server pl-localize pl-sim pl-eval pl-dataset pl-fleet; do
  test -x "$work/prefix/bin/$tool" || { echo "install: $tool was not installed into $work/prefix/bin" >&2; exit 1; }
done
test -f "$work/prefix/include/pl/client/vehicle_localizer.hpp"
cmake -S "$src/tests/install/consumer" -B "$work/build" -G Ninja -DCMAKE_PREFIX_PATH="$work/prefix" \
  -DCMAKE_CXX_FLAGS="$cxx_flags" -DCMAKE_EXE_LINKER_FLAGS="$link_flags" \
  -DEXAMPLE_SOURCE="$src/docs/examples/embed_localizer.cpp" >"$work/configure.log"
cmake --build "$work/build" >"$work/build.log"
"$work/build/consumer" "$work/yard.sqlite"
# The prefix holds a copy of every library and tool (some 700 MB in the sanitizer build): it is kept
# only when the test fails, for its logs.
rm -rf "$work"
