// lbvh.glsl: the scratch layout and key helpers shared by the LBVH passes
// (renderer/accel/gpu_lbvh.c mirrors the layout: rd_gpu_lbvh_scratch_bytes).
// Scratch, in uints from its start: [0, 8) centroid bounds as order-preserving uints
// (min xyz, max xyz); [8, 8 + 2N) the sort keys as uvec2 (x: triangle index, y: Morton code;
// N = tri count rounded up to a power of two, padding keys all ones); then leaf_slot[n] (sorted
// leaf -> output node), node_slot[n] (internal node -> output node), done[n] (per internal
// node: the lbvh_boxes pass that made its box, 0 before), range[2n] (per internal node: first
// sorted leaf and count, the count's top bits flags: LBVH_MIXED, LBVH_COLLAPSED) and alive[2n]
// (per working-tree node: 1 if it stays in the output, then its output index after lbvh_scan),
// cost[n] (per internal node: its subtree's SAH cost, float bits, lbvh_boxes), then 4 words:
// the indirect dispatch of the
// lbvh_boxes passes (x: groups, zeroed when the root is done), then lbvh_scan's block sums
// (LBVH_SCAN_BLOCK). Word 6 of the scratch: the
// output's node count.
// pc.params.x = n (triangles), pc.params.y = uint offset of leaf_slot.
#ifndef LBVH_GLSL
#define LBVH_GLSL

#include "bvh_build_types.h"

#define LBVH_KEYS_AT 8u

// Every pass is a 2D dispatch of 1D work (renderer/accel/gpu_lbvh.c: a row of at most 65535
// groups, rows in y, so that a pass can have more than 65535 groups): the linear workgroup and
// thread index; the last row may run past the work, and its threads return.
uint lbvh_group()
{
    return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
}
uint lbvh_thread()
{
    return lbvh_group() * PC_WG_1D + gl_LocalInvocationID.x;
}

layout(buffer_reference, std430, buffer_reference_align = 4) coherent buffer LbvhUints
{
    uint v[];
};
layout(buffer_reference, std430, buffer_reference_align = 8) buffer LbvhKeys
{
    uvec2 k[];
};
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer LbvhFloats
{
    float v[];
};

LbvhKeys lbvh_keys(uint64_t scratch)
{
    return LbvhKeys(scratch + 32ul); // 4 bytes * LBVH_KEYS_AT
}

uint lbvh_leaf_slot_at(uint n, uint leaf_at)
{
    return leaf_at;
}
uint lbvh_node_slot_at(uint n, uint leaf_at)
{
    return leaf_at + n;
}
uint lbvh_done_at(uint n, uint leaf_at)
{
    return leaf_at + 2u * n;
}
uint lbvh_range_at(uint n, uint leaf_at)
{
    return leaf_at + 3u * n;
}
uint lbvh_alive_at(uint n, uint leaf_at)
{
    return leaf_at + 5u * n;
}
uint lbvh_cost_at(uint n, uint leaf_at)
{
    return leaf_at + 7u * n;
}
uint lbvh_args_at(uint n, uint leaf_at)
{
    return leaf_at + 8u * n;
}
// Flags in the top bits of an internal node's range count (counts are below 2^24): its range
// mixes finite and non-finite triangles (never collapsed, lbvh_hierarchy); it is collapsed into
// one leaf (lbvh_boxes).
#define LBVH_MIXED 0x80000000u
#define LBVH_COLLAPSED 0x40000000u
#define LBVH_COUNT_MASK 0x00ffffffu
#define LBVH_COUNT_AT 6u
// Word 7: the output tree's depth (levels below the root; lbvh_hierarchy zeroes it, lbvh_boxes
// writes the root's height), so that a build's caller need not read the tree back for it.
#define LBVH_DEPTH_AT 7u
// lbvh_boxes keeps a finished node's height (levels below it, as the output will have them) in
// the top bits of its done word, the pass that finished it in the low ones.
#define LBVH_DONE_PASS 0xffu
#define LBVH_HEIGHT_SHIFT 8u
// lbvh_scan.comp's block sums (PC_LBVH_SCAN_BLOCK, gpu_types.h) follow the args words.
uint lbvh_scan_sums_at(uint n, uint leaf_at)
{
    return lbvh_args_at(n, leaf_at) + 4u;
}

// Triangle t's three vertices (9 floats each triangle).
void lbvh_triangle(uint64_t positions, uint t, out vec3 a, out vec3 b, out vec3 c)
{
    LbvhFloats p = LbvhFloats(positions);
    uint o = 9u * t;
    a = vec3(p.v[o], p.v[o + 1u], p.v[o + 2u]);
    b = vec3(p.v[o + 3u], p.v[o + 4u], p.v[o + 5u]);
    c = vec3(p.v[o + 6u], p.v[o + 7u], p.v[o + 8u]);
}

bool lbvh_finite(vec3 v)
{
    return !any(isnan(v)) && !any(isinf(v));
}

// Triangle t's box; an empty one (+inf / -inf) and false when a vertex is not finite.
bool lbvh_triangle_box(uint64_t positions, uint t, out vec3 lo, out vec3 hi)
{
    vec3 a, b, c;
    lbvh_triangle(positions, t, a, b, c);
    bool finite = lbvh_finite(a) && lbvh_finite(b) && lbvh_finite(c);
    lo = finite ? min(a, min(b, c)) : vec3(uintBitsToFloat(0x7f800000u));
    hi = finite ? max(a, max(b, c)) : vec3(-uintBitsToFloat(0x7f800000u));
    return finite;
}

// Floats to uints that compare in the same order (for atomicMin / atomicMax).
uint lbvh_f2o(float f)
{
    uint u = floatBitsToUint(f);
    return (u & 0x80000000u) != 0u ? ~u : (u | 0x80000000u);
}
float lbvh_o2f(uint o)
{
    return uintBitsToFloat((o & 0x80000000u) != 0u ? (o & 0x7fffffffu) : ~o);
}

#endif
