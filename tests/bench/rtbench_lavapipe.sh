#!/usr/bin/env bash
# rtbench_lavapipe: probecast_rtbench on lavapipe, which has no VK_KHR ray tracing: it must say
# "unsupported: <reason>", still trace our half (a row per ray set whose rays hit something),
# the 4-wide tracer and the two compressed 8-wide tracers (cwide, cwide2), whose hits must each
# agree with ours on over 99.9% of the rays, and exit 0.
# Usage: rtbench_lavapipe.sh PATH/TO/probecast_rtbench
set -u
exe="$1"
out="$(PROBECAST_DEVICE=llvmpipe PROBECAST_VALIDATION=1 "$exe" builtin:interior:0.05 \
    --size 48x27 --probes 4,2,4 --rays 16,8 2>&1)"
rc=$?
echo "$out"
fail() { echo "rtbench_lavapipe: $*" >&2; exit 1; }
[ "$rc" -eq 0 ] || fail "exit status $rc"
grep -q '^unsupported: .*VK_KHR' <<<"$out" || fail "no 'unsupported: <reason>' line"
# rows: rays, ours' time and a hit fraction above zero, driver columns '-', then for wide, cwide
# and cwide2: time, Grays/s, speed ratio and agreement with ours (the program also fails itself
# below 99.9%)
agreeing=' +[0-9.]+ +[0-9.]+ +[0-9.]+ +(99\.9[0-9]{3}|100\.0000)%'
for set in 'primary 48x27 +1296' 'probes 4x2x4 x16 +512' 'probes 4x2x4 x8 +256'; do
    grep -Eq "^builtin:interior:0.05 +[0-9]+ +${set} +[0-9.]+ +- .* ([1-9][0-9]?|100)\.[0-9]%${agreeing} ${agreeing} ${agreeing}$" \
        <<<"$out" || fail "no row for '$set' with hits and agreeing wide, cwide and cwide2 hits"
done
grep -Eq '^wide: 4-wide collapse .* [1-9][0-9]* nodes' <<<"$out" || fail "no wide collapse line"
grep -Eq '^cwide: compressed 8-wide collapse .* [1-9][0-9]* nodes of 80 bytes' <<<"$out" ||
    fail "no cwide collapse line"
grep -Eq '^node bytes: ours [1-9][0-9]*, wide [1-9][0-9]*, cwide [1-9][0-9]*$' <<<"$out" ||
    fail "no node bytes line"
for w in wide cwide cwide2; do
    [ "$(grep -Ec "^$w pays on .*: (yes|no) \($w/ours [0-9.]+\)\$" <<<"$out")" -eq 3 ] ||
        fail "no '$w pays' verdict per ray set"
done
