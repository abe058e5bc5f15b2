#!/bin/bash
# The run-log test's fixture: installs the independent MCAP reader (@mcap/core, and fzstd for its zstd
# chunks), pinned by package-lock.json, into NODE_DIR once per build tree (again when the lock changes).
#   npm_ci.sh SOURCE_DIR NODE_DIR
set -uo pipefail
src=$1 dir=$2
say() { echo "run_log npm_ci: $*" >&2; }
for tool in node npm; do
  if ! command -v "$tool" >/dev/null 2>&1; then
    say "$tool is not installed: the run-log test reads the log with @mcap/core under Node.js" \
        "(Debian: apt-get install nodejs npm; both are in deploy/debian-packages.txt)"
    exit 1
  fi
done
mkdir -p "$dir" || exit 1
if [[ -d "$dir/node_modules/@mcap/core" && -d "$dir/node_modules/fzstd" ]] && cmp -s "$src/package-lock.json" "$dir/package-lock.json"; then
  echo "run_log npm_ci: $dir already holds the modules of package-lock.json"
  exit 0
fi
cp "$src/package.json" "$src/package-lock.json" "$dir/" || exit 1
if ! (cd "$dir" && npm ci --no-audit --no-fund --loglevel=error); then
  say "npm ci failed in $dir: it fetches @mcap/core and fzstd from the npm registry once per build tree," \
      "so the registry must be reachable (or npm's proxy/registry set: npm config set proxy ...)"
  rm -f "$dir/package-lock.json"  # try again next time
  exit 1
fi
echo "run_log npm_ci: installed $(cd "$dir" && node -p "require('@mcap/core/package.json').version" 2>/dev/null || echo '?') of @mcap/core into $dir"
