#!/usr/bin/env bash
# The ctest test systemd_unit: deploy/systemd/probecast.service as systemd itself reads it
# (systemd-analyze verify; no running systemd needed). verify exits 0 on settings it ignores
# (an unknown key, a value it cannot parse), so any message fails the test too.
# Usage: systemd_verify.sh PROBECAST_BINARY ROOT
# verify checks that ExecStart's program exists: the unit is verified from a copy whose
# /usr/local/bin/probecast (where the unit expects the installed binary) is the one just built.
set -euo pipefail
bin="${1:?usage: systemd_verify.sh PROBECAST_BINARY ROOT}"
root="${2:?usage: systemd_verify.sh PROBECAST_BINARY ROOT}"
command -v systemd-analyze >/dev/null 2>&1 ||
  { echo "FAIL: systemd-analyze not found: run deploy/install-test-deps.sh" >&2; exit 1; }
[ -x "$bin" ] || { echo "FAIL: $bin is not an executable" >&2; exit 1; }
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
sed "s#/usr/local/bin/probecast#$bin#g" "$root/deploy/systemd/probecast.service" >"$dir/probecast.service"
set +e
out="$(systemd-analyze verify --man=no "$dir/probecast.service" 2>&1)"
rc=$?
set -e
[ -n "$out" ] && printf '%s\n' "$out" >&2
if [ $rc -ne 0 ] || [ -n "$out" ]; then
  echo "FAIL: systemd-analyze verify deploy/systemd/probecast.service (exit $rc)" >&2
  exit 1
fi
echo "deploy/systemd/probecast.service: verified"
