// lbvh_sort.comp: one compare-exchange step (k, j) of a bitonic sort (Batcher 1968) of the
// LBVH keys (renderer/accel/gpu_lbvh.c), ascending by (Morton code, triangle index). The
// caller dispatches every step of k = 2, 4 .. N and j = k/2 .. 1 with a barrier between:
// log2(N) (log2(N) + 1) / 2 dispatches of N/2 threads.
// Push constants (pc_push): buf2 = scratch (shaders/lbvh.glsl); params.x = N/2, params.y = k,
// params.z = j.
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

bool key_greater(uvec2 a, uvec2 b)
{
    return a.y > b.y || (a.y == b.y && a.x > b.x);
}

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.params.x) return;
    uint k = pc.params.y, j = pc.params.z;
    uint a = ((i & ~(j - 1u)) << 1) | (i & (j - 1u)), b = a | j;
    LbvhKeys keys = lbvh_keys(pc.buf2);
    uvec2 ka = keys.k[a], kb = keys.k[b];
    bool ascending = (a & k) == 0u;
    if (key_greater(ka, kb) == ascending) {
        keys.k[a] = kb;
        keys.k[b] = ka;
    }
}
