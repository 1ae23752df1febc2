#!/usr/bin/env bash
# Streaming benchmark with one view per viewer: starts `probecast serve` on the demo scene (its
# light animated, so the shared world keeps advancing), runs probecast_loadtest in its own-view
# mode and keeps the daemon's log. A benchmark, not a test.
#
#   tests/bench/stream_views.sh BIN_DIR OUT_DIR [SIZES] [VIEWERS] [-- extra serve options]
#
# BIN_DIR holds probecast and probecast_loadtest; results go to OUT_DIR (stream_views.csv, the
# printed table in stream_views.txt, serve.log). Defaults: 1280x720,1920x1080 and 1,10,50 viewers.
set -euo pipefail
bin=$1 out=$2
sizes=${3:-1280x720,1920x1080}
viewers=${4:-1,10,50}
shift $(($# < 4 ? $# : 4))
[ "${1:-}" = "--" ] && shift
mkdir -p "$out"
"$bin/probecast" serve --http 127.0.0.1:18080 --ws 127.0.0.1:18081 --max-views 64 \
    --max-total-pixels 120000000 --max-viewers 200 --max-viewers-per-ip 200 \
    --encoders "$(nproc)" --max-fps 240 "$@" >"$out/serve.log" 2>&1 &
pid=$!
trap 'kill $pid 2>/dev/null; wait $pid 2>/dev/null || true' EXIT
for _ in $(seq 300); do
    (exec 3<>/dev/tcp/127.0.0.1/18080) 2>/dev/null && break
    sleep 0.2
done
"$bin/probecast_loadtest" --http 127.0.0.1:18080 --ws 127.0.0.1:18081 --mode own \
    --sizes "$sizes" --viewers "$viewers" --seconds "${SECONDS_PER_RUN:-6}" --warmup 2 \
    --csv "$out/stream_views.csv" | tee "$out/stream_views.txt"
