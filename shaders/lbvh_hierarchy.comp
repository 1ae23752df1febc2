// lbvh_hierarchy.comp: the binary radix tree of an LBVH over the sorted keys (Karras 2012,
// "Maximizing Parallelism in the Construction of BVHs, Octrees, and k-d Trees", sec. 4, Figure 4),
// one thread per internal node i in [0, n-1). The keys are distinct (the triangle index sits in
// their low word), so the longest common prefix of two keys settles every tie. Output order
// (renderer/accel/gpu_lbvh.h): the root at node 0 and the two children of internal node i at nodes
// 2i+1 and 2i+2, adjacent as pc_bvh_node wants; every node but the root is one node's child, so the
// 2n-1 nodes of this working tree are all written once. Each thread writes its children's w words
// (interior: first = 2c+1, count 0; leaves are written by lbvh_boxes), the slots of its children
// and prim_index of its leaf children, clears its own done word for lbvh_boxes, and writes its
// range of sorted leaves and its children's alive words (1: lbvh_boxes clears those under a
// collapsed node) for lbvh_scan and lbvh_remap; thread 0 writes the indirect dispatch of the lbvh_boxes
// passes (one thread per internal node, rows of at most params.w groups). lbvh_remap copies the nodes that stay to the output.
// n == 1: the root is the one leaf; n == 0: an empty root (written straight to the output).
// Push constants (pc_push): buf0 = scratch (shaders/lbvh.glsl), buf1 = nodes (pc_bvh_node),
// buf2 = prim_index (uint); params.x = n, params.y = uint offset of leaf_slot in scratch,
// params.z unused (lbvh_boxes collapses leaves), params.w = groups a row of a dispatch (the nodes go to the working tree;
// for n == 0 buf1 is the output).
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

LbvhKeys g_keys;
int g_n;

// Length of the longest common prefix of keys i and j (64 bits); -1 for j outside the keys.
int delta(int i, int j)
{
    if (j < 0 || j >= g_n) return -1;
    uvec2 a = g_keys.k[i], b = g_keys.k[j];
    if (a.y != b.y) return 31 - findMSB(a.y ^ b.y);
    return 63 - findMSB(a.x ^ b.x);
}

void set_interior(Nodes nodes, uint slot, uint first)
{
    nodes.n[slot].bmin.w = uintBitsToFloat(first);
    nodes.n[slot].bmax.w = uintBitsToFloat(0u);
}

void main()
{
    uint n = pc.params.x, at = pc.params.y;
    uint ti = lbvh_thread();
    Nodes nodes = Nodes(pc.buf1);
    LbvhUints s = LbvhUints(pc.buf0);
    LbvhUints prim = LbvhUints(pc.buf2);
    g_keys = lbvh_keys(pc.buf0);
    g_n = int(n);
    if (ti == 0u) s.v[LBVH_DEPTH_AT] = 0u; // lbvh_boxes writes the root's height for n > 1
    if (n <= 1u) {
        if (ti != 0u) return;
        if (n == 0u) {
            float inf = uintBitsToFloat(0x7f800000u);
            nodes.n[0].bmin = vec4(inf, inf, inf, uintBitsToFloat(0u));
            nodes.n[0].bmax = vec4(-inf, -inf, -inf, uintBitsToFloat(0u));
            s.v[LBVH_COUNT_AT] = 1u;
        } else {
            s.v[lbvh_leaf_slot_at(n, at)] = 0u;
            s.v[lbvh_alive_at(n, at)] = 1u;
            prim.v[0] = g_keys.k[0].x;
        }
        return;
    }
    if (ti >= n - 1u) return;
    int i = int(ti);

    // direction and extent of the range (Figure 4, lines 2-13)
    int d = delta(i, i + 1) - delta(i, i - 1) >= 0 ? 1 : -1;
    int dmin = delta(i, i - d);
    int lmax = 2;
    while (delta(i, i + lmax * d) > dmin)
        lmax *= 2;
    int l = 0;
    for (int t = lmax / 2; t >= 1; t /= 2)
        if (delta(i, i + (l + t) * d) > dmin) l += t;
    int j = i + l * d;

    // split position (lines 15-24)
    int dnode = delta(i, j);
    int sp = 0;
    for (int div = 2;; div *= 2) {
        int t = (l + div - 1) / div;
        if (delta(i, i + (sp + t) * d) > dnode) sp += t;
        if (t == 1) break;
    }
    int gamma = i + sp * d + min(d, 0);

    // this node's range of sorted leaves, for the collapse of small subtrees (lbvh_remap)
    // (a range holding finite and non-finite triangles, keys on either side of 1 << 30, is
    // never collapsed: the count's top bit marks it; bvh.h keeps such triangles apart)
    uint lo = uint(min(i, j)), count = uint(max(i, j)) - lo + 1u;
    bool mixed = ((g_keys.k[min(i, j)].y ^ g_keys.k[max(i, j)].y) & (1u << 30)) != 0u;
    s.v[lbvh_range_at(n, at) + 2u * ti] = lo;
    s.v[lbvh_range_at(n, at) + 2u * ti + 1u] = count | (mixed ? LBVH_MIXED : 0u);
    uint children[2] = uint[2](uint(gamma), uint(gamma + 1));
    bool leaf[2] = bool[2](min(i, j) == gamma, max(i, j) == gamma + 1);
    for (uint c = 0u; c < 2u; c++) {
        uint slot = 2u * ti + 1u + c;
        s.v[lbvh_alive_at(n, at) + slot] = 1u; // until lbvh_boxes collapses an ancestor
        if (leaf[c]) {
            s.v[lbvh_leaf_slot_at(n, at) + children[c]] = slot;
            prim.v[children[c]] = g_keys.k[children[c]].x;
        } else {
            s.v[lbvh_node_slot_at(n, at) + children[c]] = slot;
            set_interior(nodes, slot, 2u * children[c] + 1u);
        }
    }
    s.v[lbvh_done_at(n, at) + ti] = 0u;
    if (ti == 0u) {
        s.v[lbvh_node_slot_at(n, at)] = 0u;
        s.v[lbvh_alive_at(n, at)] = 1u;
        uint groups = (n - 1u + PC_WG_1D - 1u) / PC_WG_1D, row = min(groups, pc.params.w);
        s.v[lbvh_args_at(n, at)] = row;
        s.v[lbvh_args_at(n, at) + 1u] = (groups + row - 1u) / row;
        s.v[lbvh_args_at(n, at) + 2u] = 1u;
        set_interior(nodes, 0u, 1u);
    }
}
