/* gpu_scene_internal.h: small helpers shared by the GPU scene's two files (gpu_scene.c, the GPU
 * half; gpu_scene_prep.c, the CPU half). Not part of the renderer's interface. */
#ifndef RD_GPU_SCENE_INTERNAL_H
#define RD_GPU_SCENE_INTERNAL_H

#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "shaders/gpu_types.h"
#include "renderer/accel/bvh.h"
#include "renderer/accel/gpu_lbvh.h"
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

/* gpu_scene_lbvh.c: bottom levels built by the GPU LBVH (gpu_lbvh.h) in place in the scene's
 * buffers, for static meshes at upload and deforming meshes' rebuilds (gpu_scene_deform.c).
 *
 * Who builds a static mesh's BLAS at upload: PROBECAST_BLAS_BUILD=auto|cpu|gpu|ploc (parsed once
 * per upload by rd_blas_build_from_env; rd_blas_build_parse: NULL or "" is auto, anything unknown
 * a warning and auto). auto: the CPU (below); cpu: never; gpu: every mesh the GPU builder takes
 * (at least one triangle, at most RD_GPU_LBVH_MAX_TRIANGLES) by its LBVH; ploc: the same meshes by
 * its PLOC method (gpu_ploc.h). */
typedef enum rd_blas_build {
    RD_BLAS_BUILD_AUTO = 0,
    RD_BLAS_BUILD_CPU,
    RD_BLAS_BUILD_GPU,
    RD_BLAS_BUILD_GPU_PLOC,
} rd_blas_build;
/* auto builds on the CPU for now: measured on an NVIDIA H200 (16 host cores;
 * tests/bench/results/h200/blas_upload_stop43.txt), builtin:spheres:8000000 (eight meshes of
 * 1.03 M triangles) with the GPU path took longer to its first frame than the CPU builder (bottom
 * level 2.0 s against 1.4 s, upload 410 against 233 ms: the reserved 2n - 1 nodes, the
 * single-threaded local-frame copy, the depth read-back), and its trees traced primary rays
 * 1.6x slower (0.80 against 0.49 ms at 640x360; depth 32 against 22), far from the 0.89-0.94x
 * test_gpu_lbvh's single-sphere bench measures. Stop 48 (NVIDIA H100, treelet restructuring,
 * no tree read-back: tests/bench/results/h100/lbvh_treelets_stop48.txt) narrowed it but did not
 * close it: 1080p primary rays over GPU-built trees 0.84 against 0.63 ms on spheres:1000000 and
 * 0.89 against 0.50 on builtin:interior (0.95 and 1.26 with one rotation a node), bottom level
 * 273 against 246 ms and 160 against 162. Real meshes' triangles vary in size, which Morton
 * order ignores (the LBVH's SAH 1.48 and 1.14 times the CPU builder's on those two scenes'
 * largest meshes). Stop 49 (H100, tests/bench/results/h100/gpu_ploc_stop49.txt): the GPU PLOC
 * method (PROBECAST_BLAS_BUILD=ploc) builds builtin:interior's bottom levels in 76 ms (CPU 126,
 * LBVH 582) and its trees trace 1080p primary rays in 0.62 ms (CPU 0.50, LBVH 0.82); spheres:
 * 1000000 0.81 (CPU 0.62, LBVH 0.84). Until the GPU's trees trace as fast, the GPU paths are
 * PROBECAST_BLAS_BUILD=gpu's and =ploc's. */
rd_blas_build rd_blas_build_parse(const char *value);
rd_blas_build rd_blas_build_from_env(void);
/* Whether a static mesh of tri_count triangles is built by the GPU under policy, on a device
 * that is a GPU (gpu_device) or a CPU implementation such as lavapipe. */
bool rd_blas_build_on_gpu(rd_blas_build policy, bool gpu_device, uint32_t tri_count);

/* Static meshes whose BLAS the upload builds on the GPU (made by rd_gpu_scene_prepare_device,
 * carried by the prep, then by the scene until rd_gpu_scene_lbvh_run): each mesh's triangles in
 * its local frame (9 floats each, the positions its records hold, in its original order) and
 * where its nodes (rd_gpu_lbvh_node_count slots) and records (original order) sit. */
