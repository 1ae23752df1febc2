/* gpu_scene.h: a scene's acceleration structures and shading data, resident on the GPU.
 *
 * Bottom-level BVHs are built once per mesh; the top-level BVH over instances is rebuilt
 * when nodes move (rd_gpu_scene_update_instances), so moving an object costs one small
 * rebuild and upload. A mesh that deforms (skins, morph targets: scene.h rd_mesh_deform) gets
 * room for any BVH of its triangles; when its pose changed (rd_gpu_scene_update_pose) it is
 * posed on the GPU and its BLAS refitted there in place, or rebuilt on the CPU (the first pose,
 * a degraded tree, PROBECAST_DEFORM=cpu: gpu_scene_deform.c). Lights are a separate small
 * upload.
 */
#ifndef RD_GPU_SCENE_H
#define RD_GPU_SCENE_H

#include "shaders/gpu_types.h"
#include "renderer/scene/scene.h"
#include "renderer/vk/vk_buffer.h"
#include "renderer/vk/vk_compute.h"
#include "renderer/vk/vk_staging.h"

#define RD_GPU_SCENE_DIRTY_MAX PC_SHADOW_MAP_BOXES
typedef struct rd_gpu_scene_dirty {
    uint64_t revision;
    float lo[3], hi[3];
} rd_gpu_scene_dirty;

typedef struct rd_gpu_scene_deform rd_gpu_scene_deform;       /* gpu_scene_deform.c */
typedef struct rd_gpu_scene_lbvh_jobs rd_gpu_scene_lbvh_jobs; /* gpu_scene_lbvh.c */

typedef struct rd_gpu_scene {
    rd_buffer tris, tri_attrs, blas_nodes, tlas_nodes, tlas_index, instances;
    rd_buffer materials, textures, texels, lights;
    pc_scene_refs refs; /* addresses and counts, ready for pc_globals */
    /* Floating origin: the GPU holds world positions minus this (the scene's centre), so that
     * a scene far from the origin keeps full float precision near its geometry and ray
     * offsets stay small. Cameras and probe grids are shifted the same way when rendering. */
    float origin_shift[3];
    uint32_t mesh_count;
    uint32_t *mesh_root; /* absolute BLAS root node per mesh */
    float *mesh_bounds;  /* 6 floats per mesh: object-space min, max */
    /* Local origin per mesh: the GPU holds a mesh's vertices (and its BLAS) minus
     * mesh_origin[3 m] and its instances' transforms carry it back, so that vertices baked far
     * from their own origin (geo-referenced data) keep the precision of their size, not of
     * their distance. 0 for a mesh that lies within its size of its origin. mesh_local_bounds:
     * 6 floats per mesh, the BLAS root's box in that local frame. */
    float *mesh_origin;
    float *mesh_local_bounds;
    uint64_t *mesh_revision; /* per mesh: the deform revision its BLAS shows (0: rigid) */
    uint32_t instance_capacity;
    uint32_t light_capacity;
    /* lights changed since the last recorded command buffer: written by the next one that
     * renders (rd_gpu_scene_record_updates), in queue order after the frames in flight */
    pc_light *lights_pending;
    uint32_t lights_pending_count;
    /* some material can trace reflection rays (glossy: see PC_REFLECT_MAX_ROUGHNESS); when
     * none can, views record no reflection pass */
    bool glossy;
    /* What rays see, as revisions: numbers no other state of any scene in this process has
     * had. geometry_revision is renewed by every upload and instance update that moves an
     * instance; light_revision[i] when light i moves, re-aims, re-ranges, changes type or
     * appears (not its colour or intensity: placed_lights keeps the last upload to compare);
     * revision by either. Distance maps (shadow_maps.h) built for them stay right until they
     * change. Lights past PC_SHADOW_MAP_MAX_LIGHTS are not tracked. */
    uint64_t revision, geometry_revision;
    /* Where the geometry changed (GPU frame): the boxes of moved instances before and after,
     * tagged with the geometry revision that moved them, the last RD_GPU_SCENE_DIRTY_MAX of
     * them. Every change after geometry revision dirty_since is in the log (an upload, or a
     * log that overflowed, moves dirty_since up): a distance map showing a revision at or
     * after it needs only the texels whose rays cross the later boxes re-traced. */
    rd_gpu_scene_dirty dirty[RD_GPU_SCENE_DIRTY_MAX];
    uint32_t dirty_count; /* entries in dirty[], oldest first */
    uint64_t dirty_since;
    pc_instance *placed; /* the instances as last uploaded (to tell which moved) */
    float bounds[6];     /* the top level's root box (GPU frame): min, max */
    uint64_t light_revision[PC_SHADOW_MAP_MAX_LIGHTS];
    pc_light *placed_lights; /* the lights as last uploaded (light_capacity of them) */
    /* static meshes whose BLAS the GPU builds, until it has (PROBECAST_BLAS_BUILD:
     * gpu_scene_lbvh.c; the staged path builds them at the commit) */
    rd_gpu_scene_lbvh_jobs *lbvh_jobs;
    /* statistics: blas_build_ms includes blas_gpu_build_ms, the GPU builds' time (submissions,
     * waits and read-backs) over blas_gpu_meshes meshes */
    double blas_build_ms, tlas_build_ms, upload_ms, blas_gpu_build_ms;
    uint32_t blas_gpu_meshes;
    /* the last rd_gpu_scene_update_pose that changed a mesh: its whole mesh work (GPU poses and
     * refits, CPU rebuilds and uploads; wall time), and the GPU time of its posing (with the
     * triangle records) and of its refits (the submission's wall time in deform_ms, refit_ms 0,
     * where the device has no timestamps; both 0 when no mesh went through the GPU) */
    double deform_build_ms, deform_ms, refit_ms;
    /* mesh poses refitted on the GPU, rebuilt on the CPU, rebuilt on the GPU (the LBVH, when a
     * refitted tree is due for a rebuild); refitted trees checked against a fresh build, the
     * checks finished (off the render thread: gpu_scene_deform.c) */
    uint64_t deform_refits, deform_rebuilds, deform_gpu_rebuilds, deform_sah_checks;
    /* Deforming meshes: GPU state (NULL until a pose needs it), and the CPU path forced for
     * every pose (set by the upload from the environment: PROBECAST_DEFORM=cpu). */
    rd_gpu_scene_deform *deform;
    bool deform_on_cpu;
    uint64_t tri_count, blas_node_count;
    uint32_t tlas_node_count, max_blas_depth;
} rd_gpu_scene;

