"""What the deploy tests (nginx_proxy.py, tls_direct.py) share: a CHECK counter, self-signed
certificates from openssl, and a minimal WebSocket client for the probecast stream over any
socket (plain or TLS)."""
import base64
import hashlib
import os
import struct
import subprocess
import sys

failures = 0
KEY = "dGhlIHNhbXBsZSBub25jZQ=="  # RFC 6455's sample key; the server's answer is checked


def check(cond, what):
    global failures
    if not cond:
        failures += 1
        print("CHECK failed:", what, file=sys.stderr)
    return cond


def make_cert(tmp, name, cn, san):
    """A self-signed certificate and its key in tmp: (cert path, key path)."""
    cert, key = os.path.join(tmp, name + "-cert.pem"), os.path.join(tmp, name + "-key.pem")
    subprocess.run(["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "2",
                    "-subj", "/CN=" + cn, "-addext", "subjectAltName=" + san,
                    "-keyout", key, "-out", cert], check=True, capture_output=True)
    return cert, key


def upgrade_request(host, origin, path="/v1/stream"):
    return (f"GET {path} HTTP/1.1\r\nHost: {host}\r\nOrigin: {origin}\r\n"
            "Upgrade: websocket\r\nConnection: Upgrade\r\n"
            f"Sec-WebSocket-Key: {KEY}\r\nSec-WebSocket-Version: 13\r\n"
            "Sec-WebSocket-Protocol: probecast.v2\r\n\r\n").encode()


class WsClient:
    """The client side of a stream connection on a connected socket s."""

    def __init__(self, s):
        self.s, self.buf = s, b""

    def handshake(self, request):
        """Sends the upgrade request; returns (status line, lower-case headers)."""
        self.s.sendall(request)
        while b"\r\n\r\n" not in self.buf:
            chunk = self.s.recv(4096)
            if not chunk:
                break
            self.buf += chunk
        head, _, self.buf = self.buf.partition(b"\r\n\r\n")
        lines = head.decode(errors="replace").split("\r\n")
        hdrs = {k.strip().lower(): v.strip() for k, _, v in (x.partition(":") for x in lines[1:])}
        return lines[0], hdrs

    @staticmethod
    def expected_accept():
        return base64.b64encode(hashlib.sha1(
            (KEY + "258EAFA5-E914-47DA-95CA-C5AB0DC85B11").encode()).digest()).decode()

    def _need(self, n):
        while len(self.buf) < n:
            chunk = self.s.recv(65536)
            if not chunk:
                raise EOFError("the stream closed")
            self.buf += chunk

    def next_message(self):
        """(opcode, payload) of the next whole message (fragments joined; control frames
        skipped)."""
        opcode, payload = None, b""
        while True:
            self._need(2)
            b = self.buf
            op, fin, length, hdr = b[0] & 0x0F, b[0] & 0x80, b[1] & 0x7F, 2
            if length == 126:
                self._need(4)
                length, hdr = struct.unpack(">H", self.buf[2:4])[0], 4
            elif length == 127:
                self._need(10)
                length, hdr = struct.unpack(">Q", self.buf[2:10])[0], 10
            self._need(hdr + length)
            data, self.buf = self.buf[hdr:hdr + length], self.buf[hdr + length:]
            if op >= 8:
                if op == 8:
                    raise EOFError(f"closed by the server: {data[2:]!r}")
                continue
            if op != 0:
                opcode = op
            payload += data
            if fin:
                return opcode, payload
