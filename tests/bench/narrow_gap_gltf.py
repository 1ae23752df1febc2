#!/usr/bin/env python3
# Writes builtin:hard:narrow-gap as a glTF file (usage: narrow_gap_gltf.py OUT.gltf) with a second
# camera, the first mirrored onto the lit side; used by tests/bench/results/h200/narrow_gap_sides.txt.
# narrow-gap as glTF (white 0.7, metallic 0, roughness 1), two cameras: 0 = the builtin's (dark side),
# 1 = the mirror of it on the lit side (x -> -x), looking at the wall's foot and the gap
import json, struct, base64, math, sys
tris = []
def quad(a, b, c, d):  # counter-clockwise seen from the front
    tris.append((a, b, c)); tris.append((a, c, d))
def box(lo, hi, inward):
    x0,y0,z0 = lo; x1,y1,z1 = hi
    P = lambda i,j,k: (x1 if i else x0, y1 if j else y0, z1 if k else z0)
    faces = [  # outward CCW
        (P(0,0,0),P(0,0,1),P(0,1,1),P(0,1,0)),  # -x
        (P(1,0,0),P(1,1,0),P(1,1,1),P(1,0,1)),  # +x
        (P(0,0,0),P(1,0,0),P(1,0,1),P(0,0,1)),  # -y
        (P(0,1,0),P(0,1,1),P(1,1,1),P(1,1,0)),  # +y
        (P(0,0,0),P(0,1,0),P(1,1,0),P(1,0,0)),  # -z
        (P(0,0,1),P(1,0,1),P(1,1,1),P(0,1,1)),  # +z
    ]
    for f in faces:
        if inward: quad(f[3], f[2], f[1], f[0])
        else: quad(*f)
box((-4,0,-2),(4,3,2),True)
box((-0.005,0.25,-2),(0.005,3,2),False)
pos=[]; nrm=[]
def sub(a,b): return [a[i]-b[i] for i in range(3)]
def cross(a,b): return [a[1]*b[2]-a[2]*b[1], a[2]*b[0]-a[0]*b[2], a[0]*b[1]-a[1]*b[0]]
for t in tris:
    n = cross(sub(t[1],t[0]), sub(t[2],t[0])); l = math.sqrt(sum(x*x for x in n)); n=[x/l for x in n]
    for v in t: pos += v; nrm += n
pb = struct.pack('<%df'%len(pos), *pos); nb = struct.pack('<%df'%len(nrm), *nrm)
buf = pb + nb
cnt = len(pos)//3
def quat_look(fwd):
    f=[x/math.sqrt(sum(y*y for y in fwd)) for x in fwd]
    z=[-x for x in f]; up=[0,1,0]
    x=cross(up,z); l=math.sqrt(sum(v*v for v in x)); x=[v/l for v in x]
    y=cross(z,x)
    m00,m01,m02=x[0],y[0],z[0]; m10,m11,m12=x[1],y[1],z[1]; m20,m21,m22=x[2],y[2],z[2]
    tr=m00+m11+m22
    if tr>0:
        s=math.sqrt(tr+1)*2; w=0.25*s; qx=(m21-m12)/s; qy=(m02-m20)/s; qz=(m10-m01)/s
    elif m00>m11 and m00>m22:
        s=math.sqrt(1+m00-m11-m22)*2; w=(m21-m12)/s; qx=0.25*s; qy=(m01+m10)/s; qz=(m02+m20)/s
    elif m11>m22:
        s=math.sqrt(1+m11-m00-m22)*2; w=(m02-m20)/s; qx=(m01+m10)/s; qy=0.25*s; qz=(m12+m21)/s
    else:
        s=math.sqrt(1+m22-m00-m11)*2; w=(m10-m01)/s; qx=(m02+m20)/s; qy=(m12+m21)/s; qz=0.25*s
    return [qx,qy,qz,w]
yfov = 70*math.pi/180
g = {"asset":{"version":"2.0"},"extensionsUsed":["KHR_lights_punctual"],
 "extensions":{"KHR_lights_punctual":{"lights":[{"type":"point","intensity":40,"color":[1,1,1]}]}},
 "scene":0,"scenes":[{"nodes":[0,1,2,3]}],
 "nodes":[{"mesh":0},
          {"camera":0,"translation":[3.7,1.6,1.7],"rotation":quat_look([-1,-0.45,-0.45])},
          {"camera":1,"translation":[-3.7,1.6,1.7],"rotation":quat_look([1,-0.45,-0.45])},
          {"translation":[-2,1.2,0],"extensions":{"KHR_lights_punctual":{"light":0}}}],
 "cameras":[{"type":"perspective","perspective":{"yfov":yfov,"znear":0.01}},{"type":"perspective","perspective":{"yfov":yfov,"znear":0.01}}],
 "materials":[{"pbrMetallicRoughness":{"baseColorFactor":[0.7,0.7,0.7,1],"metallicFactor":0,"roughnessFactor":1}}],
 "meshes":[{"primitives":[{"attributes":{"POSITION":0,"NORMAL":1},"material":0}]}],
 "accessors":[{"bufferView":0,"componentType":5126,"count":cnt,"type":"VEC3","min":[min(pos[i::3]) for i in range(3)],"max":[max(pos[i::3]) for i in range(3)]},
              {"bufferView":1,"componentType":5126,"count":cnt,"type":"VEC3"}],
 "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":len(pb)},{"buffer":0,"byteOffset":len(pb),"byteLength":len(nb)}],
 "buffers":[{"byteLength":len(buf),"uri":"data:application/octet-stream;base64,"+base64.b64encode(buf).decode()}]}
json.dump(g, open(sys.argv[1],'w'))
