#!/usr/bin/env python3
# Writes builtin:hard:narrow-gap as a glTF file (usage: narrow_gap_gltf.py OUT.gltf) with a second
# camera, the first mirrored onto the lit side; used by tests/bench/results/h200/narrow_gap_sides.txt.
# narrow-gap as glTF (white 0.7, metallic 0, roughness 1), two cameras: 0 = the builtin's (dark side),
# 1 = the mirror of it on the lit side (x -> -x), looking at the wall's foot and the gap
import sys
from gltf_scene import box, write

tris = []
box(tris, (-4, 0, -2), (4, 3, 2), True)
box(tris, (-0.005, 0.25, -2), (0.005, 3, 2), False)
white = {"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1], "metallicFactor": 0, "roughnessFactor": 1}}
write(sys.argv[1], [(tris, 0)], [white],
      cameras=[((3.7, 1.6, 1.7), (-1, -0.45, -0.45)), ((-3.7, 1.6, 1.7), (1, -0.45, -0.45))],
      lights=[((-2, 1.2, 0), 40)])
