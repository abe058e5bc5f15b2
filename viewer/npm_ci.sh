#!/bin/bash
# The viewer's build step: installs three.js (pinned by package-lock.json) into NPM_DIR with npm ci,
# once per build tree and again when the lock changes, then touches NPM_DIR/npm-ci.stamp.
#   npm_ci.sh SOURCE_DIR NPM_DIR
set -uo pipefail
src=$1 dir=$2
fail() {
  echo "viewer: $*" >&2
  exit 1
}
for tool in node npm; do
  command -v "$tool" >/dev/null 2>&1 ||
    fail "$tool is not installed: the build fetches three.js for the map viewer with npm (Debian: apt-get install nodejs npm;" \
         "both are in deploy/build-packages.txt, which ./pl installs), or configure with -DPL_BUILD_VIEWER=OFF to build without the viewer"
done
mkdir -p "$dir" || exit 1
if [[ -f "$dir/node_modules/three/package.json" ]] && cmp -s "$src/package-lock.json" "$dir/package-lock.json"; then
  touch "$dir/npm-ci.stamp"
  exit 0
fi
cp "$src/package.json" "$src/package-lock.json" "$dir/" || exit 1
if ! (cd "$dir" && npm ci --no-audit --no-fund --loglevel=error); then
  rm -f "$dir/package-lock.json"  # try again at the next build
  fail "npm ci failed in $dir: the build fetches three.js from the npm registry once per build tree (and again when" \
       "viewer/package-lock.json changes), so the registry must be reachable, or npm's proxy or registry set" \
       "(npm config set proxy URL, npm config set registry URL); then build again. Or configure with -DPL_BUILD_VIEWER=OFF" \
       "to build without the map viewer."
fi
version=$(node -p "JSON.parse(require('fs').readFileSync(process.argv[1], 'utf8')).version" "$dir/node_modules/three/package.json" 2>/dev/null)
echo "viewer: three ${version:-?} installed into $dir"
touch "$dir/npm-ci.stamp"
