// ploc.glsl: the scratch layout and cluster helpers of the GPU PLOC builder (shaders/ploc_*.comp,
// renderer/accel/gpu_ploc.c mirrors the layout: ploc_words). The keys and bounds are the LBVH's
// (lbvh.glsl: words [0, 8) bounds, node count and depth, then the sorted keys); the PLOC area
// starts at word `at` (params.y, a multiple of 4), in uints:
//   [at, at + 16): control; word 0 the merges made so far (the next cluster id is n + it);
//   then a record of PC_PLOC_LOG_WORDS a round (PC_PLOC_ROUNDS_ALL of them): the round's indirect
//   dispatches and counts (PLOC_LOG_* below);
//   cur0[n], cur1[n]: the clusters in place order (round r reads cur(r % 2), writes the other);
//   nn[n]: each place's nearest neighbour's place;
//   sums[2 * blocks]: per block of PC_PLOC_BLOCK places its (places kept, merges), then their
//   exclusive prefix;
//   clusters[2n - 1] (16-byte aligned): PlocCluster, ids 0..n-1 the triangles (id = triangle
//   index), n + k the k-th merge (by round, then place): children before parents, root 2n - 2.
#ifndef PLOC_GLSL
#define PLOC_GLSL

#include "lbvh.glsl"

// The control and round records' words are PC_PLOC_* (bvh_build_types.h, shared with gpu_ploc.c):
// a round's indirect dispatches (groups in rows: x, y, 1) of its neighbour search (one thread a
// place), of its block passes (a workgroup a block) and of its output (one thread a cluster it
// made, shaders/ploc_emit.comp); its place count, merge base and merges.

// a cluster's count word: triangles below (bits 0-23) and whether it becomes one output leaf
#define PLOC_COLLAPSED 0x40000000u
#define PLOC_COUNT_MASK 0x00ffffffu

// lo.xyz / hi.xyz: the box (empty: +inf / -inf); lo.w: the subtree's SAH cost with its
// collapses; hi.w: its output height (levels below it, as a float);
// info: x count | PLOC_COLLAPSED, y triangles with a non-finite vertex below, z, w children
// (0xffffffff for a triangle);
// out: x output nodes below it (0 for a leaf), then written top-down by ploc_emit: y its
// output slot (0xffffffff: none, inside a collapsed leaf), z the slot of its first child,
// w its first triangle in prim_index.
struct PlocCluster {
    vec4 lo;
    vec4 hi;
    uvec4 info;
    uvec4 out_;
};
layout(buffer_reference, std430, buffer_reference_align = 16) coherent buffer PlocClusters
{
    PlocCluster c[];
};

uint ploc_blocks(uint n)
{
    return (n + PC_PLOC_BLOCK - 1u) / PC_PLOC_BLOCK;
}
uint ploc_log_at(uint at, uint round)
{
    return at + PC_PLOC_CTRL_WORDS + round * PC_PLOC_LOG_WORDS;
}
uint ploc_cur_at(uint n, uint at, uint round)
{
    return at + PC_PLOC_CTRL_WORDS + PC_PLOC_ROUNDS_ALL * PC_PLOC_LOG_WORDS + (round % 2u) * n;
}
uint ploc_nn_at(uint n, uint at)
{
    return at + PC_PLOC_CTRL_WORDS + PC_PLOC_ROUNDS_ALL * PC_PLOC_LOG_WORDS + 2u * n;
}
uint ploc_sums_at(uint n, uint at)
{
    return ploc_nn_at(n, at) + n;
}
uint ploc_clusters_at(uint n, uint at)
{
    return (ploc_sums_at(n, at) + 2u * ploc_blocks(n) + 3u) & ~3u;
}
PlocClusters ploc_clusters(uint64_t scratch, uint n, uint at)
{
    return PlocClusters(scratch + 4ul * uint64_t(ploc_clusters_at(n, at)));
}

// Half the surface area of a box (0 for an empty one), as ploc_ref.c computes it: `precise`
// keeps the compiler from fusing its products, so that the GPU's choices (nearest neighbours,
// collapses) are the reference's.
float ploc_half_area(vec3 lo, vec3 hi)
{
    if (!all(lessThanEqual(lo, hi))) return 0.0;
    precise vec3 d = hi - lo;
    precise float a = d.x * d.y + d.y * d.z + d.z * d.x;
    return a;
}

// A dispatch of `groups` workgroups as rows of at most `row` (lbvh_group numbers them).
void ploc_write_args(LbvhUints s, uint at, uint groups, uint row)
{
    uint x = min(groups, row);
    s.v[at] = x;
    s.v[at + 1u] = x == 0u ? 0u : (groups + x - 1u) / x;
    s.v[at + 2u] = 1u;
}

#endif
