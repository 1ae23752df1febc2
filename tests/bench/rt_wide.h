/* rt_wide.h: the benchmark's "wide" tracer's data on the GPU: the BVHs an rd_gpu_scene uploaded,
 * read back as uploaded, collapsed to 4-wide nodes (bvh_wide.h) and uploaded next to them.
 * Traced by tests/bench/shaders/rtb_trace_wide.comp over the scene's own triangles, instances
 * and TLAS index. Benchmark code only. */
#ifndef RTB_RT_WIDE_H
#define RTB_RT_WIDE_H

#include "renderer/gpu_scene.h"
#include "renderer/vk_buffer.h"

typedef struct rtb_wide_gpu {
    rd_buffer nodes, mesh_root, refs; /* refs: one rtb_wide_refs, the shader's buf2 */
    uint32_t node_count, depth;
    uint64_t node_bytes, binary_node_bytes; /* wide nodes; the scene's BLAS + TLAS nodes */
    double collapse_ms;                     /* CPU, BLASes and TLAS */
} rtb_wide_gpu;

/* Builds and uploads the wide nodes of gs. On failure everything is released. */
rd_vk_result rtb_wide_gpu_create(rd_vk *vk, rtb_wide_gpu *w, const rd_gpu_scene *gs, char *err,
                                 size_t errlen);
void rtb_wide_gpu_destroy(rd_vk *vk, rtb_wide_gpu *w); /* idempotent */

#endif
