// lbvh_morton.comp: the sort keys of an LBVH (renderer/accel/gpu_lbvh.c; Karras 2012, sec. 4):
// a 30-bit Morton code of each triangle's centroid in the centroid box (10 bits an axis)
// beside the triangle's index, so that equal codes still give distinct keys (the paper's
// tie-break by index, sec. 4). Triangles with a non-finite vertex get code 1 << 30, past every
// finite code, so they end up in a subtree of their own. Threads past the triangles write the
// padding keys of the power-of-two sort (all ones).
// Push constants (pc_push): buf0 = positions, buf2 = scratch (shaders/lbvh.glsl);
// params.x = triangles, params.y = padded key count N.
#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"
#include "lbvh.glsl"

layout(local_size_x = PC_WG_1D) in;

layout(push_constant) uniform Push
{
    pc_push pc;
};

// 10 bits spread to every third bit of 30
uint lbvh_expand_bits(uint v)
{
    v = (v * 0x00010001u) & 0xFF0000FFu;
    v = (v * 0x00000101u) & 0x0F00F00Fu;
    v = (v * 0x00000011u) & 0xC30C30C3u;
    v = (v * 0x00000005u) & 0x49249249u;
    return v;
}

void main()
{
    uint i = lbvh_thread();
    LbvhKeys keys = lbvh_keys(pc.buf2);
    if (i >= pc.params.y) return;
    if (i >= pc.params.x) {
        keys.k[i] = uvec2(0xffffffffu);
        return;
    }
    LbvhUints s = LbvhUints(pc.buf2);
    vec3 lo = vec3(lbvh_o2f(s.v[0]), lbvh_o2f(s.v[1]), lbvh_o2f(s.v[2]));
    vec3 hi = vec3(lbvh_o2f(s.v[3]), lbvh_o2f(s.v[4]), lbvh_o2f(s.v[5]));
    vec3 a, b, c;
    lbvh_triangle(pc.buf0, i, a, b, c);
    uint code = 1u << 30;
    if (lbvh_finite(a) && lbvh_finite(b) && lbvh_finite(c)) {
        vec3 m = (a + b + c) * (1.0 / 3.0);
        vec3 ext = hi - lo;
        vec3 u = vec3(0.0);
        for (uint k = 0u; k < 3u; k++)
            u[k] = ext[k] > 0.0 ? (m[k] - lo[k]) / ext[k] : 0.0;
        uvec3 q = uvec3(clamp(u * 1024.0, vec3(0.0), vec3(1023.0)));
        code = lbvh_expand_bits(q.x) * 4u + lbvh_expand_bits(q.y) * 2u + lbvh_expand_bits(q.z);
    }
    keys.k[i] = uvec2(i, code);
}
