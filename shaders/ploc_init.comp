// ploc_init.comp: the start of a GPU PLOC build (renderer/accel/gpu_ploc.c) after the LBVH's keys
// and sort: one thread a triangle writes its cluster (its box, empty for a non-finite vertex; its
// cost, the box's area, as ploc_ref.c) and the first round's places (the triangles in sorted key
// order); thread 0 clears the round records and writes the first round's dispatches. With one
// triangle or none there is no round: thread 0 writes the output (one leaf, or an empty root),
// its node count and depth.
// Push constants (pc_push): buf0 = positions (9 floats a triangle), buf1 = output nodes,
// buf2 = scratch (shaders/ploc.glsl), globals = prim_index; params.x = n, params.y = the PLOC
// area's word offset, params.w = groups a row of a dispatch.
#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"
#include "ploc.glsl"

layout(local_size_x = PC_WG_1D) in;

layout(buffer_reference, std430, buffer_reference_align = 16) buffer Nodes
{
    pc_bvh_node n[];
};

layout(push_constant) uniform Push
{
    pc_push pc;
};

void main()
{
    uint n = pc.params.x, at = pc.params.y, row = pc.params.w, i = lbvh_thread();
    LbvhUints s = LbvhUints(pc.buf2);
    if (i == 0u) {
        for (uint w = 0u; w < PC_PLOC_CTRL_WORDS + PC_PLOC_ROUNDS_ALL * PC_PLOC_LOG_WORDS; w++)
            s.v[at + w] = 0u;
        uint log0 = ploc_log_at(at, 0u);
        s.v[log0 + PC_PLOC_LOG_COUNT] = n;
        if (n >= 2u) {
            ploc_write_args(s, log0 + PC_PLOC_LOG_NN_ARGS, (n + PC_WG_1D - 1u) / PC_WG_1D, row);
            ploc_write_args(s, log0 + PC_PLOC_LOG_BLOCK_ARGS, ploc_blocks(n), row);
        }
        if (n <= 1u) { // no clustering: one leaf, or an empty root (as the other builders give)
            pc_bvh_node root;
            root.bmin = vec4(uintBitsToFloat(0x7f800000u)); // +inf
            root.bmax = vec4(-uintBitsToFloat(0x7f800000u));
            root.bmin.w = uintBitsToFloat(0u);
            root.bmax.w = uintBitsToFloat(0u);
            if (n == 1u) {
                vec3 lo, hi;
                lbvh_triangle_box(pc.buf0, 0u, lo, hi);
                root.bmin.xyz = lo;
                root.bmax.xyz = hi;
                root.bmax.w = uintBitsToFloat(1u);
                LbvhUints(pc.globals).v[0] = 0u;
            }
            Nodes(pc.buf1).n[0] = root;
            s.v[LBVH_COUNT_AT] = 1u;
            s.v[LBVH_DEPTH_AT] = 0u;
        }
    }
    if (i >= n || n < 2u) return;
    PlocCluster k;
    bool finite = lbvh_triangle_box(pc.buf0, i, k.lo.xyz, k.hi.xyz);
    k.lo.w = ploc_half_area(k.lo.xyz, k.hi.xyz);
    k.hi.w = 0.0;
    k.info = uvec4(1u, finite ? 0u : 1u, 0xffffffffu, 0xffffffffu);
    k.out_ = uvec4(0u, 0xffffffffu, 0u, 0u);
    ploc_clusters(pc.buf2, n, at).c[i] = k;
    s.v[ploc_cur_at(n, at, 0u) + i] = lbvh_keys(pc.buf2).k[i].x;
}
