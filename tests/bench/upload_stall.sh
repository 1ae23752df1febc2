#!/usr/bin/env bash
# Do large uploads stall the views? (issue 30, item 1) `probecast serve` with DamagedHelmet-sized
# content and VIEWERS own-camera viewers (probecast_loadtest) for SECONDS; a run without uploads,
# then runs with one upload 8 s in: a 2-million-triangle .glb, a 4096 x 2048 .hdr environment
# (tests/bench/make_big_uploads.py writes both). Prints the viewers' input-to-frame p50, p99 and
# max per run; the target is a max within two frame intervals of the run without uploads.
#
#   tests/bench/upload_stall.sh BIN_DIR OUT_DIR SCENE.glb [VIEWERS] [SIZE] [SECONDS]
#
# BIN_DIR holds probecast and probecast_loadtest. Needs curl and python3.
set -euo pipefail
bin=$1 out=$2 scene=$3 viewers=${4:-10} size=${5:-1280x720} seconds=${6:-30}
here="$(cd "$(dirname "$0")" && pwd)"
mkdir -p "$out"
python3 "$here/make_big_uploads.py" "$out/big.glb" "$out/big.hdr"
port=18200
run() { # label, what to upload (none, glb, hdr)
    "$bin/probecast" serve --http 127.0.0.1:$port --scene "$scene" --max-viewers-per-ip 200 \
        >"$out/serve_$1.log" 2>&1 &
    local pid=$!
    for _ in $(seq 100); do curl -s -o /dev/null "http://127.0.0.1:$port/v1/health" && break; sleep 0.2; done
    "$bin/probecast_loadtest" --http 127.0.0.1:$port --mode own --sizes "$size" --viewers "$viewers" \
        --seconds "$seconds" --warmup 3 --csv "$out/lat_$1.csv" >"$out/lat_$1.txt" 2>&1 &
    local lt=$!
    sleep 8
    case $2 in
    glb) curl -s -o /dev/null -w "  upload big.glb: %{http_code} in %{time_total} s\n" -X PUT \
             -H 'Content-Type: model/gltf-binary' --data-binary @"$out/big.glb" \
             "http://127.0.0.1:$port/v1/scene" ;;
    hdr) curl -s -o /dev/null -w "  upload big.hdr: %{http_code} in %{time_total} s\n" -X PUT \
             -H 'Content-Type: image/vnd.radiance' --data-binary @"$out/big.hdr" \
             "http://127.0.0.1:$port/v1/environment" ;;
    esac
    wait $lt
    kill $pid
    wait $pid 2>/dev/null || true
    echo "$1: $(tail -n +2 "$out/lat_$1.csv" | awk -F, '{printf "p50 %s ms, p99 %s ms, max %s ms, %s fps per viewer", $9, $10, $11, $6}')"
}
run none none
run glb glb
run hdr hdr
