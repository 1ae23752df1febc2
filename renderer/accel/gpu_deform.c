/* gpu_deform.c: deforming meshes posed on the GPU (see gpu_deform.h). */
#include "renderer/accel/gpu_deform.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "shaders/deform.spv.h"
#include "shaders/gpu_types.h"

static const rd_pipeline_desc kPipelines[] = {
    RD_PIPELINE_DESC(rd_gpu_deformer, deform, "deform", pc_spv_deform,
                     (uint32_t)sizeof(pc_deform_push)),
};
#define PIPELINE_COUNT (sizeof kPipelines / sizeof kPipelines[0])

rd_vk_result rd_gpu_deformer_create(rd_vk *vk, rd_gpu_deformer *g, char *err, size_t errlen)
{
    memset(g, 0, sizeof *g);
    return rd_pipelines_create(vk, g, kPipelines, PIPELINE_COUNT, err, errlen);
}

void rd_gpu_deformer_destroy(rd_vk *vk, rd_gpu_deformer *g)
{
    rd_pipelines_destroy(vk, g, kPipelines, PIPELINE_COUNT);
}

/* Reserves bytes at *end (16-byte aligned) and returns its offset. */
static VkDeviceSize take(VkDeviceSize *end, size_t bytes)
{
    VkDeviceSize at = *end;
    *end += (bytes + 15) & ~(size_t)15;
    return at;
}

rd_vk_result rd_gpu_deform_mesh_create(rd_vk *vk, rd_gpu_deform_mesh *d, const rd_mesh *m,
                                       uint32_t joint_capacity, char *err, size_t errlen)
{
    memset(d, 0, sizeof *d);
    const rd_mesh_deform *src = m->deform;
    if (!src) {
        snprintf(err, errlen, "gpu deform: mesh has no deformation");
        return RD_VK_ERR_VULKAN;
    }
    size_t nv = src->vertex_count, nt = src->target_count, inf = src->influences;
    d->vertex_count = (uint32_t)nv;
    d->influences = (uint32_t)inf;
    d->target_count = (uint32_t)nt;
    d->joint_capacity = inf ? joint_capacity : 0;
    d->has_tangents = src->rest_tangents != NULL;
    d->has_target_normals = nt && src->target_normals;
    d->has_target_tangents = nt && src->target_tangents && d->has_tangents;

    VkDeviceSize end = 0;
    d->rest_positions = take(&end, nv * 3 * sizeof(float));
    d->rest_normals = take(&end, nv * 3 * sizeof(float));
    if (d->has_tangents) d->rest_tangents = take(&end, nv * 4 * sizeof(float));
    if (inf) {
        d->joints = take(&end, nv * inf * sizeof(uint32_t));
        d->weights = take(&end, nv * inf * sizeof(float));
    }
    if (nt) d->target_positions = take(&end, nt * nv * 3 * sizeof(float));
    if (d->has_target_normals) d->target_normals = take(&end, nt * nv * 3 * sizeof(float));
    if (d->has_target_tangents) d->target_tangents = take(&end, nt * nv * 3 * sizeof(float));
    VkDeviceSize out_end = 0;
    d->out_positions = take(&out_end, nv * 3 * sizeof(float));
    d->out_normals = take(&out_end, nv * 3 * sizeof(float));
    if (d->has_tangents) d->out_tangents = take(&out_end, nv * 4 * sizeof(float));
    size_t pose_bytes = ((size_t)d->joint_capacity * 16 + nt + 1) * sizeof(float);

    uint8_t *host = calloc(end ? end : 1, 1);
    if (!host) {
        fprintf(stderr, "probecast: out of memory (%llu bytes of GPU deformation)\n",
                (unsigned long long)end);
        abort();
    }
    memcpy(host + d->rest_positions, src->rest_positions, nv * 3 * sizeof(float));
    memcpy(host + d->rest_normals, src->rest_normals, nv * 3 * sizeof(float));
    if (d->has_tangents)
        memcpy(host + d->rest_tangents, src->rest_tangents, nv * 4 * sizeof(float));
    if (inf) {
        uint32_t *j = (uint32_t *)(host + d->joints);
        for (size_t i = 0; i < nv * inf; i++)
            j[i] = src->joints[i];
        memcpy(host + d->weights, src->weights, nv * inf * sizeof(float));
    }
    if (nt) memcpy(host + d->target_positions, src->target_positions, nt * nv * 3 * sizeof(float));
    if (d->has_target_normals)
        memcpy(host + d->target_normals, src->target_normals, nt * nv * 3 * sizeof(float));
    if (d->has_target_tangents)
        memcpy(host + d->target_tangents, src->target_tangents, nt * nv * 3 * sizeof(float));

    rd_vk_result r = rd_buffer_create(vk, &d->vertex_data, end, RD_MEMORY_DEVICE, err, errlen);
    if (r == RD_VK_OK) r = rd_buffer_upload(vk, &d->vertex_data, 0, host, end, err, errlen);
    if (r == RD_VK_OK)
        r = rd_buffer_create(vk, &d->pose, pose_bytes, RD_MEMORY_UPLOAD, err, errlen);
    if (r == RD_VK_OK) r = rd_buffer_create(vk, &d->out, out_end, RD_MEMORY_DEVICE, err, errlen);
    free(host);
    if (r != RD_VK_OK) {
        rd_gpu_deform_mesh_destroy(vk, d);
        return r;
    }
    memset(d->pose.mapped, 0, pose_bytes);
    return RD_VK_OK;
}

