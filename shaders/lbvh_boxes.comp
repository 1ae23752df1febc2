// lbvh_boxes.comp: the boxes of an LBVH bottom-up (Karras 2012, sec. 4, "Bounding boxes"),
// in passes rather than by one climbing thread per leaf, so that no pass reads a box written
// in the same dispatch. params.z == 0: one thread per leaf writes it (first = its sorted
// position, count 1, the triangle's box; empty [+inf, -inf] for a triangle with a non-finite
// vertex). params.z == k >= 1: one thread per internal node not yet done whose children were
// both done before pass k (leaves, or done[c] in [1, k)) writes its box, the exact union of
// theirs, and done = k. The tree over distinct 64-bit keys is at most 64 internal levels deep
// (each level's common prefix is longer than its parent's), so 64 passes finish every node;
// a done node's thread returns at once, and the thread that finishes the root zeroes the
// x group count of the indirect dispatch of the passes (scratch, lbvh_args_at; rows of groups
// in y, lbvh_hierarchy), so the passes after it launch nothing.
// The collapse of small subtrees, by SAH (the cost rd_bvh_sah_cost sums, SAH_TRAVERSAL and
// SAH_INTERSECT of bvh_internal.h both 1, box half areas, an empty box 0): a finished node's
// subtree cost is the least of its split (its area plus its children's costs; a leaf child's
// is its area) and, when it holds at most max_leaf triangles, none of them mixing finite and
// non-finite ones, one leaf over them (its area times their count). A node whose leaf wins is
// flagged LBVH_COLLAPSED (lbvh_remap makes it a leaf) and its thread clears the alive words of
// its descendants (fewer than 2 max_leaf, finished in earlier passes), so the nodes under the
// highest collapsed node go; bottom-up this gives each subtree its least cost over collapses
// (Karras 2012 collapses by count alone; here as the CPU builder weighs its leaves, not greedy).
// A leaf's cost is weighed at PC_LBVH_LEAF_WEIGHT of its SAH, so that a subtree of a few triangles
// becomes a leaf somewhat more often than SAH alone says. Measured (NVIDIA H200, test_gpu_lbvh
// bench, spheres of 1, 2 and 8 M triangles; trace rate against the CPU builder's tree, SAH
// ratio to it): by count alone 0.93 / 0.94 / 0.89, SAH 1.20 / 1.20 / 1.18; weight 1 (pure SAH)
// 0.89 / 0.88 / 0.87, SAH 1.10 / 1.11 / 1.13, two levels deeper; weight 0.75 0.93 / 0.94 / 0.89,
// SAH 1.17 / 1.17 / 1.17. Morton splits overlap more than binned SAH ones, so the model's
// smaller cost did not trace faster; the traversal is what counts.
// Runs after lbvh_hierarchy (slots, interior w words, cleared done words).
// Push constants (pc_push): buf0 = positions, buf1 = nodes (pc_bvh_node), buf2 = scratch
// (shaders/lbvh.glsl); params.x = n, params.y = uint offset of leaf_slot in scratch,
// params.z = pass, params.w = max_leaf.
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

float half_area(vec3 lo, vec3 hi)
{
    if (!all(lessThanEqual(lo, hi))) return 0.0; // empty (or NaN)
    vec3 d = hi - lo;
    return d.x * d.y + d.y * d.z + d.z * d.x;
}

// The SAH cost of the subtree at a finished child node: a triangle's area, or its cost word.
float child_cost(LbvhUints s, uint n, uint at, pc_bvh_node c)
{
    if (floatBitsToUint(c.bmax.w) != 0u) return half_area(c.bmin.xyz, c.bmax.xyz);
    return uintBitsToFloat(s.v[lbvh_cost_at(n, at) + (floatBitsToUint(c.bmin.w) - 1u) / 2u]);
}

// Clears the alive words of internal node i's descendants (a subtree of at most max_leaf
// triangles, max_leaf <= 8: at most 2 * 8 - 2 slots, fewer than 16 pending).
void clear_below(Nodes nodes, LbvhUints s, uint n, uint at, uint i)
{
    uint stack[16], sp = 0u;
    stack[sp++] = 2u * i + 1u;
    stack[sp++] = 2u * i + 2u;
    while (sp > 0u) {
        uint slot = stack[--sp];
        s.v[lbvh_alive_at(n, at) + slot] = 0u;
        pc_bvh_node c = nodes.n[slot];
        if (floatBitsToUint(c.bmax.w) != 0u || sp + 2u > 16u) continue;
        uint first = floatBitsToUint(c.bmin.w);
        stack[sp++] = first;
        stack[sp++] = first + 1u;
    }
}

// Whether a child node was finished before pass k.
bool child_ready(LbvhUints s, uint n, uint at, pc_bvh_node c, uint k)
{
    if (floatBitsToUint(c.bmax.w) != 0u) return true; /* a leaf */
    uint done = s.v[lbvh_done_at(n, at) + (floatBitsToUint(c.bmin.w) - 1u) / 2u];
    return done != 0u && done < k;
}

void main()
{
    uint n = pc.params.x, at = pc.params.y, k = pc.params.z;
    uint i = lbvh_thread();
    Nodes nodes = Nodes(pc.buf1);
    LbvhUints s = LbvhUints(pc.buf2);
    if (k == 0u) {
        if (i >= n) return;
        uint tri = lbvh_keys(pc.buf2).k[i].x;
        vec3 a, b, c;
        lbvh_triangle(pc.buf0, tri, a, b, c);
        vec3 lo = min(a, min(b, c)), hi = max(a, max(b, c));
        if (!lbvh_finite(a) || !lbvh_finite(b) || !lbvh_finite(c)) {
            lo = vec3(uintBitsToFloat(0x7f800000u));
            hi = -lo;
        }
        uint slot = s.v[lbvh_leaf_slot_at(n, at) + i];
        nodes.n[slot].bmin = vec4(lo, uintBitsToFloat(i));
        nodes.n[slot].bmax = vec4(hi, uintBitsToFloat(1u));
        return;
    }
    if (i + 1u >= n || s.v[lbvh_done_at(n, at) + i] != 0u) return;
    pc_bvh_node l = nodes.n[2u * i + 1u], r = nodes.n[2u * i + 2u];
    if (!child_ready(s, n, at, l, k) || !child_ready(s, n, at, r, k)) return;
    uint slot = s.v[lbvh_node_slot_at(n, at) + i];
    vec3 lo = min(l.bmin.xyz, r.bmin.xyz), hi = max(l.bmax.xyz, r.bmax.xyz);
    nodes.n[slot].bmin = vec4(lo, uintBitsToFloat(2u * i + 1u));
    nodes.n[slot].bmax = vec4(hi, uintBitsToFloat(0u));
    float area = half_area(lo, hi);
    float cost = area + child_cost(s, n, at, l) + child_cost(s, n, at, r);
    uint count = s.v[lbvh_range_at(n, at) + 2u * i + 1u];
    if (count <= pc.params.w && PC_LBVH_LEAF_WEIGHT * area * float(count) <= cost) { // LBVH_MIXED: never
        cost = area * float(count);
        s.v[lbvh_range_at(n, at) + 2u * i + 1u] = count | LBVH_COLLAPSED;
        clear_below(nodes, s, n, at, i);
    }
    s.v[lbvh_cost_at(n, at) + i] = floatBitsToUint(cost);
    s.v[lbvh_done_at(n, at) + i] = k;
    if (i == 0u) s.v[lbvh_args_at(n, at)] = 0u;
}
