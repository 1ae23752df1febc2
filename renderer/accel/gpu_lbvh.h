/* gpu_lbvh.h: a BVH over a triangle mesh built on the GPU, a linear BVH after Karras 2012
 * ("Maximizing Parallelism in the Construction of BVHs, Octrees, and k-d Trees"), in the node
 * layout the traversal reads (pc_bvh_node, as rd_bvh: nodes[0] the root, an interior node's
 * children adjacent at first and first + 1, a leaf's triangles [first, first + count) of
 * prim_index). Passes (shaders/lbvh_*.comp, a barrier between each):
 *   1. lbvh_bounds: the centroids' box, by atomics (two dispatches: reset, then widen);
 *   2. lbvh_morton: keys (30-bit Morton code of the centroid, triangle index);
 *   3. lbvh_sort: an LSD radix sort of the n keys by their code, stable, so ascending by
 *      (code, triangle index) as lbvh_morton writes them in triangle order: 4 passes of 8 bits
 *      over the 31-bit code (bit 30: non-finite), each a histogram per tile of 1024 keys (a
 *      64-thread workgroup), an exclusive prefix sum of the (digit, tile) counts in three
 *      dispatches and a stable scatter (a key's rank among the equal digits before it in its
 *      tile, in shared memory) into the other key buffer: 20 dispatches whatever n (8192 tiles
 *      for 8 M keys), O(n) work (rd_gpu_lbvh_record_sort). Not 3 passes of 11 bits: an odd
 *      count ends in the other buffer (a copy back), and 2048 digits a tile make 8x the counts
 *      to scan; 256 fit in shared memory beside the scatter's;
 *   4. lbvh_hierarchy: Karras's radix tree, one thread per internal node; internal node i's
 *      children go to nodes 2i+1 and 2i+2, so 2n-1 nodes with the root at 0;
 *   5. lbvh_boxes: the leaves (one thread each), then 64 indirect passes of one thread per
 *      internal node (group counts written by lbvh_hierarchy, in rows as every pass), each
 *      finishing the nodes whose children were finished in earlier passes (exact unions; a
 *      radix tree over 64-bit keys has at most 64 internal levels); the pass that finishes the
 *      root zeroes the group count of those after it. No pass reads a box written in the same
 *      dispatch. (Karras's single pass, a thread climbing from each leaf with an atomic counter
 *      per node, coherent buffers and memory barriers, gave wrong boxes above the first level
 *      on lavapipe with 64-thread workgroups and right ones with 1-thread workgroups (34 ms
 *      there against these passes' 69 ms for 100 K triangles); why is not known yet.)
 *      Each node over at least 9 triangles, once its children are finished, first restructures
 *      its treelet of up to 9 members (Karras and Aila 2013; rebuilt by greedy agglomeration as
 *      ATRBVH, kept where its inner nodes' areas sum less), so subtrees move out of the Morton
 *      medians' cuts. The
 *      same passes weigh the collapse of each subtree of at most max_leaf triangles into one
 *      leaf (their sorted leaves are contiguous: a treelet below a node does not change its
 *      leaf set, and a restructured node is not collapsed after) by SAH, bottom-up: a node's
 *      cost is the least of its split's (its area plus its children's costs) and one leaf's
 *      (its area times its triangles); where the leaf wins, the node is flagged and its
 *      descendants marked gone. Each finished node's height rides in its done word; the root's
 *      thread writes the tree's depth beside the node count.
 *   6. lbvh_scan, lbvh_remap: the nodes that stay numbered by a prefix sum and copied to the
 *      output, a flagged node as one leaf.
 * Leaf policy: the least cost over the collapses of the radix tree's subtrees of at most
 * max_leaf (default 4) triangles, a leaf's SAH weighed by PC_LBVH_LEAF_WEIGHT (0.75; SAH_TRAVERSAL
 * = SAH_INTERSECT = 1 as the CPU builder's): pure SAH (weight 1) gave 1.09 times the CPU
 * builder's SAH cost on random soups but traced 5% slower on an H200 than this weight, which
 * gives 1.11-1.14 there and 1.17 on the bench's spheres (lbvh_boxes.comp has the numbers; 1.20
 * when every such subtree became a leaf). Depth: at most 64 (a level a bit of the 64-bit
 * keys), but not kept within RD_BVH_MAX_DEPTH (48) as the CPU builder's is; random and
 * degenerate meshes of a few thousand triangles stay near 2 log2 n (test_gpu_lbvh prints it);
 * rd_gpu_lbvh_build_download reports it.
 * Children may sit before their parent (internal node i's slot is its parent's choice);
 * rd_gpu_refit_blas_create(_at) takes such trees (its levels come from a walk from the root).
 * A triangle with a non-finite vertex gets an empty box and a key past every finite one.
 * gpu_scene_deform.c rebuilds a deforming mesh's BLAS with it, and gpu_scene_lbvh.c builds large
 * static meshes' at upload (PROBECAST_BLAS_BUILD; the rest build on the CPU, renderer/accel/bvh.h).
 * The same builder has a second method over the same sorted keys, PLOC clustering (method
 * RD_GPU_BVH_PLOC, gpu_ploc.h): passes 4-6 replaced, the same output layout and collapse rule.
 * NVIDIA H100 (tests/bench/results/h100/gpu_ploc_stop49.txt): PLOC builds 8 M triangles in 17.9
 * ms against the LBVH's 26.0 at SAH 1.08 against 1.15 of the CPU builder's, and real meshes' trees
 * at 0.93 and 1.23 against 1.07 and 1.43; the renderer's primary rays trace its upload trees
 * faster (builtin:interior 0.62 ms against 0.82), test_gpu_lbvh's incoherent bench rays trace the
 * LBVH's soups faster (0.95 against 0.64 of the CPU tree's speed). Deforming meshes' rebuilds keep
 * the LBVH until the deform benchmark has measured PLOC.
 */
