"""Small glTF writer for the bench scenes (narrow_gap_gltf.py, lamp_room_gltf.py): flat-shaded
triangle groups, one primitive per material, perspective cameras and KHR point lights, all in one
embedded buffer (every position, then every normal)."""
import base64, json, math, struct


def quad(tris, a, b, c, d):
    """Two triangles of the quad a b c d, counter-clockwise seen from the front."""
    tris.append((a, b, c)); tris.append((a, c, d))


def box(tris, lo, hi, inward):
    """The six faces of the box lo..hi, facing out (or in, for a room)."""
    x0, y0, z0 = lo; x1, y1, z1 = hi
    P = lambda i, j, k: (x1 if i else x0, y1 if j else y0, z1 if k else z0)
    faces = [  # outward CCW
        (P(0,0,0), P(0,0,1), P(0,1,1), P(0,1,0)), (P(1,0,0), P(1,1,0), P(1,1,1), P(1,0,1)),
        (P(0,0,0), P(1,0,0), P(1,0,1), P(0,0,1)), (P(0,1,0), P(0,1,1), P(1,1,1), P(1,1,0)),
        (P(0,0,0), P(0,1,0), P(1,1,0), P(1,0,0)), (P(0,0,1), P(1,0,1), P(1,1,1), P(0,1,1))]
    for f in faces:
        if inward: quad(tris, f[3], f[2], f[1], f[0])
        else: quad(tris, *f)


def _sub(a, b): return [a[i] - b[i] for i in range(3)]
def _cross(a, b): return [a[1]*b[2] - a[2]*b[1], a[2]*b[0] - a[0]*b[2], a[0]*b[1] - a[1]*b[0]]


def quat_look(fwd):
    """Rotation (x, y, z, w) taking a camera's -z to fwd, +y up."""
    f = [x / math.sqrt(sum(y * y for y in fwd)) for x in fwd]
    z = [-x for x in f]
    x = _cross([0, 1, 0], z); l = math.sqrt(sum(v * v for v in x)); x = [v / l for v in x]
    y = _cross(z, x)
    m00, m01, m02 = x[0], y[0], z[0]; m10, m11, m12 = x[1], y[1], z[1]; m20, m21, m22 = x[2], y[2], z[2]
    tr = m00 + m11 + m22
    if tr > 0:
        s = math.sqrt(tr + 1) * 2; return [(m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, 0.25 * s]
    if m00 > m11 and m00 > m22:
        s = math.sqrt(1 + m00 - m11 - m22) * 2; return [0.25 * s, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s]
    if m11 > m22:
        s = math.sqrt(1 + m11 - m00 - m22) * 2; return [(m01 + m10) / s, 0.25 * s, (m12 + m21) / s, (m02 - m20) / s]
    s = math.sqrt(1 + m22 - m00 - m11) * 2; return [(m02 + m20) / s, (m12 + m21) / s, 0.25 * s, (m10 - m01) / s]


def write(path, groups, materials, cameras, lights, yfov_deg=70):
    """groups: [(triangles, material index)]; cameras: [(eye, forward)]; lights: [(position,
    intensity in cd)] (white points). Node 0 holds the mesh, then the cameras, then the lights."""
    pos = []; nrm = []; spans = []
    for tris, _ in groups:
        start = len(pos) // 3
        for t in tris:
            n = _cross(_sub(t[1], t[0]), _sub(t[2], t[0])); l = math.sqrt(sum(x * x for x in n))
            for v in t: pos += v; nrm += [x / l for x in n]
        spans.append((start, len(pos) // 3 - start))
    pb = struct.pack('<%df' % len(pos), *pos); nb = struct.pack('<%df' % len(nrm), *nrm)
    accessors, views, prims = [], [], []
    for k, ((start, count), (_, mat)) in enumerate(zip(spans, groups)):
        p = pos[start * 3:(start + count) * 3]
        views += [{"buffer": 0, "byteOffset": start * 12, "byteLength": count * 12},
                  {"buffer": 0, "byteOffset": len(pb) + start * 12, "byteLength": count * 12}]
        accessors += [{"bufferView": 2 * k, "componentType": 5126, "count": count, "type": "VEC3",
                       "min": [min(p[i::3]) for i in range(3)], "max": [max(p[i::3]) for i in range(3)]},
                      {"bufferView": 2 * k + 1, "componentType": 5126, "count": count, "type": "VEC3"}]
        prims.append({"attributes": {"POSITION": 2 * k, "NORMAL": 2 * k + 1}, "material": mat})
    nodes = [{"mesh": 0}]
    nodes += [{"camera": i, "translation": list(eye), "rotation": quat_look(fwd)}
              for i, (eye, fwd) in enumerate(cameras)]
    nodes += [{"translation": list(p), "extensions": {"KHR_lights_punctual": {"light": i}}}
              for i, (p, _) in enumerate(lights)]
    buf = pb + nb
    g = {"asset": {"version": "2.0"}, "extensionsUsed": ["KHR_lights_punctual"],
         "extensions": {"KHR_lights_punctual": {"lights": [
             {"type": "point", "intensity": i, "color": [1, 1, 1]} for _, i in lights]}},
         "scene": 0, "scenes": [{"nodes": list(range(len(nodes)))}],
         "nodes": nodes,
         "cameras": [{"type": "perspective", "perspective": {"yfov": yfov_deg * math.pi / 180, "znear": 0.01}}
                     for _ in cameras],
         "materials": materials,
         "meshes": [{"primitives": prims}],
         "accessors": accessors, "bufferViews": views,
         "buffers": [{"byteLength": len(buf),
                      "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}]}
    json.dump(g, open(path, 'w'))
