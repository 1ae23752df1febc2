// lbvh_boxes.comp: the boxes of an LBVH bottom-up (Karras 2012, sec. 4, "Bounding boxes"),
// in passes rather than by one climbing thread per leaf, so that no pass reads a box written
// in the same dispatch. params.z == 0: one thread per leaf writes it (first = its sorted
// position, count 1, the triangle's box; empty [+inf, -inf] for a triangle with a non-finite
// vertex). params.z == k >= 1: one thread per internal node not yet done whose children were
// both done before pass k (leaves, or done[c] in [1, k)) writes its box, the exact union of
// theirs, and done = k with its height (levels below it in the output tree) in the word's top
// bits (LBVH_HEIGHT_SHIFT); the root's thread writes the tree's depth (LBVH_DEPTH_AT). The tree
// over distinct 64-bit keys is at most 64 internal levels deep (each level's common prefix is
// longer than its parent's), so 64 passes finish every node;
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
// Before its box, a finished node over at least LBVH_TREELET_FROM triangles restructures its
// treelet (restructure, below): the radix tree's splits are the Morton codes' spatial medians,
// blind to triangle sizes, and a treelet moves subtrees to the side they overlap less. Measured
// (NVIDIA H100, `test_gpu_lbvh bench 1000000 2000000 8000000 spheres:1000000 interior`,
// tests/bench/results/h100/lbvh_treelets_stop48.txt) against stop 46's one rotation a node
// (Kensler 2008, which a three-member treelet is): SAH ratio to the CPU builder on soups 1.154 ->
// 1.137, on the sphere grid 1.918 -> 1.479, on the interior's largest mesh 1.616 -> 1.138; trace
// rate against the CPU builder's tree 0.94 -> 0.955, 0.64 -> 0.72, 0.49 -> 0.67 with treelets of 7;
// with treelets of 9 (the default) SAH 1.134 / 1.427 / 1.071, trace 0.955 / 0.74 / 0.82, the
// boxes of 1 M triangles 0.9 -> 4.6 ms at every node (treelets of 7: 3.2 ms; the gate below came
// after, its time not measured on a GPU yet: on lavapipe it leaves the trees as they were). With
// leaf weight 1 as well the soups' SAH ratio is 1.05 but they trace at 0.90-0.91: the weight stays
// 0.75. The CPU PLOC reference (tests/renderer/ploc_ref.h) builds better trees still on real
// meshes (lavapipe: sphere grid 1.13, the interior's largest mesh 0.85 of the CPU builder's SAH).
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
    return done != 0u && (done & LBVH_DONE_PASS) < k;
}

// The levels below a finished child in the output tree: 0 for a leaf or a collapsed node.
uint child_height(LbvhUints s, uint n, uint at, pc_bvh_node c)
{
    if (floatBitsToUint(c.bmax.w) != 0u) return 0u;
    uint id = (floatBitsToUint(c.bmin.w) - 1u) / 2u;
    if ((s.v[lbvh_range_at(n, at) + 2u * id + 1u] & LBVH_COLLAPSED) != 0u) return 0u;
    return s.v[lbvh_done_at(n, at) + id] >> LBVH_HEIGHT_SHIFT;
}

// An internal child that may be descended into by a rotation: not collapsed.
bool rotatable(LbvhUints s, uint n, uint at, pc_bvh_node c)
{
    if (floatBitsToUint(c.bmax.w) != 0u) return false; /* a leaf */
    uint id = (floatBitsToUint(c.bmin.w) - 1u) / 2u;
    return (s.v[lbvh_range_at(n, at) + 2u * id + 1u] & LBVH_COLLAPSED) == 0u;
}

