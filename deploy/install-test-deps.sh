#!/usr/bin/env bash
# Installs what the tests need beyond the build (deploy/install-deps.sh) and the browser tests
# (deploy/install-web-test-deps.sh): Debian's python3 with the Prometheus client (its text-format
# parser reads /metrics) and nginx with openssl (deploy/nginx/probecast.conf is run against a
# daemon with a self-signed certificate). Idempotent.
set -euo pipefail
packages=(python3 python3-prometheus-client nginx-light openssl)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "installing: ${missing[*]}" >&2
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