void rd_gpu_deform_mesh_destroy(rd_vk *vk, rd_gpu_deform_mesh *d)
{
    rd_buffer_destroy(vk, &d->out);
    rd_buffer_destroy(vk, &d->pose);
    rd_buffer_destroy(vk, &d->vertex_data);
}

void rd_gpu_deform_set_pose(rd_gpu_deform_mesh *d, const rd_mesh_deform *src, const float *weights,
                            uint32_t weight_count, const float *joint_mats, uint32_t joint_count)
{
    float *p = d->pose.mapped;
    uint32_t jc = joint_mats ? joint_count : 0;
    if (jc > d->joint_capacity) jc = d->joint_capacity;
    if (jc) memcpy(p, joint_mats, (size_t)jc * 16 * sizeof(float));
    const float *w = weight_count == d->target_count && weights ? weights : src->default_weights;
    if (d->target_count)
        memcpy(p + (size_t)d->joint_capacity * 16, w, d->target_count * sizeof(float));
    d->pose_joints = jc;
}

void rd_gpu_deform_record(rd_cmd *c, const rd_gpu_deformer *g, const rd_gpu_deform_mesh *d)
{
    uint32_t jc = d->pose_joints;
    VkDeviceAddress in = d->vertex_data.address, out = d->out.address, pose = d->pose.address;
    pc_deform_push push = {
        .counts = {d->vertex_count, jc ? d->influences : 0, d->target_count, jc},
        .rest_positions = in + d->rest_positions,
        .rest_normals = in + d->rest_normals,
        .rest_tangents = d->has_tangents ? in + d->rest_tangents : 0,
        .joints = d->influences ? in + d->joints : 0,
        .weights = d->influences ? in + d->weights : 0,
        .target_positions = d->target_count ? in + d->target_positions : 0,
        .target_normals = d->has_target_normals ? in + d->target_normals : 0,
        .target_tangents = d->has_target_tangents ? in + d->target_tangents : 0,
        .joint_mats = jc ? pose : 0,
        .morph_weights = pose + (VkDeviceAddress)d->joint_capacity * 16 * sizeof(float),
        .out_positions = out + d->out_positions,
        .out_normals = out + d->out_normals,
        .out_tangents = d->has_tangents ? out + d->out_tangents : 0,
    };
    uint32_t groups = (d->vertex_count + PC_WG_1D - 1) / PC_WG_1D;
    if (groups) rd_cmd_dispatch(c, &g->deform, &push, groups, 1, 1);
    rd_cmd_barrier(c);
}
