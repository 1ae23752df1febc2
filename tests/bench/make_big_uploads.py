#!/usr/bin/env python3
# The large uploads of tests/bench/upload_stall.sh: a 2-million-triangle grid with a point light
# as .glb (1001 x 1001 vertices, gently waved; 36 MB) and a 4096 x 2048 run-length .hdr of noisy
# grey texels (34 MB).  usage: make_big_uploads.py OUT.glb OUT.hdr
import json
import math
import random
import struct
import sys
n = 1001
pos = bytearray()
for j in range(n):
    for i in range(n):
        x = i / (n - 1) * 4 - 2; z = j / (n - 1) * 4 - 2
        pos += struct.pack('<3f', x, 0.05 * math.sin(7 * x) * math.cos(5 * z), z)
idx = bytearray()
for j in range(n - 1):
    for i in range(n - 1):
        a = j * n + i
        idx += struct.pack('<6I', a, a + n, a + 1, a + 1, a + n, a + n + 1)
binary = bytes(pos) + bytes(idx)
doc = {"asset": {"version": "2.0"}, "buffers": [{"byteLength": len(binary)}],
       "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(pos)},
                       {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx)}],
       "accessors": [{"bufferView": 0, "componentType": 5126, "count": n * n, "type": "VEC3",
                      "min": [-2, -0.05, -2], "max": [2, 0.05, 2]},
                     {"bufferView": 1, "componentType": 5125, "count": len(idx) // 4, "type": "SCALAR"}],
       "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
       "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}],
       "extensionsUsed": ["KHR_lights_punctual"],
       "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 50}]}}}
doc["nodes"].append({"translation": [0, 2, 0], "extensions": {"KHR_lights_punctual": {"light": 0}}})
doc["scenes"][0]["nodes"].append(1)
js = json.dumps(doc).encode()
js += b' ' * ((4 - len(js) % 4) % 4)
binary += b'\0' * ((4 - len(binary) % 4) % 4)
glb = struct.pack('<III', 0x46546C67, 2, 12 + 8 + len(js) + 8 + len(binary))
glb += struct.pack('<II', len(js), 0x4E4F534A) + js + struct.pack('<II', len(binary), 0x004E4942) + binary
open(sys.argv[1], 'wb').write(glb)
w, h = 4096, 2048
out = bytearray(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (h, w))
random.seed(1)
for y in range(h):
    out += bytes([2, 2, w >> 8, w & 255])
    for c in range(4):
        row = bytes([random.randrange(100, 140) if c < 3 else 128 for _ in range(w)])
        x = 0
        while x < w:
            k = min(128, w - x)
            out += bytes([k]) + row[x:x + k]
            x += k
open(sys.argv[2], 'wb').write(out)
