#!/usr/bin/env bash
# The main job: install dependencies, build, and run the daemon in the foreground with the
# bundled demo scene. Open the printed http:// address in a browser; stop with Ctrl-C.
# State (the last upload, camera, lights, settings) is kept in a data directory, so it survives
# a restart: $PROBECAST_DATA_DIR, else ${XDG_DATA_HOME:-~/.local/share}/probecast, unless the
# options name one with --data-dir.
# Usage: deploy/run.sh [extra serve options...]   (e.g. --http 0.0.0.0:8080 --token T)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
"$root/deploy/install-deps.sh"
"$root/deploy/build.sh"
args=("$@")
given=0
for a in "${args[@]}"; do [ "$a" = "--data-dir" ] && given=1; done
if [ "$given" = 0 ]; then
  data="${PROBECAST_DATA_DIR:-${XDG_DATA_HOME:-$HOME/.local/share}/probecast}"
  mkdir -p "$data"
  echo "probecast: keeping state in $data (set PROBECAST_DATA_DIR or pass --data-dir to change)" >&2
  args=(--data-dir "$data" "${args[@]}")
fi
exec "${BUILD_DIR:-$root/build}/probecast" serve "${args[@]}"
