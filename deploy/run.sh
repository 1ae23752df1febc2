#!/usr/bin/env bash
# The main job: install dependencies, build, and render the bundled demo scene.
# Usage: deploy/run.sh [extra render options...]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
"$root/deploy/install-deps.sh"
"$root/deploy/build.sh"
out="${OUT_IMAGE:-$root/out/demo.png}"
mkdir -p "$(dirname "$out")"
"$root/build/probecast" render builtin:cornell -o "$out" --timings "$@"
echo "wrote $out"
