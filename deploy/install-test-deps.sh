#!/usr/bin/env bash
# Installs what the tests need beyond the build (deploy/install-deps.sh) and the browser tests
# (deploy/install-web-test-deps.sh): Debian's python3 with the Prometheus client (its text-format
# parser reads /metrics), nginx with openssl (deploy/nginx/probecast.conf is run against a
# daemon with a self-signed certificate), systemd's systemd-analyze (verifies
# deploy/systemd/probecast.service; no running systemd needed), and Node.js with
# tests/deploy/lint/node_modules (Redocly CLI and kubernetes-models, pinned by its
# package-lock.json; they lint protocol/openapi.yaml and deploy/kubernetes), and clang with
# its libFuzzer runtime (tests/fuzz/run.sh), and dav1d's library (test_video_encoder decodes
# the AV1 encoder's packets with it; the daemon only encodes). Idempotent.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
lint="$root/tests/deploy/lint"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

packages=(python3 python3-prometheus-client nginx-light openssl systemd clang libclang-rt-14-dev
          libdav1d-dev)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# Debian's Node.js 18 and npm, when no node is installed (the lint tools work on 18 and 20)
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
  missing+=(nodejs npm)
fi
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing: ${missing[*]}" >&2
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# npm ci installs exactly the lock file; it is rerun when the lock file is newer than the
# installed tree (npm writes node_modules/.package-lock.json on every install).
if [ ! -f "$lint/node_modules/.package-lock.json" ] ||
   [ "$lint/package-lock.json" -nt "$lint/node_modules/.package-lock.json" ]; then
  echo "installing: tests/deploy/lint/node_modules (npm ci)" >&2
  (cd "$lint" && npm ci --no-audit --no-fund --loglevel=error)
fi