// Treelet restructuring (after Karras and Aila, "Fast Parallel Construction of High-Quality
// Bounding Volume Hierarchies", 2013, with the treelet rebuilt by greedy agglomeration as
// Domingues and Pedrini's ATRBVH, 2015), at internal node i whose children l (slot 2i+1) and
// r (slot 2i+2) are finished: the treelet grows from {l, r} by opening its largest-area member
// that is an internal, uncollapsed node until it has LBVH_TREELET members (or none opens); the
// members are then merged pairwise, the pair whose union has the least area first, down to two,
// i's new children. The subtree's SAH cost changes by exactly the sum of the inner nodes' areas
// (every member and i's box stay), so the new shape is taken only where that sum is smaller.
// The opened nodes' ids (their child pairs, cost words) carry the new inner nodes; their ranges
// are left as they were (a node below i is never collapsed after, lbvh_remap reads ranges of
// collapsed nodes only, and i's leaf set does not change). A three-member treelet is Kensler's
// tree rotation (2008), which this pass took before. l and r come back as they are after.
#define LBVH_TREELET 9u
// Only nodes over at least this many triangles restructure (as Karras and Aila's gamma): below,
// the collapse decides the leaves, and the passes' few ready threads a warp pay for the rest.
#define LBVH_TREELET_FROM 9u
#define LBVH_CLUSTERS (2u * LBVH_TREELET - 1u)

float node_area(pc_bvh_node c)
{
    return half_area(c.bmin.xyz, c.bmax.xyz);
}

// A member's node record from its box and w words (x: bmin.w, y: bmax.w).
pc_bvh_node member_node(vec3 lo, vec3 hi, uvec2 w)
{
    pc_bvh_node c;
    c.bmin = vec4(lo, uintBitsToFloat(w.x));
    c.bmax = vec4(hi, uintBitsToFloat(w.y));
    return c;
}

