#!/usr/bin/env python3
"""probecast serve --tls-cert/--tls-key without a proxy, as an operator would run it: a self-signed
certificate, HTTPS requests to the API and the viewer (and plain http:// refused on that port), a
change from the page's https:// origin, and a protocol-2 stream over wss:// (welcome, then a binary
frame; plain ws:// refused). Also: a missing file, a lone flag, a file that is not PEM and a key of
another certificate each stop the daemon at start with status 2 and a sentence naming the problem;
SIGTERM stops it cleanly (status 0).

usage: tls_direct.py PATH/TO/probecast SOURCE_DIR"""
import http.client
import json
import os
import re
import shutil
import socket
import ssl
import struct
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import deploy_util  # noqa: E402
from deploy_util import WsClient, check, upgrade_request  # noqa: E402


def make_cert(tmp, name):
    return deploy_util.make_cert(tmp, name, "localhost", "DNS:localhost,IP:127.0.0.1")


exe, src = sys.argv[1], sys.argv[2]
tmp = tempfile.mkdtemp(prefix="probecast-tls-")
cert, key = make_cert(tmp, "server")
_, other_key = make_cert(tmp, "other")
garbage = os.path.join(tmp, "garbage.pem")
open(garbage, "w").write("this is not a certificate\n")
small = ["--width", "32", "--height", "24", "--probes", "2,2,2", "--rays", "16", "--no-animate",
         "--scene", "builtin:cornell", "--web-dir", os.path.join(src, "web")]


def start_fails(tls_args, pattern, what):
    """The daemon must stop at start with status 2 and a message matching pattern."""
    p = subprocess.run([exe, "serve", "--http", "127.0.0.1:0", "--ws", "127.0.0.1:0"] + small +
                       tls_args, capture_output=True, text=True, timeout=120)
    check(p.returncode == 2, f"{what}: exit status {p.returncode} (want 2)")
    check("probecast serving" not in p.stdout, f"{what}: it did not serve")
    check(re.search(pattern, p.stderr), f"{what}: the message names the problem: {p.stderr!r}")


missing = os.path.join(tmp, "missing-key.pem")
start_fails(["--tls-cert", cert, "--tls-key", missing],
            r"--tls-key file '" + re.escape(missing) + r"': No such file", "a missing key file")
start_fails(["--tls-cert", cert], r"--tls-cert needs --tls-key", "--tls-cert alone")
start_fails(["--tls-cert", garbage, "--tls-key", key],
            r"--tls-cert file '" + re.escape(garbage) + r"' holds no PEM certificate",
            "a certificate file that is not PEM")
start_fails(["--tls-cert", cert, "--tls-key", other_key],
            r"--tls-key file '" + re.escape(other_key) + r"' is not the private key of the "
            r"certificate", "a key of another certificate")

log = open(os.path.join(tmp, "daemon.log"), "w+")
daemon = subprocess.Popen(
    [exe, "serve", "--http", "127.0.0.1:0", "--ws", "127.0.0.1:0", "--tls-cert", cert,
     "--tls-key", key] + small, stdout=subprocess.PIPE, stderr=log, text=True)