#ifndef RD_GPU_LBVH_H
#define RD_GPU_LBVH_H

#include <stdint.h>

#include "renderer/accel/bvh.h"
#include "renderer/vk/vk_compute.h"
#include "shaders/bvh_build_types.h"

/* The hierarchy over the sorted keys (rd_gpu_lbvh_builder.method): the LBVH's radix tree with
 * treelet restructuring (the passes above), or PLOC clustering (gpu_ploc.h). Both end in the
 * same node layout, leaves collapsed by the same weighted SAH. */
#define RD_GPU_BVH_LBVH 0u
#define RD_GPU_BVH_PLOC 1u

typedef struct rd_gpu_lbvh_builder {
    rd_pipeline bounds, morton, sort, hierarchy, boxes, scan, remap;
    rd_pipeline ploc_init, ploc_round, ploc_emit;
    /* RD_GPU_BVH_LBVH (as create leaves it) or RD_GPU_BVH_PLOC; a scratch buffer is sized for
     * one method (rd_gpu_lbvh_scratch_bytes). */
    uint32_t method;
    /* Groups a row of a pass's dispatch (x; rows in y): 0 (as create leaves it) = 65535, the
     * least per-dimension limit Vulkan allows. A test hook: tests lower it so that small meshes
     * need several rows. */
    uint32_t row_groups;
} rd_gpu_lbvh_builder;

rd_vk_result rd_gpu_lbvh_builder_create(rd_vk *vk, rd_gpu_lbvh_builder *b, char *err,
                                        size_t errlen);
void rd_gpu_lbvh_builder_destroy(rd_vk *vk, rd_gpu_lbvh_builder *b); /* idempotent */

/* Triangles one build takes at most: 2^24 (16.7 M; lbvh_morton's N padded keys at most 2^24). Every
 * pass is one dispatch of rows of at most 65535 groups (x) in y, the indirect ones too, so a pass
 * of 2n threads needs 2n / (64 * 65535) rows (9 for 2^24); the limit is set by 32-bit indices
 * in the shaders (scratch words, 2n - 1 nodes) with room to spare, and by memory: 2^24
 * triangles take about 0.6 GiB of positions, 1.7 GiB of scratch (0.14 of it the sort's) and 1 GiB
 * of nodes. */
