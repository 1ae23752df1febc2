#!/usr/bin/env bash
# The ctest tests openapi_lint and kubernetes_manifests (tests/CMakeLists.txt), run from this npm
# package's node_modules (deploy/install-test-deps.sh installs it with npm ci).
#   run.sh openapi ROOT     Redocly CLI's linter (redocly.yaml: recommended-strict) on
#                           ROOT/protocol/openapi.yaml
#   run.sh kubernetes ROOT  every manifest in ROOT/deploy/kubernetes against the Kubernetes API
#                           schemas (kubernetes.mjs)
# A missing or outdated install fails the test (it is never skipped).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
what="${1:?usage: run.sh openapi|kubernetes ROOT}"
root="${2:?usage: run.sh openapi|kubernetes ROOT}"

fail() { echo "FAIL: $*" >&2; exit 1; }
command -v node >/dev/null 2>&1 || fail "node not found: run deploy/install-test-deps.sh"
[ -f "$here/node_modules/.package-lock.json" ] ||
  fail "$here/node_modules is missing: run deploy/install-test-deps.sh (npm ci there)"
[ "$here/package-lock.json" -nt "$here/node_modules/.package-lock.json" ] &&
  fail "$here/node_modules is older than package-lock.json: run deploy/install-test-deps.sh"

case "$what" in
openapi)
  # no usage telemetry and no update check (CI has no network but the package registries)
  export REDOCLY_TELEMETRY=off REDOCLY_SUPPRESS_UPDATE_NOTICE=true
  exec node "$here/node_modules/@redocly/cli/bin/cli.js" lint --config "$here/redocly.yaml" \
    --format stylish "$root/protocol/openapi.yaml"
  ;;
kubernetes)
  shopt -s nullglob
  manifests=("$root"/deploy/kubernetes/*.yaml)
  [ ${#manifests[@]} -gt 0 ] || fail "no manifests in $root/deploy/kubernetes"
  exec node "$here/kubernetes.mjs" "${manifests[@]}"
  ;;
*) fail "unknown check '$what' (openapi or kubernetes)" ;;
esac