try:
    line = daemon.stdout.readline()
    m = re.match(r"probecast serving https=127\.0\.0\.1:(\d+) wss=127\.0\.0\.1:(\d+)", line)
    if not check(m, f"the start-up line names https and wss: {line!r}"):
        raise SystemExit(1)
    api_port, ws_port = int(m.group(1)), int(m.group(2))
    check(f"open https://127.0.0.1:{api_port}/" in daemon.stdout.readline(),
          "the second line gives an https:// address")

    ctx = ssl.create_default_context(cafile=cert)  # trusts this certificate only
    ctx.check_hostname = True

    def request(method, path, body=None, headers=None):
        conn = http.client.HTTPSConnection("127.0.0.1", api_port, timeout=60, context=ctx)
        conn.request(method, path, body=body, headers=headers or {})
        r = conn.getresponse()
        data = r.read()
        conn.close()
        return r.status, data

    status, body = request("GET", "/v1/health")
    check(status == 200, f"HTTPS GET /v1/health: {status}")
    stream = json.loads(body or b"{}").get("stream", {})
    check(stream.get("tls") is True and stream.get("scheme") == "wss",
          f"health says the stream is wss: {stream}")
    check(stream.get("port") == ws_port and stream.get("http_port") == api_port,
          f"health names both ports: {stream}")

    # the same port does not answer plain HTTP
    plain_ok = False
    try:
        conn = http.client.HTTPConnection("127.0.0.1", api_port, timeout=20)
        conn.request("GET", "/v1/health")
        plain_ok = conn.getresponse().status == 200
        conn.close()
    except (OSError, http.client.HTTPException):
        pass
    check(not plain_ok, "plain http:// to the HTTPS port is not served")

    status, body = request("GET", "/")
    check(status == 200 and b"<html" in body.lower(), f"the viewer page over HTTPS: {status}")
    status, body = request("GET", "/js/main.js")
    check(status == 200 and b"wss:" in body, f"the viewer's script over HTTPS: {status}")
    status, body = request("PATCH", "/v1/settings", body=b'{"exposure":0.5}',
                           headers={"Content-Type": "application/json",
                                    "Origin": f"https://127.0.0.1:{api_port}"})
    check(status == 200, f"a change from the page's https:// origin: {status} {body[:200]}")

    # plain ws:// to the stream port gets no upgrade
    upgrade = upgrade_request(f"127.0.0.1:{ws_port}", f"https://127.0.0.1:{api_port}")
    answer = b""
    try:
        s = socket.create_connection(("127.0.0.1", ws_port), timeout=20)
        s.sendall(upgrade)
        answer = s.recv(4096)
        s.close()
    except OSError:
        pass
    check(not answer.startswith(b"HTTP/1.1 101"), f"plain ws:// is not upgraded: {answer[:60]!r}")

    def wss_session(port, where, upgrade):
        """wss:// with subprotocol probecast.v2: 101, a welcome text message, then a binary frame"""
        s = ctx.wrap_socket(socket.create_connection(("127.0.0.1", port), timeout=120),
                            server_hostname="127.0.0.1")
        ws = WsClient(s)
        status_line, hdrs = ws.handshake(upgrade)
        check(status_line.startswith("HTTP/1.1 101"),
              f"WebSocket upgrade over TLS {where}: {status_line}")
        check(hdrs.get("sec-websocket-protocol") == "probecast.v2",
              f"subprotocol probecast.v2 chosen: {hdrs.get('sec-websocket-protocol')}")
        check(hdrs.get("sec-websocket-accept") == WsClient.expected_accept(), "Sec-WebSocket-Accept")

        welcome = {}
        try:
            op, data = ws.next_message()
            welcome = json.loads(data) if op == 1 else {}
            check(welcome.get("type") == "welcome" and welcome.get("protocol") == 2,
                  f"welcome over wss {where}: opcode {op}, {data[:200]!r}")
            frame = None
            for _ in range(100):  # events may come first
                op, data = ws.next_message()
                if op == 2:
                    frame = data
                    break
            check(frame is not None, f"a binary frame over wss {where}")
            if frame:
                magic, version, header_size = struct.unpack_from("<IHH", frame, 0)
                view_id, width, height = struct.unpack_from("<III", frame, 40)
                jpeg_size = struct.unpack_from("<I", frame, 56)[0]
                check(magic == 0x52464350 and version == 2, f"frame header: {magic:#x} v{version}")
                check(view_id == welcome.get("view") and (width, height) == (32, 24),
                      f"the frame is of the own view at 32x24: view {view_id}, {width}x{height}")
                jpeg = frame[header_size:header_size + jpeg_size]
                check(len(jpeg) == jpeg_size and jpeg[:2] == b"\xff\xd8", "the frame holds a JPEG")
        except (EOFError, OSError, ValueError) as e:
            check(False, f"stream over wss {where}: {e}")
        s.sendall(bytes([0x88, 0x82]) + b"\0\0\0\0" + struct.pack(">H", 1000))  # close, masked
        s.close()

    wss_session(ws_port, "on the --ws port", upgrade)
    # one origin: the same stream at /v1/stream of the API's own https address
    wss_session(api_port, "at /v1/stream of the API's address",
                upgrade_request(f"127.0.0.1:{api_port}", f"https://127.0.0.1:{api_port}"))
finally:
    daemon.terminate()
    try:
        rc = daemon.wait(timeout=30)
    except subprocess.TimeoutExpired:
        daemon.kill()
        rc = daemon.wait()
    log.seek(0)
    err = log.read()
    log.close()
    check(rc == 0, f"daemon clean exit after SIGTERM, status {rc}")
    check("stopped cleanly" in err, "the log says it stopped cleanly")
    if deploy_util.failures:
        sys.stderr.write(err[-4000:])
    shutil.rmtree(tmp, ignore_errors=True)
print(f"tls_direct: {deploy_util.failures} failed")
sys.exit(1 if deploy_util.failures else 0)
