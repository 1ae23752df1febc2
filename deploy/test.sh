#!/usr/bin/env bash
# All tests: install dependencies, then build and run ctest twice: a -Werror build and an
# AddressSanitizer + UndefinedBehaviorSanitizer build. GPU tests run on lavapipe with the
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
echo "== tests: sanitizer build =="
# tests that converge probe fields (hundreds of lavapipe updates, 10-20x slower under ASan, see
# tests/CMakeLists.txt) and the serve tests rerun on the GPU JPEG path (label rerun) run once, in
# the release run below
(cd "$root/build-asan" && ctest --output-on-failure -j "$jobs" -LE "converging|rerun") || status=1
echo "== tests: release build =="
(cd "$root/build-test" && ctest --output-on-failure -j "$jobs") || status=1
exit $status
