#!/usr/bin/env python3
# Writes the lamp room as glTF (usage: lamp_room_gltf.py OUT.gltf): a closed 4 x 3 x 4 m room
# (white 0.7, metallic 0, roughness 1) with a point light of 8 cd inside an open, flared lamp shade
# (double-sided, base (0.9, 0.85, 0.7), roughness 1) in one corner, the shape of
# builtin:interior's lamps; the camera looks at the lamp from the opposite corner. The light leaves
# the shade through its two openings and, bounced off its inside, lights the room: DDGI probes see
# the shade from outside, so the field cannot hold that near-field light (probe_paths.txt).
import base64, json, math, struct, sys

tris = []

def quad(a, b, c, d):  # counter-clockwise seen from the front
    tris.append((a, b, c)); tris.append((a, c, d))

def box_inward(lo, hi):
    x0, y0, z0 = lo; x1, y1, z1 = hi
    P = lambda i, j, k: (x1 if i else x0, y1 if j else y0, z1 if k else z0)
    faces = [  # outward CCW, reversed below
        (P(0,0,0), P(0,0,1), P(0,1,1), P(0,1,0)), (P(1,0,0), P(1,1,0), P(1,1,1), P(1,0,1)),
        (P(0,0,0), P(1,0,0), P(1,0,1), P(0,0,1)), (P(0,1,0), P(0,1,1), P(1,1,1), P(1,1,0)),
        (P(0,0,0), P(0,1,0), P(1,1,0), P(1,0,0)), (P(0,0,1), P(1,0,1), P(1,1,1), P(0,1,1))]
    for f in faces:
        quad(f[3], f[2], f[1], f[0])

box_inward((-2, 0, -2), (2, 3, 2))
room_n = len(tris)
L = (1.2, 1.45, 1.2)
seg, rings = 32, 10
prof = []
for i in range(rings):  # the profile of procedural_interior.c's shade
    u = i / (rings - 1)
    prof.append((0.22 - 0.1 * u - 0.03 * math.sin(math.pi * u), 1.3 + 0.3 * u))
for i in range(rings - 1):
    for j in range(seg):
        t0 = 2 * math.pi * j / seg; t1 = 2 * math.pi * (j + 1) / seg
        (r0, y0), (r1, y1) = prof[i], prof[i + 1]
        pt = lambda r, y, t: (L[0] + r * math.cos(t), y, L[2] + r * math.sin(t))
        quad(pt(r0, y0, t0), pt(r0, y0, t1), pt(r1, y1, t1), pt(r1, y1, t0))

def sub(a, b): return [a[i] - b[i] for i in range(3)]
def cross(a, b): return [a[1]*b[2] - a[2]*b[1], a[2]*b[0] - a[0]*b[2], a[0]*b[1] - a[1]*b[0]]
pos = []; nrm = []
for t in tris:
    n = cross(sub(t[1], t[0]), sub(t[2], t[0])); l = math.sqrt(sum(x * x for x in n))
    for v in t: pos += v; nrm += [x / l for x in n]
pb = struct.pack('<%df' % len(pos), *pos); nb = struct.pack('<%df' % len(nrm), *nrm)
buf = pb + nb
n0 = room_n * 3; n1 = len(tris) * 3 - n0

def quat_look(fwd):  # rotation taking the camera's -z to fwd, +y up
    f = [x / math.sqrt(sum(y * y for y in fwd)) for x in fwd]
    z = [-x for x in f]
    x = cross([0, 1, 0], z); l = math.sqrt(sum(v * v for v in x)); x = [v / l for v in x]
    y = cross(z, x)
    m00, m01, m02 = x[0], y[0], z[0]; m10, m11, m12 = x[1], y[1], z[1]; m20, m21, m22 = x[2], y[2], z[2]
    tr = m00 + m11 + m22
    if tr > 0:
        s = math.sqrt(tr + 1) * 2; return [(m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, 0.25 * s]
    if m00 > m11 and m00 > m22:
        s = math.sqrt(1 + m00 - m11 - m22) * 2; return [0.25 * s, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s]
    if m11 > m22:
        s = math.sqrt(1 + m11 - m00 - m22) * 2; return [(m01 + m10) / s, 0.25 * s, (m12 + m21) / s, (m02 - m20) / s]
    s = math.sqrt(1 + m22 - m00 - m11) * 2; return [(m02 + m20) / s, (m12 + m21) / s, 0.25 * s, (m10 - m01) / s]

sp = pos[n0 * 3:]
g = {"asset": {"version": "2.0"}, "extensionsUsed": ["KHR_lights_punctual"],
     "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 8, "color": [1, 1, 1]}]}},
     "scene": 0, "scenes": [{"nodes": [0, 1, 2]}],
     "nodes": [{"mesh": 0},
               {"camera": 0, "translation": [-1.8, 1.7, -1.8], "rotation": quat_look([1, -0.1, 1])},
               {"translation": list(L), "extensions": {"KHR_lights_punctual": {"light": 0}}}],
     "cameras": [{"type": "perspective", "perspective": {"yfov": 70 * math.pi / 180, "znear": 0.01}}],
     "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1], "metallicFactor": 0, "roughnessFactor": 1}},
                   {"doubleSided": True, "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.85, 0.7, 1], "metallicFactor": 0, "roughnessFactor": 1}}],
     "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "material": 0},
                                {"attributes": {"POSITION": 2, "NORMAL": 3}, "material": 1}]}],
     "accessors": [
         {"bufferView": 0, "componentType": 5126, "count": n0, "type": "VEC3", "min": [-2, 0, -2], "max": [2, 3, 2]},
         {"bufferView": 1, "componentType": 5126, "count": n0, "type": "VEC3"},
         {"bufferView": 2, "componentType": 5126, "count": n1, "type": "VEC3",
          "min": [min(sp[i::3]) for i in range(3)], "max": [max(sp[i::3]) for i in range(3)]},
         {"bufferView": 3, "componentType": 5126, "count": n1, "type": "VEC3"}],
     "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": n0 * 12},
                     {"buffer": 0, "byteOffset": len(pb), "byteLength": n0 * 12},
                     {"buffer": 0, "byteOffset": n0 * 12, "byteLength": n1 * 12},
                     {"buffer": 0, "byteOffset": len(pb) + n0 * 12, "byteLength": n1 * 12}],
     "buffers": [{"byteLength": len(buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}]}
json.dump(g, open(sys.argv[1], 'w'))
