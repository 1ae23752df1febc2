/* gpu_refit.h: a BLAS refitted on the GPU for a deformed mesh (shaders/refit.comp): the node
 * boxes recomputed bottom-up over the topology of any valid tree (the CPU builder's, or the GPU
 * LBVH's, whose children may sit before their parent: levels are depths found by a walk from the
 * root), one dispatch per level
 * (deepest first; a level's nodes only read deeper ones, so no atomics and a deterministic
 * result; depth is ~log2(triangles / 4) + a few, so ~20-40 small dispatches per mesh). The nodes
 * keep pc_bvh_node's layout and w words, so the traversal reads them as it reads a CPU build.
 * Quality: rd_bvh_sah_cost of the refitted tree against a fresh build decides when to rebuild
 * (the caller's policy). gpu_scene_deform.c refits a deforming mesh's BLAS in place in the
 * scene's node buffer (rd_gpu_refit_blas_create_at). */
#ifndef RD_GPU_REFIT_H
#define RD_GPU_REFIT_H

#include <stdbool.h>
#include <stdint.h>

#include "renderer/accel/bvh.h"
#include "renderer/vk/vk_compute.h"

typedef struct rd_gpu_refitter {
    rd_pipeline refit;
} rd_gpu_refitter;

rd_vk_result rd_gpu_refitter_create(rd_vk *vk, rd_gpu_refitter *g, char *err, size_t errlen);
void rd_gpu_refitter_destroy(rd_vk *vk, rd_gpu_refitter *g); /* idempotent */

/* One BLAS on the GPU: its topology (node indices by level, deepest level first, then the
 * leaf-order -> triangle map) and where its nodes are: node index i (as pc_bvh_node's child
 * indices count) at node_address + 32 i, its node 0 at index node_base, its first triangle at
 * tri_base (leaf indices count from it). */
typedef struct rd_gpu_refit_blas {
    rd_buffer nodes; /* its own nodes (rd_gpu_refit_blas_create); none with _create_at */
    rd_buffer topology;
    VkDeviceAddress node_address;
    uint32_t node_base, tri_base;
    uint32_t node_count, prim_count, level_count;
    uint32_t *level_start; /* level_count + 1 entries into the topology's node list */
} rd_gpu_refit_blas;

/* Uploads bvh (built over the mesh's triangles, rd_bvh_build_triangles or the GPU LBVH) into nodes
 * of its own (indices relative to their start: node_base and tri_base 0). */
rd_vk_result rd_gpu_refit_blas_create(rd_vk *vk, rd_gpu_refit_blas *b, const rd_bvh *bvh, char *err,
                                      size_t errlen);
/* Uploads only bvh's topology, for nodes already on the GPU at node_address as a scene holds
 * them (rd_gpu_scene_fill_mesh: bvh's node i at index node_base + i, child indices plus
 * node_base, leaf indices plus tri_base, all counted from node_address). The refit writes those
 * nodes in place; b does not own them. */
rd_vk_result rd_gpu_refit_blas_create_at(rd_vk *vk, rd_gpu_refit_blas *b, const rd_bvh *bvh,
                                         VkDeviceAddress node_address, uint32_t node_base,
                                         uint32_t tri_base, char *err, size_t errlen);
void rd_gpu_refit_blas_destroy(rd_vk *vk, rd_gpu_refit_blas *b); /* idempotent */

/* When a refitted tree has degraded enough to rebuild: its SAH cost (rd_bvh_sah_cost over a
 * read-back of b's nodes) over a fresh CPU build's of the same deformed mesh past this ratio.
 * Measured with probecast_deformbench (a sheet skinned to two joints, bent 10-150 degrees from
 * its rest pose): 1.01-1.29 for 8 K and 66 K triangles, the worst at 150 degrees, where the
 * bend folds the tree's rest-pose split planes over each other; 1.25 rebuilds only such folds.
 * Its trace cost, measured since (NVIDIA H100, probecast_deformbench's swing cycle, refit only
 * for 10 s: tests/bench/results/h100/lbvh_treelets_stop48.txt): SAH ratios of 1.10-1.20 traced
 * at 0.81-0.85 of a fresh build's speed for 1 M triangles, 1.09-1.15 at 0.84-0.98 for 66 K; so
 * a refitted tree under this ratio may trace up to about a fifth slower than a fresh one. */
#define RD_GPU_REFIT_REBUILD_SAH_RATIO 1.25

/* true when the refitted tree (SAH cost sah_refitted) should be rebuilt, given a fresh build's
 * cost sah_fresh: the ratio above passed (a zero or non-finite cost: rebuild too). */
bool rd_gpu_refit_should_rebuild(double sah_refitted, double sah_fresh);

/* Records the refit of b over positions (device address of 9 floats per triangle, the mesh's
 * original triangle order, e.g. rd_gpu_deform_mesh's out positions), a barrier after each level. */
void rd_gpu_refit_record(rd_cmd *c, const rd_gpu_refitter *g, const rd_gpu_refit_blas *b,
                         VkDeviceAddress positions);

#endif
