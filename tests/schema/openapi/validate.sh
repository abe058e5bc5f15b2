#!/bin/bash
# schema/openapi.yaml checked by a standard OpenAPI 3 validator not written here (swagger-cli, which
# client generators and API gateways agree with), and the same validator refusing a copy with the
# classic YAML slip (a description with a comma inside a flow mapping), so that a validator that
# passes everything fails this test.
#   validate.sh OPENAPI_YAML NODE_DIR WORK_DIR
set -uo pipefail
spec=$1 node_dir=$2 work=$3
cli=$node_dir/node_modules/.bin/swagger-cli
[[ -x "$cli" ]] || { echo "no swagger-cli in $node_dir: the schema.openapi.NpmCi fixture installs it" >&2; exit 1; }
if ! "$cli" validate "$spec"; then
  echo "FAIL: $spec is not valid OpenAPI 3 (swagger-cli's reasons above)" >&2
  exit 1
fi
mkdir -p "$work"
sed 's|description: "ENU east, metres"|description: ENU east, metres|' "$spec" >"$work/broken.yaml"
if cmp -s "$spec" "$work/broken.yaml"; then
  echo "FAIL: the ROI query's x parameter is no longer described as \"ENU east, metres\"; update the broken copy in $0" >&2
  exit 1
fi
if "$cli" validate "$work/broken.yaml" >"$work/broken.log" 2>&1; then
  echo "FAIL: swagger-cli accepted a copy with an unquoted comma in a flow mapping:" >&2
  cat "$work/broken.log" >&2
  exit 1
fi
grep -q "additional properties" "$work/broken.log" || { cat "$work/broken.log" >&2; exit 1; }
echo "swagger-cli: $spec valid; the broken copy refused"
