// lbvh_bounds.comp: the box of the triangles' centroids for the Morton codes of an LBVH
// (renderer/accel/gpu_lbvh.c), by atomics on order-preserving uints; triangles with a
// non-finite vertex are left out. params.z == 0: one thread resets the box (its own dispatch,
// before the others); params.z == 1: one thread per triangle widens it.
// Push constants (pc_push): buf0 = positions (9 floats per triangle), buf2 = scratch
// (shaders/lbvh.glsl); params.x = triangles.
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

void main()
{
    uint i = lbvh_thread();
    LbvhUints s = LbvhUints(pc.buf2);
    if (pc.params.z == 0u) {
        if (i < 3u) {
            s.v[i] = 0xffffffffu;
            s.v[3u + i] = 0u;
        }
        return;
    }
    if (i >= pc.params.x) return;
    vec3 a, b, c;
    lbvh_triangle(pc.buf0, i, a, b, c);
    if (!lbvh_finite(a) || !lbvh_finite(b) || !lbvh_finite(c)) return;
    vec3 m = (a + b + c) * (1.0 / 3.0);
    for (uint k = 0u; k < 3u; k++) {
        atomicMin(s.v[k], lbvh_f2o(m[k]));
        atomicMax(s.v[3u + k], lbvh_f2o(m[k]));
    }
}
