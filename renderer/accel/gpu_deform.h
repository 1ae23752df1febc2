/* gpu_deform.h: a deforming mesh (rd_mesh_deform) posed on the GPU by shaders/deform.comp, the
 * same math as rd_mesh_deform_apply (renderer/scene/deform.c), which stays the reference.
 * The per-vertex arrays (rest shape, joints and weights, morph deltas) go up once at create; a
 * pose uploads only the joint matrices and the morph weights. The outputs are flat arrays
 * (3 floats per vertex for positions and normals, 4 for tangents) in a device buffer whose
 * addresses the caller reads: gpu_scene_deform.c writes a scene's triangle records from them and
 * refits the mesh's BLAS over them (rd_gpu_scene_update_pose). */
#ifndef RD_GPU_DEFORM_H
#define RD_GPU_DEFORM_H

#include <stdbool.h>
#include <stdint.h>

#include "renderer/scene/scene.h"
#include "renderer/vk/vk_compute.h"

/* The pipeline, shared by every deforming mesh. */
typedef struct rd_gpu_deformer {
    rd_pipeline deform;
} rd_gpu_deformer;

rd_vk_result rd_gpu_deformer_create(rd_vk *vk, rd_gpu_deformer *g, char *err, size_t errlen);
void rd_gpu_deformer_destroy(rd_vk *vk, rd_gpu_deformer *g); /* idempotent */

/* One mesh's GPU arrays. */
typedef struct rd_gpu_deform_mesh {
    rd_buffer vertex_data; /* rest shape, joints, weights, morph deltas (device local) */
    rd_buffer pose;        /* joint matrices then morph weights (host visible) */
    rd_buffer out;         /* positions, normals, tangents (device local) */
    uint32_t vertex_count, influences, target_count, joint_capacity;
    uint32_t pose_joints; /* joint matrices in the current pose (0: no skinning) */
    bool has_tangents, has_target_normals, has_target_tangents;
    /* byte offsets inside vertex_data and out (0 in vertex_data: absent, except rest_positions) */
    VkDeviceSize rest_positions, rest_normals, rest_tangents, joints, weights;
    VkDeviceSize target_positions, target_normals, target_tangents;
    VkDeviceSize out_positions, out_normals, out_tangents;
} rd_gpu_deform_mesh;

/* Uploads mesh m's deformation (m->deform must be set) for skins of up to joint_capacity joints. */
rd_vk_result rd_gpu_deform_mesh_create(rd_vk *vk, rd_gpu_deform_mesh *d, const rd_mesh *m,
                                       uint32_t joint_capacity, char *err, size_t errlen);
void rd_gpu_deform_mesh_destroy(rd_vk *vk, rd_gpu_deform_mesh *d); /* idempotent */

/* Writes the pose (as rd_mesh_deform_apply takes it: weights, weight_count of them, 0 or a count
 * other than target_count: the mesh's defaults; joint_count matrices or NULL: no skin; joints past
 * joint_capacity are left out) into d->pose. The host writes it directly: do not call while a
 * command buffer that reads it is in flight. */
void rd_gpu_deform_set_pose(rd_gpu_deform_mesh *d, const rd_mesh_deform *src, const float *weights,
                            uint32_t weight_count, const float *joint_mats, uint32_t joint_count);
/* Records the deformation into c (a barrier follows it). */
void rd_gpu_deform_record(rd_cmd *c, const rd_gpu_deformer *g, const rd_gpu_deform_mesh *d);

#endif