/* The CPU half of a scene's creation: every mesh's bottom-level BVH and the triangle records in
 * leaf order. Plain CPU work with no Vulkan, so it can run on any thread (the daemon builds an
 * upload's BVHs on the uploading connection's thread, not on the render thread). */
typedef struct rd_gpu_scene_prep {
    uint32_t mesh_count;
    uint32_t *mesh_root;      /* absolute BLAS root node per mesh */
    float *mesh_bounds;       /* 6 floats per mesh */
    float *mesh_origin;       /* 3 floats per mesh (rd_gpu_scene.mesh_origin) */
    float *mesh_local_bounds; /* 6 floats per mesh */
    uint64_t *mesh_revision;  /* per mesh (rd_gpu_scene.mesh_revision) */
    pc_bvh_node *nodes;
    pc_tri *tris;
    pc_tri_attr *attrs;
    uint64_t tri_count, node_count;
    uint32_t max_blas_depth;
    double build_ms;
    /* meshes left to the GPU's LBVH (PROBECAST_BLAS_BUILD): their nodes are zero here, their
     * records in original order; the upload builds them */
    rd_gpu_scene_lbvh_jobs *lbvh_jobs;
} rd_gpu_scene_prep;

/* Builds the BLASes of scene. On failure (a scene too large) p is left empty. gpu_device: the
 * scene goes to a GPU (not a CPU implementation such as lavapipe), where large meshes are left
 * to the GPU's LBVH (PROBECAST_BLAS_BUILD; rd_gpu_scene_prepare: as for a CPU device). */
rd_vk_result rd_gpu_scene_prepare_device(rd_gpu_scene_prep *p, const rd_scene *scene,
                                         bool gpu_device, char *err, size_t errlen);
rd_vk_result rd_gpu_scene_prepare(rd_gpu_scene_prep *p, const rd_scene *scene, char *err,
                                  size_t errlen);
void rd_gpu_scene_prep_destroy(rd_gpu_scene_prep *p); /* idempotent */
/* The GPU half: uploads prep (its mesh tables move into gs, its arrays are freed), builds the
 * top level, uploads materials, textures and lights. prep must come from the same scene. On
 * failure everything is released. */
