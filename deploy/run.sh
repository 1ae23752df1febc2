#!/usr/bin/env bash
# The main job: install dependencies, build, and run the daemon in the foreground with the
# bundled demo scene. Open the printed http:// address in a browser; stop with Ctrl-C.
# Usage: deploy/run.sh [extra serve options...]   (e.g. --http 0.0.0.0:8080 --token T)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
"$root/deploy/install-deps.sh"
"$root/deploy/build.sh"
exec "${BUILD_DIR:-$root/build}/probecast" serve "$@"
