#!/usr/bin/env bash
# Installs what the browser tests of the viewer (tests/web) need: Debian's Chromium (Playwright's
# own browser download is not used), Node.js and npm (Debian's, when none is installed: 18 on
# Debian 12; the tests run on Node.js 18 and newer) and tests/web/node_modules (playwright-core,
# pinned by tests/web/package-lock.json).
# Idempotent: does nothing when all are present; safe to run before every test run. Exits non-zero
# when something is still missing afterwards: the browser test fails then rather than skips.
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
if [ "$node_major" -lt 18 ]; then
  echo "error: tests/web needs Node.js 18 or newer, found $(node --version)" >&2
  exit 1
fi

# playwright-core is pinned at 1.61.1, the newest release whose engines allow Node.js 18 (1.62
# and later need 20): Debian 12's nodejs is 18, and the tests should run on a stock Debian 12 as
# they do on Node.js 20. It drives Debian's Chromium (156 in bookworm-security; 1.61 was built
# against 149) over CDP through everything the viewer tests use. Raise the pin once the tests no
# longer have to run on Node.js 18 (Debian 13 ships 20).
# npm ci installs exactly the lock file; it is rerun when the lock file is newer than the
# installed tree (npm writes node_modules/.package-lock.json on every install) or the installed
# playwright-core is not the pinned one.
pinned() {
  node -p 'require(process.argv[1]).packages["node_modules/playwright-core"].version' "$1" 2>/dev/null || true
}
if [ ! -d "$web/node_modules/playwright-core" ] || [ "$web/package-lock.json" -nt "$web/node_modules/.package-lock.json" ] ||
   [ "$(pinned "$web/package-lock.json")" != "$(pinned "$web/node_modules/.package-lock.json")" ]; then
  echo "installing: tests/web/node_modules (npm ci)" >&2
  (cd "$web" && PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1 npm ci --no-audit --no-fund --loglevel=error)
fi

if [ ! -x /usr/bin/chromium ] || [ ! -f "$web/node_modules/playwright-core/package.json" ]; then
  echo "error: /usr/bin/chromium or tests/web/node_modules/playwright-core is still missing" >&2
  exit 1
fi