void restructure(Nodes nodes, LbvhUints s, uint n, uint at, uint i, inout pc_bvh_node l,
                 inout pc_bvh_node r)
{
    /* clusters: [0, nm) the members, then one a merge, in order; a member is kept as its box,
     * its w words, its area and whether it may be opened (fewer live values than whole nodes) */
    vec3 lo[LBVH_CLUSTERS], hi[LBVH_CLUSTERS];
    uvec2 mw[LBVH_TREELET];
    float area[LBVH_TREELET];
    bool opens[LBVH_TREELET];
    uint ids[LBVH_TREELET - 2u];
    lo[0] = l.bmin.xyz, hi[0] = l.bmax.xyz, mw[0] = floatBitsToUint(vec2(l.bmin.w, l.bmax.w));
    lo[1] = r.bmin.xyz, hi[1] = r.bmax.xyz, mw[1] = floatBitsToUint(vec2(r.bmin.w, r.bmax.w));
    area[0] = node_area(l), area[1] = node_area(r);
    opens[0] = rotatable(s, n, at, l), opens[1] = rotatable(s, n, at, r);
    uint nm = 2u, nf = 0u;
    float was = 0.0;
    while (nm < LBVH_TREELET) {
        uint pick = LBVH_TREELET;
        float big = -1.0;
        for (uint j = 0u; j < nm; j++)
            if (opens[j] && area[j] > big) big = area[j], pick = j;
        if (pick == LBVH_TREELET) break;
        uint f = mw[pick].x;
        ids[nf++] = (f - 1u) / 2u;
        was += big;
        for (uint side = 0u; side < 2u; side++) {
            uint j = side == 0u ? pick : nm;
            pc_bvh_node c = nodes.n[f + side];
            lo[j] = c.bmin.xyz, hi[j] = c.bmax.xyz;
            mw[j] = floatBitsToUint(vec2(c.bmin.w, c.bmax.w));
            area[j] = node_area(c);
            opens[j] = rotatable(s, n, at, c);
        }
        nm++;
    }
    if (nf == 0u) return;
    uint kid[LBVH_TREELET - 2u][2];
    uint live[LBVH_TREELET];
    for (uint j = 0u; j < nm; j++) live[j] = j;
    uint nl = nm, nc = nm;
    float now = 0.0;
    while (nl > 2u) {
        float least = uintBitsToFloat(0x7f800000u);
        uint a = 0u, b = 1u;
        for (uint x = 0u; x + 1u < nl; x++)
            for (uint y = x + 1u; y < nl; y++) {
                float u = half_area(min(lo[live[x]], lo[live[y]]), max(hi[live[x]], hi[live[y]]));
                if (u < least) least = u, a = x, b = y;
            }
        lo[nc] = min(lo[live[a]], lo[live[b]]);
        hi[nc] = max(hi[live[a]], hi[live[b]]);
        kid[nc - nm][0] = live[a];
        kid[nc - nm][1] = live[b];
        now += half_area(lo[nc], hi[nc]);
        live[a] = nc++;
        live[b] = live[--nl];
    }
    float root = half_area(min(l.bmin.xyz, r.bmin.xyz), max(l.bmax.xyz, r.bmax.xyz));
    if (!(now < was - 1e-6 * root)) return;
    /* write the new shape: cluster c >= nm is inner node ids[c - nm] */
    float cost[LBVH_CLUSTERS];
    uint height[LBVH_CLUSTERS];
    for (uint j = 0u; j < nm; j++) {
        pc_bvh_node c = member_node(lo[j], hi[j], mw[j]);
        cost[j] = child_cost(s, n, at, c);
        height[j] = child_height(s, n, at, c);
    }
    for (uint c = nm; c < nc; c++) {
        uint id = ids[c - nm], a = kid[c - nm][0], b = kid[c - nm][1];
        cost[c] = half_area(lo[c], hi[c]) + cost[a] + cost[b];
        height[c] = 1u + max(height[a], height[b]);
        s.v[lbvh_cost_at(n, at) + id] = floatBitsToUint(cost[c]);
        uint done = s.v[lbvh_done_at(n, at) + id] & LBVH_DONE_PASS;
        s.v[lbvh_done_at(n, at) + id] = done | (height[c] << LBVH_HEIGHT_SHIFT);
    }
    for (uint c = nm; c <= nc; c++) {
        /* the children of cluster c (c == nc: node i, whose children are the two left live) */
        uint first = c == nc ? 2u * i + 1u : 2u * ids[c - nm] + 1u;
        for (uint side = 0u; side < 2u; side++) {
            uint k = c == nc ? live[side] : kid[c - nm][side];
            uvec2 w = k < nm ? mw[k] : uvec2(2u * ids[k - nm] + 1u, 0u);
            pc_bvh_node rec = member_node(lo[k], hi[k], w);
            nodes.n[first + side] = rec;
            if (w.y == 0u) s.v[lbvh_node_slot_at(n, at) + (w.x - 1u) / 2u] = first + side;
            if (c == nc && side == 0u) l = rec;
            if (c == nc && side == 1u) r = rec;
        }
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
        vec3 lo, hi;
        lbvh_triangle_box(pc.buf0, tri, lo, hi);
        uint slot = s.v[lbvh_leaf_slot_at(n, at) + i];
        nodes.n[slot].bmin = vec4(lo, uintBitsToFloat(i));
        nodes.n[slot].bmax = vec4(hi, uintBitsToFloat(1u));
        return;
    }
    if (i + 1u >= n || s.v[lbvh_done_at(n, at) + i] != 0u) return;
    pc_bvh_node l = nodes.n[2u * i + 1u], r = nodes.n[2u * i + 2u];
    if (!child_ready(s, n, at, l, k) || !child_ready(s, n, at, r, k)) return;
    if ((s.v[lbvh_range_at(n, at) + 2u * i + 1u] & LBVH_COUNT_MASK) >= LBVH_TREELET_FROM)
        restructure(nodes, s, n, at, i, l, r);
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
    uint height = 1u + max(child_height(s, n, at, l), child_height(s, n, at, r));
    s.v[lbvh_done_at(n, at) + i] = k | (height << LBVH_HEIGHT_SHIFT);
    if (i == 0u) {
        s.v[lbvh_args_at(n, at)] = 0u;
        bool collapsed = (s.v[lbvh_range_at(n, at) + 1u] & LBVH_COLLAPSED) != 0u;
        s.v[LBVH_DEPTH_AT] = collapsed ? 0u : height;
    }
}
