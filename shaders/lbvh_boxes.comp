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
// Before its box, a finished node takes one tree rotation (rotate, below: Kensler 2008) where
// that shrinks a child's box: the radix tree's splits are the Morton codes' spatial medians, and
// a rotation moves a subtree to the side it overlaps less. Measured (NVIDIA H100, `test_gpu_lbvh
// bench 1000000 2000000 8000000`, two rounds in one call, tests/bench/results/h100/
// lbvh_rotations_stop46.txt): SAH ratio 1.165 / 1.172 / 1.174 -> 1.154 / 1.160 / 1.162, trace rate
// against the CPU builder's tree 0.94 / 0.94 / 0.89 -> 0.95 / 0.95 / 0.90, build 1.64 / 2.63 / 9.4
// -> 1.9 / 2.8 / 10.1 ms. With leaf weight 1 as well the SAH ratio is 1.08 / 1.09 / 1.10 but the
// trace rate 0.90 / 0.89 / 0.89: the weight stays 0.75.
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

// An internal child that may be descended into by a rotation: not collapsed.
bool rotatable(LbvhUints s, uint n, uint at, pc_bvh_node c)
{
    if (floatBitsToUint(c.bmax.w) != 0u) return false; /* a leaf */
    uint id = (floatBitsToUint(c.bmin.w) - 1u) / 2u;
    return (s.v[lbvh_range_at(n, at) + 2u * id + 1u] & LBVH_COLLAPSED) == 0u;
}

// Tree rotations (Kensler, "Tree Rotations for Improving Bounding Volume Hierarchies", 2008),
// at internal node i whose children l (slot 2i+1) and r (slot 2i+2) are finished: of the four
// swaps of one child with a grandchild under the other, the one that shrinks the other child's
// box most, if any. The subtree's SAH cost changes by exactly that child's change of area (every
// other box and subtree stays), so the greedy step never raises it. The changed child keeps its
// id and slot and gets the moved node in the grandchild's slot; its range is left as it was (it
// is never collapsed after: lbvh_remap reads ranges of collapsed nodes only, and the ancestors'
// leaf sets do not change). l and r come back as they are after the swap. One step a node: a
// second at the same node changed no tree of the test's soups (lavapipe, 100 K and 1 M).
void rotate(Nodes nodes, LbvhUints s, uint n, uint at, uint i, inout pc_bvh_node l,
            inout pc_bvh_node r)
{
    float best = 0.0;
    uint pick = 4u;
    for (uint side = 0u; side < 2u; side++) {
        pc_bvh_node stay = side == 0u ? l : r, down = side == 0u ? r : l;
        if (!rotatable(s, n, at, down)) continue;
        uint f = floatBitsToUint(down.bmin.w);
        pc_bvh_node g0 = nodes.n[f], g1 = nodes.n[f + 1u];
        float was = half_area(down.bmin.xyz, down.bmax.xyz);
        /* stay swapped with g0: down becomes (stay, g1); with g1: (g0, stay) */
        float d0 = half_area(min(stay.bmin.xyz, g1.bmin.xyz), max(stay.bmax.xyz, g1.bmax.xyz)) - was;
        float d1 = half_area(min(stay.bmin.xyz, g0.bmin.xyz), max(stay.bmax.xyz, g0.bmax.xyz)) - was;
        if (d0 < best) best = d0, pick = 2u * side;
        if (d1 < best) best = d1, pick = 2u * side + 1u;
    }
    if (pick == 4u || !(best < -1e-6 * half_area(min(l.bmin.xyz, r.bmin.xyz), max(l.bmax.xyz, r.bmax.xyz))))
        return;
    uint side = pick / 2u, g = pick % 2u;
    uint stay_slot = 2u * i + 1u + side, down_slot = 2u * i + 2u - side;
    pc_bvh_node stay = side == 0u ? l : r, down = side == 0u ? r : l;
    uint f = floatBitsToUint(down.bmin.w);
    pc_bvh_node moved = nodes.n[f + g], kept = nodes.n[f + 1u - g];
    /* the swap: the grandchild takes the child's slot, the child goes under down */
    nodes.n[stay_slot] = moved;
    nodes.n[f + g] = stay;
    if (floatBitsToUint(moved.bmax.w) == 0u)
        s.v[lbvh_node_slot_at(n, at) + (floatBitsToUint(moved.bmin.w) - 1u) / 2u] = stay_slot;
    if (floatBitsToUint(stay.bmax.w) == 0u)
        s.v[lbvh_node_slot_at(n, at) + (floatBitsToUint(stay.bmin.w) - 1u) / 2u] = f + g;
    /* down's new box and cost */
    uint id = (f - 1u) / 2u;
    down.bmin.xyz = min(stay.bmin.xyz, kept.bmin.xyz);
    down.bmax.xyz = max(stay.bmax.xyz, kept.bmax.xyz);
    nodes.n[down_slot] = down;
    float cost = half_area(down.bmin.xyz, down.bmax.xyz) + child_cost(s, n, at, stay) +
                 child_cost(s, n, at, kept);
    s.v[lbvh_cost_at(n, at) + id] = floatBitsToUint(cost);
    if (side == 0u) {
        l = moved;
        r = down;
    } else {
        l = down;
        r = moved;
    }
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
    rotate(nodes, s, n, at, i, l, r);
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
