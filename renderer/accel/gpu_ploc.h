/* gpu_ploc.h: the GPU PLOC hierarchy (Meister and Bittner 2018, "Parallel Locally-Ordered
 * Clustering for Bounding Volume Hierarchy Construction"), the second method of the GPU BVH
 * builder (rd_gpu_lbvh_builder.method = RD_GPU_BVH_PLOC, gpu_lbvh.h): after the LBVH's keys and
 * radix sort, clusters in Morton order merge with their nearest neighbour (least union area
 * within PC_PLOC_RADIUS places) where the choice is mutual, round after round, until one is left
 * (shaders/ploc_round.comp: a neighbour search, a block count, a scan and a scatter a round, each
 * round's dispatches sized by the round before, indirectly); a merge's cluster decides at once
 * whether it becomes one leaf (the LBVH's weighted SAH collapse); then the output is written
 * top-down, a dispatch a round in reverse (shaders/ploc_emit.comp), depth-first as
 * tests/renderer/ploc_ref.c (the CPU reference, the same choices) lays it out. Internal to
 * gpu_lbvh.c, which records the keys and the sort and calls this. */
#ifndef RD_GPU_PLOC_H
#define RD_GPU_PLOC_H

#include <stdint.h>

#include "renderer/accel/gpu_lbvh.h"
#include "shaders/gpu_types.h"

/* Words of the PLOC area (shaders/ploc.glsl) for n triangles; it starts at a word offset that is
 * a multiple of 4. */
uint64_t rd_gpu_ploc_words(uint32_t n);

/* Records the clustering and the output after the keys are sorted (the scratch's keys as
 * gpu_lbvh.c leaves them); area_at: the PLOC area's word offset in the scratch. Ends with a
 * barrier; marks ploc_rounds and ploc_emit on timer (may be NULL). */
void rd_gpu_ploc_record(rd_cmd *c, const rd_gpu_lbvh_builder *b, VkDeviceAddress positions,
                        uint32_t n, uint32_t max_leaf, VkDeviceAddress nodes,
                        VkDeviceAddress prim_index, const rd_buffer *scratch, uint32_t area_at,
                        rd_timer *timer);

/* gpu_lbvh.c's dispatch of `groups` workgroups in rows (shaders/lbvh.glsl's lbvh_group), and the
 * groups of a row. */
void rd_gpu_lbvh_dispatch_rows(rd_cmd *c, const rd_gpu_lbvh_builder *b, const rd_pipeline *p,
                               const pc_push *push, uint64_t groups);
uint32_t rd_gpu_lbvh_row_groups(const rd_gpu_lbvh_builder *b);

#endif