typedef struct rd_gpu_scene_lbvh_mesh {
    uint32_t mesh, node_base, tri_base, tri_count;
    float *positions;
} rd_gpu_scene_lbvh_mesh;
struct rd_gpu_scene_lbvh_jobs {
    uint32_t count;
    uint32_t method; /* the GPU builder's (gpu_lbvh.h: RD_GPU_BVH_LBVH or RD_GPU_BVH_PLOC) */
    rd_gpu_scene_lbvh_mesh *meshes;
};
void rd_gpu_scene_lbvh_jobs_free(rd_gpu_scene_lbvh_jobs *j); /* NULL is fine */
/* Builds gs->lbvh_jobs' meshes on the GPU (render thread; the scene's buffers written: records
 * uploaded in original order), one submission each, waited for: the LBVH over its positions,
 * its nodes and records placed (rd_gpu_scene_record_lbvh_place), the tree's nodes read back for
 * its depth. A tree deeper than RD_BVH_MAX_DEPTH, or a build that could not be made (no memory,
 * no pipeline): the CPU builds that mesh and its records are reordered on the host, with a log
 * line. Frees the jobs; adds the time to gs->blas_build_ms and gs->blas_gpu_build_ms. Returns
 * an error only when the fallback fails too (a lost device, no memory). */
rd_vk_result rd_gpu_scene_lbvh_run(rd_vk *vk, rd_gpu_scene *gs, char *err, size_t errlen);
/* The deepest GPU tree rd_gpu_scene_lbvh_run keeps: RD_BVH_MAX_DEPTH; a test hook (tests lower it
 * to send every mesh through the CPU fallback). */
extern uint32_t rd_gpu_scene_lbvh_depth_limit;

/* One LBVH build's buffers: its nodes (rd_gpu_lbvh_node_count), then prim_index at prim_at, and
 * its scratch. create: not RD_VK_OK (b freed) when the LBVH cannot take tris triangles or there
 * is no memory. */
typedef struct rd_gpu_scene_lbvh_build {
    rd_buffer out, scratch;
    VkDeviceSize prim_at;
} rd_gpu_scene_lbvh_build;
rd_vk_result rd_gpu_scene_lbvh_build_create(rd_vk *vk, rd_gpu_scene_lbvh_build *b,
                                            const rd_gpu_lbvh_builder *lbvh, uint32_t tris,
                                            char *err, size_t errlen);
void rd_gpu_scene_lbvh_build_destroy(rd_vk *vk, rd_gpu_scene_lbvh_build *b); /* idempotent */
/* blas_place.comp's pipeline (its SPIR-V is embedded once, in gpu_scene_lbvh.c). */
rd_vk_result rd_gpu_scene_place_create(rd_vk *vk, rd_pipeline *place, char *err, size_t errlen);
/* Records an LBVH build over n triangles (positions: 9 floats each, original order) into b,
 * then its placing in gs's buffers by blas_place.comp (place): its nodes at node_base with the
 * node and record bases added, its records gathered in the new leaf order at tri_base from
 * source (n pc_tri then n pc_tri_attr, original order; must not overlap gs's records). Ends with
 * a barrier. */
void rd_gpu_scene_record_lbvh_place(rd_cmd *c, const rd_gpu_lbvh_builder *lbvh,
                                    const rd_pipeline *place, const rd_gpu_scene *gs,
                                    uint32_t node_base, uint32_t tri_base, uint32_t n,
                                    VkDeviceAddress positions, VkDeviceAddress source,
                                    const rd_gpu_scene_lbvh_build *b);

/* gpu_scene_materials.c: a device buffer holding size bytes of data, written at once without st,
 * staged into st with it (vk_staging.h); and the scene's materials, texture table and texels
 * (sets gs->glossy). */
rd_vk_result rd_gpu_scene_upload_new(rd_vk *vk, rd_staging *st, rd_buffer *b, const void *data,
                                     size_t size, char *err, size_t errlen);
rd_vk_result rd_gpu_scene_upload_materials(rd_vk *vk, rd_staging *st, rd_gpu_scene *gs,
                                           const rd_scene *s, char *err, size_t errlen);

#endif
