#!/usr/bin/env bash
# All tests: install dependencies, build twice (-Werror release, and AddressSanitizer +
# UndefinedBehaviorSanitizer), fuzz every parser of untrusted bytes for 30 s each (clang,
# tests/fuzz/run.sh), and run every test once: the sanitizer build runs all but the slow ones,
# the release build those (labels converging and rerun). GPU tests run on lavapipe with the
# Vulkan validation layer on.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
"$root/deploy/install-deps.sh"
"$root/deploy/install-test-deps.sh"
"$root/deploy/install-web-test-deps.sh"
jobs="$(nproc)"

echo "== build (warnings are errors) =="
BUILD_DIR="$root/build-test" "$root/deploy/build.sh" -DPROBECAST_WERROR=ON -DPROBECAST_SANITIZE=OFF
echo "== build (AddressSanitizer + UBSan) =="
BUILD_DIR="$root/build-asan" "$root/deploy/build.sh" -DPROBECAST_WERROR=ON -DPROBECAST_SANITIZE=ON

status=0
echo "== fuzzing (clang, libFuzzer, ${FUZZ_SECONDS:-30} s per harness) =="
FUZZ_BUILD_DIR="$root/build-fuzz" "$root/tests/fuzz/run.sh" || status=1
echo "== tests: sanitizer build =="
# tests that converge probe fields (hundreds of lavapipe updates, 10-20x slower under ASan, see
# tests/CMakeLists.txt) and the serve tests rerun on the GPU JPEG path (label rerun) run once, in
# the release run below
(cd "$root/build-asan" && ctest --output-on-failure -j "$jobs" -LE "converging|rerun") || status=1
echo "== tests: release build (converging, rerun) =="
# the rest ran above, under the sanitizers; running it again here took minutes of the CI budget
(cd "$root/build-test" && ctest --output-on-failure -j "$jobs" -L "converging|rerun") || status=1
exit $status
