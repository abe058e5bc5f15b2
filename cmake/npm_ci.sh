#!/bin/bash
# A test fixture: installs the npm modules pinned by SOURCE_DIR/package-lock.json (checkers not
# written here: @mcap/core for the run logs, swagger-cli for the OpenAPI file) into NODE_DIR, once per
# build tree and again when the lock changes.
#   npm_ci.sh SOURCE_DIR NODE_DIR
set -uo pipefail
src=$1 dir=$2
what=$(basename "$src")
say() { echo "npm_ci ($what): $*" >&2; }
for tool in node npm; do
  if ! command -v "$tool" >/dev/null 2>&1; then
    say "$tool is not installed: the test runs a checker under Node.js" \
        "(Debian: apt-get install nodejs npm; both are in deploy/build-packages.txt)"
    exit 1
  fi
done
mkdir -p "$dir" || exit 1
if [[ -d "$dir/node_modules" ]] && cmp -s "$src/package-lock.json" "$dir/package-lock.json"; then
  echo "npm_ci ($what): $dir already holds the modules of package-lock.json"
  exit 0
fi
cp "$src/package.json" "$src/package-lock.json" "$dir/" || exit 1
if ! (cd "$dir" && npm ci --no-audit --no-fund --loglevel=error); then
  say "npm ci failed in $dir: it fetches the modules of $src/package.json from the npm registry once" \
      "per build tree, so the registry must be reachable (or npm's proxy/registry set: npm config set proxy ...)"
  rm -f "$dir/package-lock.json"  # try again next time
  exit 1
fi
echo "npm_ci ($what): installed $(cd "$dir" && npm ls --depth=0 --parseable 2>/dev/null | tail -n +2 | xargs -n1 basename | tr '\n' ' ')into $dir"
