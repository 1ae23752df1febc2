// lbvh_scan.comp: the output index of every node of the LBVH working tree that stays (after the
// collapse of small subtrees, renderer/accel/gpu_lbvh.c): an exclusive prefix sum of the alive
// words in place, in three dispatches over blocks of PC_LBVH_SCAN_BLOCK words (m = 2n - 1 words):
//   params.z = 0: one workgroup a block writes the block's sum (after the args words);
//   params.z = 1: one workgroup scans the block sums (exclusive) and writes the output's node
//                 count to scratch word LBVH_COUNT_AT;
//   params.z = 2: one workgroup a block rewrites its words: alive -> its output index (the block's
//                 offset plus the alive words before it), gone -> 0xffffffff.
// Within a block each thread takes a contiguous chunk of PC_LBVH_SCAN_BLOCK / PC_WG_1D words and
// thread 0 scans the chunk sums in shared memory. Siblings stay or go together, so they stay
// adjacent. (One workgroup for the whole array took 22 of the 26 ms of a 2 M-triangle build on
// an NVIDIA H200: tests/bench/results/h200/gpu_bvh_stop41.txt.)
// Push constants (pc_push): buf2 = scratch (shaders/lbvh.glsl); params.x = n,
// params.y = uint offset of leaf_slot in scratch, params.z = the phase.
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
    uint n = pc.params.x, at = pc.params.y, phase = pc.params.z, t = gl_LocalInvocationID.x;
    uint m = 2u * n - 1u, blocks = (m + PC_LBVH_SCAN_BLOCK - 1u) / PC_LBVH_SCAN_BLOCK;
    LbvhUints s = LbvhUints(pc.buf2);
    uint base = lbvh_alive_at(n, at), sums = lbvh_scan_sums_at(n, at);
    if (phase == 1u) { // the block sums, by chunks
        uint chunk = (blocks + PC_WG_1D - 1u) / PC_WG_1D;
        uint a = min(t * chunk, blocks), b = min(a + chunk, blocks), sum = 0u;
        for (uint k = a; k < b; k++)
            sum += s.v[sums + k];
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
            uint v = s.v[sums + k];
            s.v[sums + k] = run;
            run += v;
        }
        return;
    }
    uint block = lbvh_group(), chunk = PC_LBVH_SCAN_BLOCK / PC_WG_1D;
    if (block >= blocks) return; /* past the last block: the whole group */
    uint a = min(block * PC_LBVH_SCAN_BLOCK + t * chunk, m), b = min(a + chunk, m), sum = 0u;
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
        if (phase == 0u) s.v[sums + block] = run;
    }
    barrier();
    if (phase == 0u) return;
    uint run = s.v[sums + block] + g_sums[t];
    for (uint k = a; k < b; k++) {
        uint v = s.v[base + k];
        s.v[base + k] = v != 0u ? run : 0xffffffffu;
        run += v;
    }
}