#define RD_GPU_LBVH_MAX_TRIANGLES (1u << 24)

/* Nodes a build over tri_count triangles writes at most: 2 tri_count - 1 (1 for none); with
 * leaves of several triangles fewer, their count at RD_GPU_LBVH_COUNT_OFFSET in the scratch. */
uint32_t rd_gpu_lbvh_node_count(uint32_t tri_count);
/* Bytes of scratch a build with b's method needs (16-byte aligned device address). */
uint64_t rd_gpu_lbvh_scratch_bytes(const rd_gpu_lbvh_builder *b, uint32_t tri_count);
/* Records the sort of a build (pass 3) on its own, for tests: sorts n keys (at most
 * RD_GPU_LBVH_MAX_TRIANGLES; uvec2 each at keys: x a payload, y the 32-bit code) ascending by y,
 * stably, in place. keys and sort_scratch (rd_gpu_lbvh_sort_scratch_bytes(n) bytes; a
 * build's sits at the end of its scratch): 8-byte aligned. Ends with a barrier. */
void rd_gpu_lbvh_record_sort(rd_cmd *c, const rd_gpu_lbvh_builder *b, VkDeviceAddress keys,
                             uint32_t n, VkDeviceAddress sort_scratch);
uint64_t rd_gpu_lbvh_sort_scratch_bytes(uint32_t n);
/* Byte offsets in the scratch of the uint node count a build writes, and of the tree's depth
 * (levels below the root), which follows it. */
#define RD_GPU_LBVH_COUNT_OFFSET 24u
#define RD_GPU_LBVH_DEPTH_OFFSET 28u

/* Records a build into c (tri_count at most RD_GPU_LBVH_MAX_TRIANGLES: asserted; callers check
 * it, as rd_gpu_lbvh_build_download does, and report an error beyond it). positions: device address
 * of 9 floats per triangle; max_leaf: a subtree of at most this many triangles may become one leaf
 * (0 = 4 as the CPU builder, at most RD_BVH_MAX_LEAF; 1 = one triangle a leaf); nodes: room for
 * rd_gpu_lbvh_node_count(tri_count) pc_bvh_node (indices relative to it); prim_index: room for
 * tri_count uints (leaf order -> triangle); scratch: a buffer of rd_gpu_lbvh_scratch_bytes
 * (also read as indirect dispatch arguments). All must stay
 * alive until c has run; the results are ready after the barrier that ends the recording.
 * timer (may be NULL): begun by the caller; marks lbvh_keys, lbvh_sort, lbvh_hierarchy,
 * lbvh_boxes and lbvh_collapse (those that run). */
void rd_gpu_lbvh_record(rd_cmd *c, const rd_gpu_lbvh_builder *b, VkDeviceAddress positions,
                        uint32_t tri_count, uint32_t max_leaf, VkDeviceAddress nodes,
                        VkDeviceAddress prim_index, const rd_buffer *scratch, rd_timer *timer);

/* Blocking convenience (tests, benchmarks): uploads positions, builds, waits, and reads the
 * tree back into out (an rd_bvh the caller frees with rd_bvh_destroy; depth walked on the CPU,
 * and an error where the build wrote another). gpu_ms (may be NULL): wall time of the submit
 * and wait of the build alone; timer (may be NULL): begun here and resolved after the wait, one
 * section a pass. On error out is zeroed; more than RD_GPU_LBVH_MAX_TRIANGLES is RD_VK_ERR_UNSUPPORTED with a message,
 * before anything is read or allocated. */
rd_vk_result rd_gpu_lbvh_build_download(rd_vk *vk, const rd_gpu_lbvh_builder *b,
                                        const float *positions, uint32_t tri_count,
                                        uint32_t max_leaf, rd_timer *timer, rd_bvh *out,
                                        double *gpu_ms, char *err, size_t errlen);

#endif
