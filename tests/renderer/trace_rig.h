/* trace_rig.h: one BLAS traced on the GPU by shaders/trace.glsl (through test_trace.comp), for
 * tests and benchmarks that compare trees: a one-instance scene over a tree and its triangles,
 * rays uploaded as test_trace.comp reads them, a timed trace, and the traversal speed. Shared by
 * test_gpu_lbvh and probecast_deformbench. */
#ifndef PC_TRACE_RIG_H
#define PC_TRACE_RIG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "renderer/accel/bvh.h"
#include "renderer/vk/vk_buffer.h"
#include "renderer/vk/vk_compute.h"
#include "renderer/vk/vk_context.h"

/* One ray's closest hit as test_trace.comp writes it (t as float bits; tri: the leaf-order
 * index, the tree's prim_index maps it back). */
typedef struct pc_trace_hit {
    uint32_t t, u, v, hit;
    uint32_t instance, tri, backface, pad;
} pc_trace_hit;

/* A one-instance scene: bvh (identity transform) under a one-leaf TLAS, its triangles (pos, 9
 * floats each) in leaf order. */
typedef struct pc_trace_scene {
    rd_buffer buf[5]; /* BLAS nodes, tris, instance, TLAS node, TLAS index */
    rd_buffer globals;
} pc_trace_scene;

bool pc_trace_scene_create(rd_vk *vk, pc_trace_scene *ts, const rd_bvh *bvh, const float *pos,
                           uint32_t n, char *err, size_t errlen);
void pc_trace_scene_destroy(rd_vk *vk, pc_trace_scene *ts);

/* The test_trace pipeline (destroy with rd_pipeline_destroy). */
rd_vk_result pc_trace_pipeline_create(rd_vk *vk, rd_pipeline *pipe, char *err, size_t errlen);

/* A device buffer of rays: (origin, tmin 0), (direction, tmax +inf). */
bool pc_trace_rays_upload(rd_vk *vk, rd_buffer *buf, const float *orgs, const float *dirs,
                          uint32_t rays, char *err, size_t errlen);

/* Traces rays through ts into res (a pc_trace_hit each) and waits. timer (may be NULL): begun
 * here, the trace marked "trace" and resolved. */
bool pc_trace_rays(rd_vk *vk, const rd_pipeline *pipe, const pc_trace_scene *ts,
                   const rd_buffer *ray_buf, const rd_buffer *res, uint32_t rays, rd_timer *timer,
                   char *err, size_t errlen);

/* Traversal speed of bvh over the rays in ray_buf: the best of reps GPU-timed traces (wall time
 * where the device has no timestamps), in Mrays/s; the hits go to hits (NULL: not read back).
 * 0 on error (printed). */
double pc_trace_speed(rd_vk *vk, const rd_pipeline *pipe, rd_timer *timer, const rd_bvh *bvh,
                      const float *pos, uint32_t n, const rd_buffer *ray_buf, const rd_buffer *res,
                      uint32_t rays, int reps, pc_trace_hit *hits);

/* Rays from random points on the sphere around the box [lo, hi] (centre, 1.5 x the half
 * diagonal) toward random points inside it, unit directions; deterministic (seeds bvh_check.h's
 * generator). */
void pc_sphere_rays(float *orgs, float *dirs, uint32_t rays, const float lo[3], const float hi[3]);

#endif
