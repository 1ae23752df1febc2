/* rt_wide.h: the data of the benchmark's wide tracers on the GPU: the BVHs an rd_gpu_scene
 * uploaded, read back as uploaded, collapsed to 4-wide nodes (bvh_wide.h, the "wide" tracer)
 * and to compressed 8-wide nodes (bvh_cwide.h, the "cwide" tracer) and uploaded next to them.
 * Traced by tests/bench/shaders/rtb_trace_wide.comp and rtb_trace_cwide.comp over the scene's
 * own triangles, instances and TLAS index. Benchmark code only. */
#ifndef RTB_RT_WIDE_H
#define RTB_RT_WIDE_H

#include "renderer/accel/gpu_scene.h"
#include "renderer/vk/vk_buffer.h"

typedef struct rtb_wide_gpu {
    rd_buffer nodes, mesh_root, refs; /* refs: one rtb_wide_refs, the shader's buf2 */
    uint32_t node_count, depth;
    uint64_t node_bytes, binary_node_bytes; /* wide nodes; the scene's BLAS + TLAS nodes */
    double collapse_ms;                     /* CPU, BLASes and TLAS */
    struct {                                /* compressed 8-wide nodes */
        rd_buffer nodes, leaf_first, mesh_root, refs; /* refs: one rtb_cwide_refs */
        uint32_t node_count, leaf_count, depth;
        uint64_t node_bytes; /* nodes and leaf_first */
        double collapse_ms;
    } cwide;
} rtb_wide_gpu;

/* Builds and uploads the 4-wide and the compressed 8-wide nodes of gs. On failure everything is
 * released. */
rd_vk_result rtb_wide_gpu_create(rd_vk *vk, rtb_wide_gpu *w, const rd_gpu_scene *gs, char *err,
                                 size_t errlen);
void rtb_wide_gpu_destroy(rd_vk *vk, rtb_wide_gpu *w); /* idempotent */

#endif
