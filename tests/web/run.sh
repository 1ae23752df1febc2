#!/usr/bin/env bash
# Browser tests of the viewer (web/): starts `probecast serve` (the executable given as $1) on
# free loopback ports with a tiny render size and a scratch --data-dir, runs
# `node --test viewer.test.mjs` against it in Debian's headless Chromium (playwright-core), then
# stops the daemon; beside it `node --test scene.test.mjs` and then `video.test.mjs`, which run
# daemons of their own.
# viewer.test.mjs imports the topic files under viewer/ (stream, camera, panels, layout, views,
# daemon) in order: they are one session in one process on one page. The viewer tests
# themselves kill and restart the daemon (same ports and data dir), so the daemon's pid lives in
# a file both read.
#
# Exit status: the tests' (0 = pass). A missing piece (Chromium, Node.js 18 or newer,
# tests/web/node_modules as the lock file pins it) is a failure, not a skip: the install step,
# deploy/install-web-test-deps.sh, installs all of them, so a run without them is a broken set-up
# that must not pass quietly. The only skip is asked for: PROBECAST_SKIP_WEB_TESTS=1 exits 77
# (ctest SKIP_RETURN_CODE), for a machine that cannot run a browser.
# Screenshots and the daemon's log go to $PROBECAST_WEB_OUT (default: ./test-output/web of the
# working directory, i.e. the build folder under ctest).
set -euo pipefail

