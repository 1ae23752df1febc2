// lbvh_sort.comp: a bitonic sort (Batcher 1968) of the LBVH keys (renderer/accel/gpu_lbvh.c),
// ascending by (Morton code, triangle index), over N keys (a power of two, at least
// LBVH_SORT_BLOCK). Three kinds of dispatch (params.w):
//   0: one compare-exchange step (k, j) over all keys, N/2 threads (for j >= LBVH_SORT_BLOCK);
//   1: every step j = LBVH_SORT_BLOCK/2 .. 1 of one k, a workgroup a block of
//      LBVH_SORT_BLOCK keys in shared memory;
//   2: every k = 2 .. LBVH_SORT_BLOCK and its steps, the same way (the first dispatch).
// So a sort is one dispatch of kind 2, then for each k = 2 LBVH_SORT_BLOCK .. N the global
// steps j = k/2 .. LBVH_SORT_BLOCK and one dispatch of kind 1: 28 dispatches for N = 8192.
// Push constants (pc_push): buf2 = scratch (shaders/lbvh.glsl); params.x = N/2, params.y = k,
// params.z = j (kind 0), params.w = kind.
#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"
#include "lbvh.glsl"

layout(local_size_x = PC_WG_1D) in;

#define LBVH_SORT_BLOCK (2u * PC_WG_1D)

layout(push_constant) uniform Push
{
    pc_push pc;
};

shared uvec2 g_block[LBVH_SORT_BLOCK];

bool key_greater(uvec2 a, uvec2 b)
{
    return a.y > b.y || (a.y == b.y && a.x > b.x);
}

// the lower index of thread i's pair in step j (i with a zero bit inserted at j)
uint pair_low(uint i, uint j)
{
    return ((i & ~(j - 1u)) << 1) | (i & (j - 1u));
}

void main()
{
    uint k = pc.params.y, kind = pc.params.w;
    LbvhKeys keys = lbvh_keys(pc.buf2);
    if (kind == 0u) {
        uint i = lbvh_thread(), j = pc.params.z;
        if (i >= pc.params.x) return;
        uint a = pair_low(i, j), b = a | j;
        uvec2 ka = keys.k[a], kb = keys.k[b];
        if (key_greater(ka, kb) == ((a & k) == 0u)) {
            keys.k[a] = kb;
            keys.k[b] = ka;
        }
        return;
    }
    uint t = gl_LocalInvocationID.x, block = lbvh_group();
    if (block >= pc.params.x / PC_WG_1D) return; /* past the last block: the whole group */
    uint base = block * LBVH_SORT_BLOCK;
    g_block[t] = keys.k[base + t];
    g_block[t + PC_WG_1D] = keys.k[base + t + PC_WG_1D];
    barrier();
    uint k_first = kind == 2u ? 2u : k, k_last = kind == 2u ? LBVH_SORT_BLOCK : k;
    for (uint kk = k_first; kk <= k_last; kk <<= 1) {
        for (uint j = min(kk, LBVH_SORT_BLOCK) / 2u; j > 0u; j >>= 1) {
            uint a = pair_low(t, j), b = a | j;
            uvec2 ka = g_block[a], kb = g_block[b];
            if (key_greater(ka, kb) == (((base + a) & kk) == 0u)) {
                g_block[a] = kb;
                g_block[b] = ka;
            }
            barrier();
        }
    }
    keys.k[base + t] = g_block[t];
    keys.k[base + t + PC_WG_1D] = g_block[t + PC_WG_1D];
}
