#!/usr/bin/env bash
# Installs what the browser tests of the viewer (tests/web) need: Debian's Chromium (Playwright's
# own browser download is not used), Node.js and npm (Debian's, when none is installed) and
# tests/web/node_modules (playwright-core, pinned by tests/web/package-lock.json).
# Idempotent: does nothing when both are present; safe to run before every test run.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
web="$root/tests/web"

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

if ! dpkg-query -W -f='${Status}' chromium 2>/dev/null | grep -q "install ok installed" || [ ! -x /usr/bin/chromium ]; then
  echo "installing: chromium" >&2
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends chromium >/dev/null
fi

if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
  echo "installing: nodejs npm" >&2
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends nodejs npm >/dev/null
fi
node_major="$(node -p 'process.versions.node.split(".")[0]')"
if [ "$node_major" -lt 20 ]; then
  # playwright-core needs Node.js 20; Debian 12's own is 18. The browser test then reports
  # itself skipped (ctest exit code 77) instead of failing the run.
  echo "warning: tests/web needs Node.js 20 or newer (found $(node --version)): the browser test will be skipped" >&2
  exit 0
fi

# npm ci installs exactly the lock file; it is rerun when the lock file is newer than the
# installed tree (npm writes node_modules/.package-lock.json on every install).
if [ ! -d "$web/node_modules/playwright-core" ] || [ "$web/package-lock.json" -nt "$web/node_modules/.package-lock.json" ]; then
  echo "installing: tests/web/node_modules (npm ci)" >&2
  (cd "$web" && PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1 npm ci --no-audit --no-fund --loglevel=error)
fi
