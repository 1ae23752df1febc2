/* gpu_scene_internal.h: small helpers shared by the GPU scene's two files (gpu_scene.c, the GPU
 * half; gpu_scene_prep.c, the CPU half). Not part of the renderer's interface. */
#ifndef RD_GPU_SCENE_INTERNAL_H
#define RD_GPU_SCENE_INTERNAL_H

#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "shaders/gpu_types.h"
#include "renderer/accel/bvh.h"
#include "renderer/accel/gpu_scene.h"
#include "renderer/scene/scene.h"

static inline double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

static inline void *xcalloc(size_t n, size_t size)
{
    void *p = calloc(n ? n : 1, size ? size : 1);
    if (!p) {
        fprintf(stderr, "probecast: out of memory\n");
        abort();
    }
    return p;
}

static inline pc_vec4 v4(const float *p, float w)
{
    return (pc_vec4){p[0], p[1], p[2], w};
}

static inline float clamp01(float x)
{
    return x > 0.0f ? (x < 1.0f ? x : 1.0f) : 0.0f; /* NaN -> 0 */
}

/* BLAS node slots mesh m takes in the nodes buffer: what its BVH built (built), or for a mesh
 * that deforms the most any BVH of its triangles can take (2 n - 1), so that a rebuild after a
 * pose change fits in place. */
static inline uint64_t blas_slots(const rd_mesh *m, uint32_t built)
{
    return m->deform ? 2ull * m->tri_count : built;
}

/* Writes mesh m's BLAS (bvh, node 0 its root; vertices minus the local origin o) into nodes and
 * its triangle records in leaf order into tris and attrs: child and leaf indices are absolute,
 * the mesh's first node at node_base and first triangle at tri_base (gpu_scene_prep.c). */
void rd_gpu_scene_fill_mesh(const rd_scene *s, uint32_t m, const rd_bvh *bvh, const float o[3],
                            uint32_t node_base, uint32_t tri_base, pc_bvh_node *nodes, pc_tri *tris,
                            pc_tri_attr *attrs);

/* gpu_scene_deform.c: deforming meshes posed and refitted on the GPU (rd_gpu_scene_update_pose).
 * rd_gpu_scene_deform_built: the CPU just wrote mesh m's BLAS from bvh (its first triangle at
 * tri_base): the GPU state of m (its vertex arrays and source records, made once, and bvh's
 * topology) follows it, unless gs->deform_on_cpu. rd_gpu_scene_deform_on_gpu: whether m's next
 * pose goes to the GPU (refitted, or rebuilt there when due; else rebuilt on the CPU).
 * rd_gpu_scene_deform_run: poses and refits (or rebuilds with the GPU LBVH) the meshes
 * list[0..n) (each rd_gpu_scene_deform_on_gpu) in one submission, in the scene's buffers, and
 * sets their bounds and revisions; rebuild[k] = 1 where list[k] is to be rebuilt on the CPU now
 * (a GPU rebuild it was due could not be made or kept: too deep a tree, too many triangles, no
 * memory; the SAH checks that call for rebuilds run on a pool of their own).
 * rd_gpu_scene_deform_wait_checks: waits for every SAH check in flight and collects it (counted;
 * its verdict applied at the mesh's next pose), for tests. rd_gpu_scene_deform_destroy: idempotent;
 * waits for the checks; no submission may be in flight. */
rd_vk_result rd_gpu_scene_deform_built(rd_vk *vk, rd_gpu_scene *gs, const rd_scene *s, uint32_t m,
                                       const rd_bvh *bvh, uint32_t tri_base, char *err,
                                       size_t errlen);
bool rd_gpu_scene_deform_on_gpu(const rd_gpu_scene *gs, uint32_t m);
rd_vk_result rd_gpu_scene_deform_run(rd_vk *vk, rd_gpu_scene *gs, const rd_scene *s,
                                     const uint32_t *list, uint32_t n, uint8_t *rebuild, char *err,
                                     size_t errlen);
void rd_gpu_scene_deform_wait_checks(rd_gpu_scene *gs);
void rd_gpu_scene_deform_destroy(rd_vk *vk, rd_gpu_scene *gs);

#endif
