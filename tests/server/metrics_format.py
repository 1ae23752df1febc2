#!/usr/bin/env python3
"""/metrics is valid Prometheus text exposition (format 0.0.4), read by the Prometheus project's
own parser (Debian's python3-prometheus-client), with metric names in base units: seconds and
bytes, counters ending in _total, no milliseconds or bits.

usage: metrics_format.py PATH/TO/probecast"""
import re
import subprocess
import sys
import time
import urllib.request

from prometheus_client.parser import text_string_to_metric_families

failures = 0


def check(cond, what):
    global failures
    if not cond:
        failures += 1
        print("CHECK failed:", what, file=sys.stderr)


exe = sys.argv[1]
proc = subprocess.Popen(
    [exe, "serve", "--http", "127.0.0.1:0", "--ws", "127.0.0.1:0", "--width", "32", "--height",
     "24", "--probes", "2,2,2", "--rays", "16", "--no-animate", "--scene", "builtin:cornell"],
    stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
try:
    line = proc.stdout.readline()
    m = re.search(r"http=127\.0\.0\.1:(\d+)", line)
    check(m is not None, "serving line: " + line)
    port = int(m.group(1))
    deadline = time.monotonic() + 120
    while True:  # until the first frame, so the pass timings exist
        body = urllib.request.urlopen(f"http://127.0.0.1:{port}/metrics", timeout=30).read()
        body = body.decode()
        if re.search(r"^probecast_frames_rendered_total [1-9]", body, re.M) or \
                time.monotonic() > deadline:
            break
        time.sleep(0.2)
    families = list(text_string_to_metric_families(body))
    check(len(families) >= 20, f"{len(families)} metric families")
    names = set()
    for fam in families:
        for s in fam.samples:
            names.add(s.name)
            check(s.name.startswith("probecast_"), "prefix: " + s.name)
            check(not re.search(r"milli|_ms\b|bits", s.name), "base units: " + s.name)
            if fam.type == "counter":
                check(s.name.endswith("_total"), "counter ends in _total: " + s.name)
            check(s.value == s.value, "NaN in " + s.name)
    for want in ["probecast_uptime_seconds", "probecast_frame_gpu_seconds",
                 "probecast_pass_gpu_seconds", "probecast_jpeg_encode_seconds",
                 "probecast_stream_bandwidth_bytes_per_second", "probecast_world_ticks_total",
                 "probecast_probe_updates_total", "probecast_http_responses_total",
                 "probecast_resident_memory_bytes", "probecast_heap_in_use_bytes"]:
        check(want in names, "metric present: " + want)
finally:
    proc.terminate()
    rc = proc.wait(timeout=30)
    check(rc == 0, f"clean exit, status {rc}")
print(f"metrics_format: {failures} failed")
sys.exit(1 if failures else 0)