rd_vk_result rd_gpu_scene_upload(rd_vk *vk, rd_gpu_scene *gs, const rd_scene *scene,
                                 rd_gpu_scene_prep *prep, char *err, size_t errlen);
/* The GPU half split once more, for uploads that must not stall rendering: on any thread,
 * rd_gpu_scene_stage creates the scene's buffers and stages their contents in host-visible
 * memory (vk_staging.h; nothing is submitted, and prep's arrays are freed as they are staged);
 * on the queue's thread, rd_gpu_scene_commit copies them (one submission, waited for) and
 * gives the scene. A staged scene that is never committed is freed by
 * rd_gpu_scene_staged_destroy (idempotent; on any thread). */
typedef struct rd_gpu_scene_staged {
    rd_vk *vk; /* NULL: nothing staged */
    rd_gpu_scene gs;
    rd_staging copies;
    double stage_ms;
} rd_gpu_scene_staged;
rd_vk_result rd_gpu_scene_stage(rd_vk *vk, rd_gpu_scene_staged *out, const rd_scene *scene,
                                rd_gpu_scene_prep *prep, char *err, size_t errlen);
rd_vk_result rd_gpu_scene_commit(rd_gpu_scene_staged *st, rd_gpu_scene *gs, char *err,
                                 size_t errlen);
void rd_gpu_scene_staged_destroy(rd_gpu_scene_staged *st);
/* Both halves at once. */
rd_vk_result rd_gpu_scene_create(rd_vk *vk, rd_gpu_scene *gs, const rd_scene *scene, char *err,
                                 size_t errlen);
/* Rebuilds the top-level BVH and instance transforms from scene's current node world
 * matrices (call rd_scene_update first). The instance count must not change. */
rd_vk_result rd_gpu_scene_update_instances(rd_vk *vk, rd_gpu_scene *gs, const rd_scene *scene,
                                           char *err, size_t errlen);
/* Whether mesh's deformed shape changed since its BLAS was built (its deform revision moved). */
bool rd_gpu_scene_mesh_stale(const rd_gpu_scene *gs, const rd_scene *scene, uint32_t mesh);
/* rd_gpu_scene_update_instances after a pose (rd_scene_update done: its CPU deformation gives
 * the pose, and the shape a CPU rebuild uses): every stale deformed mesh gets its triangle
 * records and BLAS written in place, posed and refitted on the GPU (gpu_scene_deform.c), or
 * rebuilt on the CPU from the CPU's deformed shape; the boxes its instances took before and
 * take now are logged as changed geometry (a new geometry revision). *rebuilt (may be NULL) gets
 * how many meshes changed (refitted or rebuilt); deform_build_ms, deform_ms and refit_ms the
 * time it took. */
rd_vk_result rd_gpu_scene_update_pose(rd_vk *vk, rd_gpu_scene *gs, const rd_scene *scene,
                                      uint32_t *rebuilt, char *err, size_t errlen);
/* Re-uploads the lights (the count may change). Within the buffer's capacity nothing waits: the
 * new values are recorded into the next command buffer that renders the scene (a light that
 * moves every frame used to cost a staging buffer and a queue wait, 1.8 ms on an H200); growing
 * the buffer waits for the device. */
rd_vk_result rd_gpu_scene_update_lights(rd_vk *vk, rd_gpu_scene *gs, const rd_scene *scene,
                                        char *err, size_t errlen);
/* Records pending light values at the start of cmd (vkCmdUpdateBuffer and a barrier). Every
 * command buffer that reads the scene's lights calls it before its first dispatch: probe updates
 * (rd_world_update) and view frames (rd_view_record, path-tracing batches). */
void rd_gpu_scene_record_updates(rd_gpu_scene *gs, rd_cmd *cmd);
void rd_gpu_scene_destroy(rd_vk *vk, rd_gpu_scene *gs); /* idempotent */
/* World bounds of mesh placed by the column-major world matrix m (its box's corners moved). */
void rd_gpu_scene_mesh_world_bounds(const rd_gpu_scene *gs, uint32_t mesh, const float m[16],
                                    float lo[3], float hi[3]);
/* World bounds of instance i of scene as its node places it now (the mesh's box transformed;
 * world coordinates, not shifted by the floating origin). */
void rd_gpu_scene_instance_bounds(const rd_gpu_scene *gs, const rd_scene *scene, uint32_t i,
                                  float lo[3], float hi[3]);

#endif
