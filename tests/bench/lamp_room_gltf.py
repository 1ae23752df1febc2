#!/usr/bin/env python3
# Writes the lamp room as glTF (usage: lamp_room_gltf.py OUT.gltf): a closed 4 x 3 x 4 m room
# (white 0.7, metallic 0, roughness 1) with a point light of 8 cd inside an open, flared lamp shade
# (double-sided, base (0.9, 0.85, 0.7), roughness 1) in one corner, the shape of
# builtin:interior's lamps; the camera looks at the lamp from the opposite corner. The light leaves
# the shade through its two openings and, bounced off its inside, lights the room: DDGI probes see
# the shade from outside, so the field cannot hold that near-field light (probe_paths.txt).
import math, sys
from gltf_scene import box, quad, write

room = []
box(room, (-2, 0, -2), (2, 3, 2), True)
L = (1.2, 1.45, 1.2)
seg, rings = 32, 10
prof = []
for i in range(rings):  # the profile of procedural_interior.c's shade
    u = i / (rings - 1)
    prof.append((0.22 - 0.1 * u - 0.03 * math.sin(math.pi * u), 1.3 + 0.3 * u))
shade = []
pt = lambda r, y, t: (L[0] + r * math.cos(t), y, L[2] + r * math.sin(t))
for i in range(rings - 1):
    for j in range(seg):
        t0 = 2 * math.pi * j / seg; t1 = 2 * math.pi * (j + 1) / seg
        (r0, y0), (r1, y1) = prof[i], prof[i + 1]
        quad(shade, pt(r0, y0, t0), pt(r0, y0, t1), pt(r1, y1, t1), pt(r1, y1, t0))
write(sys.argv[1], [(room, 0), (shade, 1)],
      [{"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1], "metallicFactor": 0, "roughnessFactor": 1}},
       {"doubleSided": True,
        "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.85, 0.7, 1], "metallicFactor": 0, "roughnessFactor": 1}}],
      cameras=[((-1.8, 1.7, -1.8), (1, -0.1, 1))], lights=[(L, 8)])