if [ $# -lt 1 ]; then
  echo "usage: $0 PATH/TO/probecast" >&2
  exit 2
fi
exe="$(cd "$(dirname "$1")" && pwd)/$(basename "$1")"
here="$(cd "$(dirname "$0")" && pwd -P)"
root="$(cd "$here/../.." && pwd)"
chromium="${PROBECAST_CHROMIUM:-/usr/bin/chromium}"

if [ "${PROBECAST_SKIP_WEB_TESTS:-0}" = 1 ]; then
  echo "SKIP: PROBECAST_SKIP_WEB_TESTS=1"
  exit 77
fi
missing() {
  echo "error: $1: run deploy/install-web-test-deps.sh (or set PROBECAST_SKIP_WEB_TESTS=1 to skip the browser tests)" >&2
  exit 1
}
[ -x "$chromium" ] || missing "$chromium is missing"
command -v node >/dev/null 2>&1 || missing "node is missing"
node_major="$(node -p 'process.versions.node.split(".")[0]')"
[ "$node_major" -ge 18 ] || missing "the tests need Node.js 18 or newer, found $(node --version)"
# The installed driver is the one the lock file pins (npm ci runs again when the lock changes).
want="$(node -p 'require(process.argv[1]).packages["node_modules/playwright-core"].version' "$here/package-lock.json")"
have="$(node -p 'require(process.argv[1]).version' "$here/node_modules/playwright-core/package.json" 2>/dev/null || true)"
[ -n "$have" ] || missing "tests/web/node_modules/playwright-core is missing"
[ "$have" = "$want" ] || missing "tests/web/node_modules has playwright-core $have, the lock file pins $want"
if [ ! -x "$exe" ]; then
  echo "error: $exe is not an executable" >&2
  exit 2
fi

out="${PROBECAST_WEB_OUT:-$PWD/test-output/web}"
mkdir -p "$out"
rm -f "$out"/*.png "$out"/daemon*.log
scratch="$(mktemp -d "${TMPDIR:-/tmp}/probecast-web.XXXXXX")"
pidfile="$scratch/daemon.pid"

# A pid is alive while /proc has it and it is not a zombie (an orphan that nobody reaped yet
# has let go of its ports already).
alive() {
  [ -n "$1" ] && [ -r "/proc/$1/stat" ] && ! grep -q '^[0-9]* (.*) Z ' "/proc/$1/stat" 2>/dev/null
}

stop_daemon() {
  local pid
  pid="$(cat "$pidfile" 2>/dev/null || true)"
  if alive "$pid"; then
    kill -TERM "$pid" 2>/dev/null || true
    for _ in $(seq 1 100); do alive "$pid" || break; sleep 0.1; done
    if alive "$pid"; then
      echo "the daemon did not stop within 10 s of SIGTERM; killing it" >&2
      kill -KILL "$pid" 2>/dev/null || true
    fi
  fi
}
cleanup() {
  stop_daemon
  if [ -n "${others_pid:-}" ] && alive "$others_pid"; then
    pkill -TERM -P "$others_pid" 2>/dev/null || true
    kill -TERM "$others_pid" 2>/dev/null || true
  fi
  rm -rf "$scratch"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# Render small whatever the browser window: lavapipe shares these two cores with Chromium. The
# test caps max_pixels at 15360, so the 960x600 page asks for 156x97, the size started with here:
# the render size does not change while frames are in flight (see viewer/session.mjs, RENDER).
# A low hysteresis lets the probes settle within a second after each change.
args=(serve --http 127.0.0.1:0 --ws 127.0.0.1:0 --width 156 --height 97 --probes 4,4,4 --rays 16
      --hysteresis 0.5 --no-animate --encoders 1 --max-fps 20 --data-dir "$scratch/data" --web-dir "$root/web")

# The subshell waits for the daemon, so it is reaped as soon as the test kills it.
( "$exe" "${args[@]}" >"$scratch/stdout" 2>>"$out/daemon.log" &
  echo $! >"$pidfile"
  wait $! || true ) &

line=""
for _ in $(seq 1 600); do
  line="$(head -n 1 "$scratch/stdout" 2>/dev/null || true)"
  case "$line" in *" ws="*) break ;; esac
  if [ -s "$pidfile" ] && ! alive "$(cat "$pidfile")"; then break; fi
  sleep 0.1
done
case "$line" in
  "probecast serving http="*" ws="*) ;;
  *)
    echo "error: the daemon did not start; its log:" >&2
    tail -n 30 "$out/daemon.log" >&2 || true
    exit 1
    ;;
esac
http="${line#probecast serving http=}"
http="${http%% *}"
ws="${line##* ws=}"
echo "daemon: http=$http ws=$ws (pid $(cat "$pidfile"), log $out/daemon.log)"

# The same command with the bound ports, for the test's restart.
restart_args=()
for a in "${args[@]}"; do
  case "$a" in
    127.0.0.1:0) if [ ${#restart_args[@]} -gt 0 ] && [ "${restart_args[-1]}" = "--http" ]; then a="$http"; else a="$ws"; fi ;;
  esac
  restart_args+=("$a")
done

# The scene tests (node tree, picking, gizmo, multi-file uploads) and the video path (WebCodecs
# VP9 decode into the canvas) start daemons of their own: they run one after the other beside the
# viewer session (each session waits on its browser and daemon most of the time: a quarter of
# two cores), their report printed after it. In turn the three took 120 s of CI's wall time.
others() {
  local st=0
  cd "$here"
  export PCWEB_EXE="$exe" PCWEB_OUT="$out" PCWEB_CHROMIUM="$chromium" PCWEB_ROOT="$root"
  node --test --test-reporter=spec scene.test.mjs || st=1
  node --test --test-reporter=spec video.test.mjs || st=1
  return $st
}
others >"$scratch/others.log" 2>&1 &
others_pid=$!

status=0
(
  cd "$here"
  export PCWEB_HTTP="$http" PCWEB_WS="$ws" PCWEB_PIDFILE="$pidfile" PCWEB_EXE="$exe" PCWEB_OUT="$out"
  export PCWEB_CHROMIUM="$chromium" PCWEB_ROOT="$root"
  PCWEB_ARGS="$(node -e 'process.stdout.write(JSON.stringify(process.argv.slice(1)))' -- "${restart_args[@]}")"
  export PCWEB_ARGS
  node --test --test-reporter=spec viewer.test.mjs
) || status=$?
wait "$others_pid" || status=1
cat "$scratch/others.log"

stop_daemon
exit $status
