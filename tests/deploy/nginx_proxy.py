#!/usr/bin/env python3
"""deploy/nginx/probecast.conf in front of a running daemon, as an operator would deploy it: a
self-signed certificate, nginx terminating TLS on one origin, HTTPS requests to the API and the
viewer, and a WebSocket stream (protocol v2) through the same origin. Also: a foreign Host through
the proxy is refused by the daemon.

usage: nginx_proxy.py PATH/TO/probecast SOURCE_DIR"""
import http.client
import json
import os
import shutil
import socket
import ssl
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import deploy_util  # noqa: E402
from deploy_util import WsClient, check, upgrade_request  # noqa: E402


def free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


exe, src = sys.argv[1], sys.argv[2]
nginx = shutil.which("nginx") or "/usr/sbin/nginx"
tmp = tempfile.mkdtemp(prefix="probecast-nginx-")
name = "render.test"
cert, key = deploy_util.make_cert(tmp, "server", name, "DNS:" + name)

api_port, tls_port = free_port(), free_port()
daemon = subprocess.Popen(
    [exe, "serve", "--http", f"127.0.0.1:{api_port}", "--public-name", name, "--width", "32", "--height", "24", "--probes", "2,2,2", "--rays", "16",
     "--no-animate", "--scene", "builtin:cornell", "--web-dir", os.path.join(src, "web")],
    stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
proc = None
try:
    check("probecast serving" in daemon.stdout.readline(), "daemon started")
    # the shipped configuration, pointed at this daemon, certificate and port
    conf = open(os.path.join(src, "deploy/nginx/probecast.conf")).read()
    conf = conf.replace("127.0.0.1:8080", f"127.0.0.1:{api_port}")
    conf = conf.replace("listen 443 ssl;", f"listen 127.0.0.1:{tls_port} ssl;")
    conf = conf.replace("/etc/probecast/tls/cert.pem", cert).replace("/etc/probecast/tls/key.pem", key)
    conf = conf.replace("render.example.org", name)
    check(f"127.0.0.1:{api_port}" in conf and cert in conf, "configuration adapted")
    open(os.path.join(tmp, "site.conf"), "w").write(conf)
    main = f"""pid {tmp}/nginx.pid;
error_log {tmp}/error.log;
daemon off;
events {{ worker_connections 64; }}
http {{
    access_log off;
    client_body_temp_path {tmp}/body;
    proxy_temp_path {tmp}/proxy;
    fastcgi_temp_path {tmp}/fastcgi;
    uwsgi_temp_path {tmp}/uwsgi;
    scgi_temp_path {tmp}/scgi;
    include {tmp}/site.conf;
}}
"""
    open(os.path.join(tmp, "nginx.conf"), "w").write(main)
    proc = subprocess.Popen([nginx, "-p", tmp, "-c", os.path.join(tmp, "nginx.conf")],
                            stderr=subprocess.PIPE, text=True)
    for _ in range(100):
        try:
            socket.create_connection(("127.0.0.1", tls_port), timeout=1).close()
            break
        except OSError:
            time.sleep(0.1)

    ctx = ssl.create_default_context(cafile=cert)
    ctx.check_hostname = True

    def request(method, path, body=None, headers=None, host=name):
        conn = http.client.HTTPSConnection("127.0.0.1", tls_port, timeout=60, context=ctx)
        # TLS for render.test while connecting to 127.0.0.1
        conn.sock = ctx.wrap_socket(socket.create_connection(("127.0.0.1", tls_port), timeout=60),
                                    server_hostname=name)
        h = {"Host": host}
        h.update(headers or {})
        conn.request(method, path, body=body, headers=h)
        r = conn.getresponse()
        data = r.read()
        conn.close()
        return r.status, data

    status, body = request("GET", "/v1/health")
    check(status == 200, f"health through the proxy: {status}")
    health = json.loads(body or b"{}")
    check(health.get("stream", {}).get("http_port") == api_port, "health names the API port")
    status, body = request("GET", "/")
    check(status == 200 and b"<html" in body.lower(), f"the viewer page: {status}")
    status, body = request("PATCH", "/v1/settings", body=b'{"exposure":0.5}',
                           headers={"Content-Type": "application/json",
                                    "Origin": "https://" + name})
    check(status == 200, f"a change from the proxied page's origin: {status} {body[:200]}")
    status, _ = request("GET", "/v1/scene", host="evil.example")
    check(status == 403, f"a foreign Host through the proxy is refused: {status}")

    # the stream on the same origin, through the proxy's WebSocket upgrade
    s = ctx.wrap_socket(socket.create_connection(("127.0.0.1", tls_port), timeout=60),
                        server_hostname=name)
    ws = WsClient(s)
    status_line, _ = ws.handshake(upgrade_request(name, f"https://{name}"))
    check(status_line.startswith("HTTP/1.1 101"), "WebSocket upgrade through the proxy: " + status_line)
    # the first message is the welcome (a text frame)
    try:
        opcode, payload = ws.next_message()
        msg = json.loads(payload) if opcode == 1 else {}
    except (EOFError, OSError, ValueError) as e:
        opcode, msg = None, {"error": str(e)}
    check(msg.get("type") == "welcome" and msg.get("protocol") == 2,
          f"welcome over wss: opcode {opcode}, {msg}")
    s.close()
finally:
    if proc:
        proc.terminate()
        proc.wait(timeout=30)
    daemon.terminate()
    rc = daemon.wait(timeout=30)
    check(rc == 0, f"daemon clean exit, status {rc}")
    shutil.rmtree(tmp, ignore_errors=True)
print(f"nginx_proxy: {deploy_util.failures} failed")
sys.exit(1 if deploy_util.failures else 0)
