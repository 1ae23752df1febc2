#!/usr/bin/env bash
# The libFuzzer harnesses, built with clang (coverage, AddressSanitizer and UBSan: CMake option
# PROBECAST_FUZZ) and run for FUZZ_SECONDS each (default 30) from their corpora in
# tests/fuzz/corpus/HARNESS (seeds we wrote: glTF and GLB files, JSON bodies and viewer
# messages, .hdr and .exr images). The fuzzers work on a copy, so what they find stays out of
# the repository. A crash, a sanitizer report, a leak, an input slower than 10 s or one that
# takes more than 2.5 GiB fails the run (non-zero exit), with the input kept under the printed
# folder to reproduce it: build-fuzz/tests/fuzz_HARNESS FILE. deploy/test.sh runs this.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
build="${FUZZ_BUILD_DIR:-$root/build-fuzz}"
seconds="${FUZZ_SECONDS:-30}"
harnesses=(gltf api_json env_image)

CC=clang CXX=clang++ cmake -S "$root" -B "$build" -DPROBECAST_FUZZ=ON \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
targets=()
for h in "${harnesses[@]}"; do targets+=("fuzz_$h"); done
cmake --build "$build" -j"$(nproc)" --target "${targets[@]}" >/dev/null

work="$(mktemp -d "${TMPDIR:-/tmp}/probecast-fuzz.XXXXXX")"
# one harness per core at a time (each fuzzer is one process on one core): the same
# FUZZ_SECONDS each, in less wall time
fuzz_one() {
  local h="$1"
  mkdir -p "$work/$h/corpus" "$work/$h/found"
  cp "$root/tests/fuzz/corpus/$h/"* "$work/$h/corpus/"
  if "$build/tests/fuzz_$h" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2560 \
      -print_final_stats=1 -artifact_prefix="$work/$h/found/" "$work/$h/corpus" \
      >"$work/$h/log" 2>&1; then
    echo 0 >"$work/$h/status"
  else
    echo 1 >"$work/$h/status"
  fi
}
cores="$(nproc)"
for h in "${harnesses[@]}"; do
  while [ "$(jobs -rp | wc -l)" -ge "$cores" ]; do wait -n || true; done
  fuzz_one "$h" &
done
wait
status=0
for h in "${harnesses[@]}"; do
  if [ "$(cat "$work/$h/status" 2>/dev/null)" = 0 ]; then
    runs="$(grep -o 'stat::number_of_executed_units: [0-9]*' "$work/$h/log" | grep -o '[0-9]*$')"
    cov="$(grep -o 'cov: [0-9]*' "$work/$h/log" | tail -1)"
    echo "fuzz_$h: ${runs:-?} inputs in ${seconds} s, ${cov:-cov: ?}, nothing found"
  else
    echo "fuzz_$h: FAILED (inputs kept in $work/$h/found)"
    tail -n 60 "$work/$h/log"
    status=1
  fi
done
if [ $status -eq 0 ]; then rm -rf "$work"; fi
exit $status
