// lbvh_scan.comp: the output index of every node of the LBVH working tree that stays (after the
// collapse of small subtrees, renderer/accel/gpu_lbvh.c): an exclusive prefix sum of the alive
// words in place, by one workgroup: each thread sums a contiguous chunk, thread 0 scans the
// chunk sums in shared memory, each thread rewrites its chunk. O(m) work on PC_WG_1D threads,
// m = 2n - 1; simple rather than fast. Siblings stay or go together, so they stay adjacent.
// Also writes the output's node count to scratch word LBVH_COUNT_AT.
// Push constants (pc_push): buf2 = scratch (shaders/lbvh.glsl); params.x = n,
// params.y = uint offset of leaf_slot in scratch. Dispatch one workgroup.
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

shared uint g_sums[PC_WG_1D];

void main()
{
    uint n = pc.params.x, at = pc.params.y, t = gl_LocalInvocationID.x;
    uint m = 2u * n - 1u, chunk = (m + PC_WG_1D - 1u) / PC_WG_1D;
    uint a = min(t * chunk, m), b = min(a + chunk, m);
    LbvhUints s = LbvhUints(pc.buf2);
    uint base = lbvh_alive_at(n, at), sum = 0u;
    for (uint k = a; k < b; k++)
        sum += s.v[base + k];
    g_sums[t] = sum;
    barrier();
    if (t == 0u) {
        uint run = 0u;
        for (uint k = 0u; k < PC_WG_1D; k++) {
            uint v = g_sums[k];
            g_sums[k] = run;
            run += v;
        }
        s.v[LBVH_COUNT_AT] = run;
    }
    barrier();
    uint run = g_sums[t];
    for (uint k = a; k < b; k++) {
        uint v = s.v[base + k];
        s.v[base + k] = v != 0u ? run : 0xffffffffu;
        run += v;
    }
}
