// lbvh_remap.comp: the output of an LBVH build (renderer/accel/gpu_lbvh.c): one thread per
// node of the working tree copies each node that stays to its output index (lbvh_scan), an
// interior node's first child renumbered, and an interior node that lbvh_boxes collapsed
// (LBVH_COLLAPSED in its range count) turned into one leaf over its range (its sorted leaves are
// contiguous, so first = its range's first sorted leaf, count = its range's count; prim_index
// is unchanged).
// Push constants (pc_push): buf0 = working nodes, buf1 = output nodes (pc_bvh_node),
// buf2 = scratch (shaders/lbvh.glsl); params.x = n, params.y = uint offset of leaf_slot,
// params.z unused (the collapse is flagged).
#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"
#include "lbvh.glsl"

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
    uint n = pc.params.x, at = pc.params.y, slot = lbvh_thread();
    if (slot >= 2u * n - 1u) return;
    LbvhUints s = LbvhUints(pc.buf2);
    uint out_at = s.v[lbvh_alive_at(n, at) + slot];
    if (out_at == 0xffffffffu) return;
    pc_bvh_node node = Nodes(pc.buf0).n[slot];
    if (floatBitsToUint(node.bmax.w) == 0u) {
        uint c = (floatBitsToUint(node.bmin.w) - 1u) / 2u;
        uint first = s.v[lbvh_range_at(n, at) + 2u * c];
        uint count = s.v[lbvh_range_at(n, at) + 2u * c + 1u];
        if ((count & LBVH_COLLAPSED) != 0u) {
            node.bmin.w = uintBitsToFloat(first);
            node.bmax.w = uintBitsToFloat(count & LBVH_COUNT_MASK);
        } else {
            node.bmin.w = uintBitsToFloat(s.v[lbvh_alive_at(n, at) + 2u * c + 1u]);
        }
    }
    Nodes(pc.buf1).n[out_at] = node;
}
