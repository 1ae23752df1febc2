#!/usr/bin/env bash
# Soak benchmark: `probecast serve` at a tiny size with 10 viewers of their own views
# (probecast_loadtest) and an API writer (camera, light and settings changes, a light added and
# removed, several a second) for a while; the daemon's resident memory is sampled every few
# seconds. A benchmark, not a test: it prints a table and writes files; look for growth.
#
#   tests/bench/soak.sh BIN_DIR OUT_DIR [SECONDS] [-- extra serve options]
#
# BIN_DIR holds probecast and probecast_loadtest; OUT_DIR gets soak_rss.csv (seconds, RSS in
# KiB, frames rendered, requests, and the C heap from /v1/stats: KiB in use and KiB free but
# kept), soak.txt (the table and the viewers' summary) and serve.log. SOAK_WRITER=0 leaves the
# API writer out (viewers only).
# Default: 600 seconds (the issue's 10 minutes), lavapipe when no GPU is present. Needs curl and
# python3 besides the build.
set -euo pipefail
bin=$1 out=$2
seconds=${3:-600}
shift $(($# < 3 ? $# : 3))
[ "${1:-}" = "--" ] && shift
mkdir -p "$out"
port=18180
"$bin/probecast" serve --http 127.0.0.1:$port --width 64 --height 48 --probes 4,2,4 --rays 32 \
    --max-fps 30 --max-viewers-per-ip 64 --no-animate --scene builtin:cornell "$@" \
    >"$out/serve.log" 2>&1 &
pid=$!
writer=""
viewers=""
cleanup() {
    [ -n "$writer" ] && kill "$writer" 2>/dev/null
    [ -n "$viewers" ] && kill "$viewers" 2>/dev/null
    kill "$pid" 2>/dev/null
    wait 2>/dev/null || true
}
trap cleanup EXIT
for _ in $(seq 600); do
    (exec 3<>/dev/tcp/127.0.0.1/$port) 2>/dev/null && break
    sleep 0.2
done

api() { curl -s -o /dev/null -w '%{http_code}' -X "$1" -H 'Content-Type: application/json' \
        ${3:+--data "$3"} "http://127.0.0.1:$port$2"; }

# the viewers: 10 own views for the whole run (frames acknowledged, latency measured)
"$bin/probecast_loadtest" --http 127.0.0.1:$port --mode own --sizes 64x48 --viewers 10 \
    --seconds "$seconds" --warmup 1 --csv "$out/soak_viewers.csv" >"$out/soak_viewers.txt" 2>&1 &
viewers=$!

# the writer: a change every 200 ms, cycling through the kinds of change
if [ "${SOAK_WRITER:-1}" != 0 ]; then
(
    i=0
    while :; do
        x=$(awk -v i=$i 'BEGIN { printf "%.3f", sin(i / 10) * 1.5 }')
        case $((i % 5)) in
        0) api PATCH /v1/camera "{\"position\":[$x,1,3.9],\"target\":[0,1,0]}" >/dev/null ;;
        1) api PATCH /v1/lights/0 "{\"intensity\":$(awk -v i=$i 'BEGIN { print 2 + (i % 7) / 3 }')}" >/dev/null ;;
        2) api PATCH /v1/settings "{\"exposure\":$(awk -v i=$i 'BEGIN { print (i % 5) / 10 }')}" >/dev/null ;;
        3) api POST /v1/lights '{"type":"point","position":[0.5,1.5,0.5],"intensity":0.5}' >/dev/null ;;
        4) id=$(curl -s "http://127.0.0.1:$port/v1/lights" |
                python3 -c 'import json,sys; l=json.load(sys.stdin)["lights"]; print(l[-1]["id"] if len(l) > 1 else "")')
           [ -n "$id" ] && api DELETE "/v1/lights/$id" >/dev/null ;;
        esac
        i=$((i + 1))
        sleep 0.2
    done
) 2>/dev/null &
writer=$!
fi

printf '%8s %10s %10s %10s %10s %10s\n' seconds rss_kib frames requests heap_kib free_kib |
    tee "$out/soak.txt"
echo "seconds,rss_kib,frames,requests,heap_in_use_kib,heap_free_kib" >"$out/soak_rss.csv"
start=$(date +%s)
while :; do
    now=$(($(date +%s) - start))
    rss=$(awk '/^VmRSS:/ { print $2 }' "/proc/$pid/status" 2>/dev/null || echo 0)
    stats=$(curl -s "http://127.0.0.1:$port/v1/stats" || echo '{}')
    read -r frames reqs heap free <<<"$(echo "$stats" | python3 -c '
import json, sys
s = json.load(sys.stdin); m = s.get("memory", {})
print(s.get("frames_rendered", 0), s.get("http", {}).get("requests", 0),
      m.get("heap_in_use_bytes", 0) // 1024, m.get("heap_free_bytes", 0) // 1024)' 2>/dev/null ||
        echo 0 0 0 0)"
    printf '%8d %10d %10s %10s %10s %10s\n' "$now" "$rss" "$frames" "$reqs" "$heap" "$free" |
        tee -a "$out/soak.txt"
    echo "$now,$rss,$frames,$reqs,$heap,$free" >>"$out/soak_rss.csv"
    [ "$now" -ge "$seconds" ] && break
    sleep "${SOAK_SAMPLE_S:-10}"
done
wait "$viewers" 2>/dev/null || true
viewers=""
cat "$out/soak_viewers.txt" >>"$out/soak.txt"
first=$(sed -n 2p "$out/soak_rss.csv" | cut -d, -f2)
mid=$(awk -F, -v h=$((seconds / 2)) 'NR > 1 && $1 >= h { print $2; exit }' "$out/soak_rss.csv")
last=$(tail -n 1 "$out/soak_rss.csv" | cut -d, -f2)
echo "resident memory: ${first} KiB at the start, ${mid} KiB half way, ${last} KiB at the end" |
    tee -a "$out/soak.txt"
