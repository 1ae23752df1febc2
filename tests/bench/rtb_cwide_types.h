/* rtb_cwide_types.h: the compressed 8-wide BVH node of the benchmark's "cwide" tracer,
 * compiled by C11 (tests/bench/bvh_cwide.c) and glslang (tests/bench/shaders/rtb_trace_cwide.comp).
 * Benchmark only: the product traverses pc_bvh_node (shaders/gpu_types.h). Include after
 * gpu_types.h.
 *
 * After Ylitie, Karras, Laine, "Efficient Incoherent Ray Traversal on GPUs Through Compressed
 * Wide BVHs", HPG 2017, sec. 3.1 (fig. 2), 80 bytes per node: the node's own box origin p, a
 * power-of-two scale 2^e per axis, and per child an 8-bit lo and hi per axis; child k's box on
 * axis a is [p + qlo * 2^e, p + qhi * 2^e], evaluated in float (q * 2^e is exact, so a fused and
 * an unfused multiply-add give the same plane). qlo is rounded down and qhi up until that float
 * box contains the child's exact box, so the compressed tree is conservative.
 *
 * Two differences from the paper, both because leaves keep their (first, count) into the
 * triangle and TLAS-index arrays the binary BVH indexes (the paper reorders triangles so that
 * a node's leaves are contiguous and a 5-bit offset finds them):
 *   - a leaf child's first primitive is read from a separate uint array, leaf_first, at the
 *     node's leaf_base plus the leaf's rank among the node's leaves (4 bytes per leaf, counted
 *     as node memory); its count sits in the child's meta byte;
 *   - the meta byte gives the child's rank directly instead of the paper's slot index and
 *     imask, so the node has a spare byte.
 * Interior children are stored contiguously from child_base, in slot order (as in the paper),
 * and leaf entries from leaf_base in slot order too: a child's rank is the number of children
 * of its kind in lower slots, which the group traversal (rtb_trace_cwide.comp with
 * RTB_CWIDE_GROUPS) computes with a population count instead of reading the meta byte.
 * Slots are ordered by ray octant (bvh_cwide.h).
 *
 * Words, as uvec4/vec4 for std430 (bytes little-endian, byte k = bits 8k..8k+7):
 *   origin.xyz  p (float); origin.w uint bits: byte a (a = 0, 1, 2 for x, y, z) = the biased
 *               float exponent of the scale of axis a (scale = uintBitsToFloat(byte << 23),
 *               1..254), byte 3 = 0;
 *   refs.x      child_base: wide node index of the first interior child;
 *   refs.y      leaf_base: index into leaf_first of the first leaf child;
 *   refs.z, .w  meta of children 0-3 and 4-7, a byte each: 0 = unused slot;
 *               RTB_CWIDE_INTERIOR | r = interior child, node child_base + r;
 *               count << 3 | r (count in [1, RD_BVH_MAX_LEAF]) = leaf, first primitive
 *               leaf_first[leaf_base + r];
 *   q_x         x: qlo of children 0-3, y: qlo of 4-7, z: qhi of 0-3, w: qhi of 4-7; q_y, q_z
 *               the same for y and z. Unused slots hold qlo 255, qhi 0, but only meta marks
 *               them (the traversal masks them out).
 */
#ifndef RTB_CWIDE_TYPES_H
#define RTB_CWIDE_TYPES_H

#define RTB_CWIDE 8
#define RTB_CWIDE_INTERIOR 0x80u
/* Traversal stack entries of rtb_trace_cwide.comp; rtb_wide_stack_need(RTB_CWIDE, depth) must
 * not exceed it (depth 15 or less). The group traversal needs less: a group per level of the
 * TLAS and of one BLAS and the instances of one TLAS node's leaves, 2 (depth + 1) +
 * RTB_CWIDE * RD_BVH_MAX_LEAF = 96 entries at depth 15. */
#define RTB_CWIDE_STACK 256

PC_STRUCT(rtb_cwide_node)
{
    pc_vec4 origin;
    pc_uvec4 refs;
    pc_uvec4 q_x;
    pc_uvec4 q_y;
    pc_uvec4 q_z;
}
PC_END(rtb_cwide_node);

/* What the cwide tracer reads besides the scene: nodes = rtb_cwide_node[] (every BLAS and the
 * TLAS), leaf_first = uint[], mesh_root = uint[] compressed root per mesh (instance.info.y),
 * info.x = the TLAS's compressed root. */
PC_STRUCT(rtb_cwide_refs)
{
    pc_u64 nodes;
    pc_u64 leaf_first;
    pc_u64 mesh_root;
    pc_u64 unused;
    pc_uvec4 info;
}
PC_END(rtb_cwide_refs);

#ifndef PC_GLSL
_Static_assert(sizeof(rtb_cwide_node) == 80, "rtb_cwide_node size");
_Static_assert(offsetof(rtb_cwide_node, refs) == 16, "rtb_cwide_node.refs offset");
_Static_assert(offsetof(rtb_cwide_node, q_x) == 32, "rtb_cwide_node.q_x offset");
_Static_assert(offsetof(rtb_cwide_node, q_y) == 48, "rtb_cwide_node.q_y offset");
_Static_assert(offsetof(rtb_cwide_node, q_z) == 64, "rtb_cwide_node.q_z offset");
_Static_assert(sizeof(rtb_cwide_refs) == 48, "rtb_cwide_refs size");
_Static_assert(offsetof(rtb_cwide_refs, mesh_root) == 16, "rtb_cwide_refs.mesh_root offset");
_Static_assert(offsetof(rtb_cwide_refs, info) == 32, "rtb_cwide_refs.info offset");
#endif

#endif
