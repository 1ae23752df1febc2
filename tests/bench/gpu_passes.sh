#!/usr/bin/env bash
# GPU benchmark: BVH build, primary/shadow ray throughput (issue 2) and the DDGI per-pass
# times at 32x8x32 probes x 64/128/256 rays (issue 3, the paper's Table 2 setting) on a
# procedurally built scene. Prints the tables and writes them under OUT_DIR (default
# tests/bench/results). Usage: tests/bench/gpu_passes.sh [PROBECAST_BINARY]
set -euo pipefail
bin="${1:-build/probecast}"
out="${OUT_DIR:-tests/bench/results}"
tris="${BENCH_TRIANGLES:-1000000}"
width="${BENCH_WIDTH:-1920}"
height="${BENCH_HEIGHT:-1080}"
mkdir -p "$out"
{
  echo "# probecast GPU benchmark, $(date -u +%Y-%m-%dT%H:%MZ)"
  "$bin" render --list-devices
  echo
  echo "## direct lighting, ${width}x${height}, builtin:spheres:$tris"
  "$bin" render "builtin:spheres:$tris" --gi off --width "$width" --height "$height" \
      --timings --repeat 10 -o "$out/spheres-direct.png"
  for rays in 64 128 256; do
    echo
    echo "## DDGI 32x8x32 probes x $rays rays, ${width}x${height}, builtin:spheres:$tris"
    "$bin" render "builtin:spheres:$tris" --gi ddgi --probes 32,8,32 --rays "$rays" --frames 8 \
        --width "$width" --height "$height" --timings --repeat 10 -o "$out/spheres-ddgi-$rays.png"
  done
} 2>&1 | tee "$out/gpu_passes.txt"
