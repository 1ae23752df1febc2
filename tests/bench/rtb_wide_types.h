/* rtb_wide_types.h: the 4-wide BVH node of the benchmark's "wide" tracer, compiled by C11
 * (tests/bench/bvh_wide.c) and glslang (tests/bench/shaders/rtb_trace_wide.comp). Benchmark
 * only: the product traverses pc_bvh_node (shaders/gpu_types.h). Include after gpu_types.h.
 *
 * A node holds the boxes of up to four children as structure of arrays (Wald et al.,
 * "Getting Rid of Packets", RT 2008, the QBVH layout), so one node load tests four boxes.
 * child[k]/count[k]: count 0 = interior child, wide node index child[k]; count in
 * [1, RD_BVH_MAX_LEAF] = leaf over primitives [child[k], child[k] + count) of the same arrays
 * the binary BVH indexes (scene.tris, scene.tlas_index); RTB_WIDE_EMPTY = unused slot, whose
 * box is the inverted [+inf, -inf] that the direction-signed slab test always rejects. */
#ifndef RTB_WIDE_TYPES_H
#define RTB_WIDE_TYPES_H

#define RTB_WIDE 4
#define RTB_WIDE_EMPTY 0xffffffffu
/* Traversal stack entries of rtb_trace_wide.comp; rtb_wide_stack_need(RTB_WIDE, depth) must
 * not exceed it. */
#define RTB_WIDE_STACK 192

PC_STRUCT(rtb_wide_node)
{
    pc_vec4 lo_x;
    pc_vec4 hi_x;
    pc_vec4 lo_y;
    pc_vec4 hi_y;
    pc_vec4 lo_z;
    pc_vec4 hi_z;
    pc_uvec4 child;
    pc_uvec4 count;
}
PC_END(rtb_wide_node);

/* What the wide tracer reads besides the scene: nodes = rtb_wide_node[] (every BLAS and the
 * TLAS), mesh_root = uint[] wide root per mesh (instance.info.y), info.x = the TLAS's wide root. */
PC_STRUCT(rtb_wide_refs)
{
    pc_u64 nodes;
    pc_u64 mesh_root;
    pc_uvec4 info;
}
PC_END(rtb_wide_refs);

#ifndef PC_GLSL
_Static_assert(sizeof(rtb_wide_node) == 128, "rtb_wide_node size");
_Static_assert(offsetof(rtb_wide_node, hi_z) == 80, "rtb_wide_node.hi_z offset");
_Static_assert(offsetof(rtb_wide_node, child) == 96, "rtb_wide_node.child offset");
_Static_assert(offsetof(rtb_wide_node, count) == 112, "rtb_wide_node.count offset");
_Static_assert(sizeof(rtb_wide_refs) == 32, "rtb_wide_refs size");
_Static_assert(offsetof(rtb_wide_refs, info) == 16, "rtb_wide_refs.info offset");
#endif

#endif
