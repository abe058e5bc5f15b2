#!/bin/bash
# Installs the npm modules pinned by SOURCE_DIR/package-lock.json into NODE_DIR with npm ci, once per
# build tree and again when the lock changes: three.js for the map viewer's build, and the checkers
# the tests run that are not written here (@mcap/core for the run logs, swagger-cli for the OpenAPI
# file). With STAMP, touches it when done (a build step's output); HINT is added to the errors.
#   npm_ci.sh SOURCE_DIR NODE_DIR [STAMP [HINT]]
set -uo pipefail
src=$1 dir=$2 stamp=${3:-} hint=${4:-}
what=$(basename "$src")
fail() {
  echo "npm_ci ($what): $*${hint:+ $hint}" >&2
  exit 1
}
for tool in node npm; do
  command -v "$tool" >/dev/null 2>&1 ||
    fail "$tool is not installed (Debian: apt-get install nodejs npm; both are in deploy/viewer-packages.txt, which ./pl installs)."
done
mkdir -p "$dir" || exit 1
if [[ -d "$dir/node_modules" ]] && cmp -s "$src/package-lock.json" "$dir/package-lock.json"; then
  echo "npm_ci ($what): $dir already holds the modules of package-lock.json"
else
  cp "$src/package.json" "$src/package-lock.json" "$dir/" || exit 1
  if ! (cd "$dir" && npm ci --no-audit --no-fund --loglevel=error); then
    rm -f "$dir/package-lock.json"  # try again next time
    fail "npm ci failed in $dir: it fetches the modules of $src/package.json from the npm registry once per build tree" \
         "(and again when the lock changes), so the registry must be reachable, or npm's proxy or registry set" \
         "(npm config set proxy URL, npm config set registry URL)."
  fi
  echo "npm_ci ($what): installed $(cd "$dir" && npm ls --depth=0 --parseable 2>/dev/null | tail -n +2 | xargs -n1 basename | tr '\n' ' ')into $dir"
fi
if [[ -n "$stamp" ]]; then touch "$stamp"; fi
