/* gpu_scene_lbvh.c: bottom levels built by the GPU LBVH (gpu_lbvh.h) in place in a scene's
 * buffers (gpu_scene_internal.h): the policy (PROBECAST_BLAS_BUILD) for static meshes at upload,
 * the build-and-place sequence that the upload and deforming meshes' rebuilds
 * (gpu_scene_deform.c) share, and the upload's builds with their CPU fallback. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/accel/gpu_scene_internal.h"
#include "shaders/blas_place.spv.h"

uint32_t rd_gpu_scene_lbvh_depth_limit = RD_BVH_MAX_DEPTH;

rd_blas_build rd_blas_build_parse(const char *value)
{
    if (!value || !*value || strcmp(value, "auto") == 0) return RD_BLAS_BUILD_AUTO;
    if (strcmp(value, "cpu") == 0) return RD_BLAS_BUILD_CPU;
    if (strcmp(value, "gpu") == 0) return RD_BLAS_BUILD_GPU;
    if (strcmp(value, "ploc") == 0) return RD_BLAS_BUILD_GPU_PLOC;
    fprintf(stderr,
            "probecast: warning: PROBECAST_BLAS_BUILD=%s is not auto, cpu, gpu or ploc: using "
            "auto\n",
            value);
    return RD_BLAS_BUILD_AUTO;
}

rd_blas_build rd_blas_build_from_env(void)
{
    return rd_blas_build_parse(getenv("PROBECAST_BLAS_BUILD"));
}

bool rd_blas_build_on_gpu(rd_blas_build policy, bool gpu_device, uint32_t tri_count)
{
    if (tri_count == 0 || tri_count > RD_GPU_LBVH_MAX_TRIANGLES) return false;
    switch (policy) {
    case RD_BLAS_BUILD_CPU:
        return false;
    case RD_BLAS_BUILD_GPU:
    case RD_BLAS_BUILD_GPU_PLOC:
        return true;
    default: /* auto: the CPU (gpu_scene_internal.h says why) */
        (void)gpu_device;
        return false;
    }
}

void rd_gpu_scene_lbvh_jobs_free(rd_gpu_scene_lbvh_jobs *j)
{
    if (!j) return;
    for (uint32_t k = 0; k < j->count; k++)
        free(j->meshes[k].positions);
    free(j->meshes);
    free(j);
}

void rd_gpu_scene_lbvh_build_destroy(rd_vk *vk, rd_gpu_scene_lbvh_build *b)
{
    rd_buffer_destroy(vk, &b->scratch);
    rd_buffer_destroy(vk, &b->out);
}

rd_vk_result rd_gpu_scene_lbvh_build_create(rd_vk *vk, rd_gpu_scene_lbvh_build *b,
                                            const rd_gpu_lbvh_builder *lbvh, uint32_t tris,
                                            char *err, size_t errlen)
{
    memset(b, 0, sizeof *b);
    if (tris > RD_GPU_LBVH_MAX_TRIANGLES) {
        snprintf(err, errlen, "%u triangles, more than the GPU LBVH takes", tris);
        return RD_VK_ERR_UNSUPPORTED;
    }
    b->prim_at = sizeof(pc_bvh_node) * (VkDeviceSize)rd_gpu_lbvh_node_count(tris);
    rd_vk_result r = rd_buffer_create(vk, &b->out, b->prim_at + 4 * (VkDeviceSize)tris,
                                      RD_MEMORY_DEVICE, err, errlen);
    if (r == RD_VK_OK)
        r = rd_buffer_create(vk, &b->scratch, rd_gpu_lbvh_scratch_bytes(lbvh, tris),
                             RD_MEMORY_DEVICE, err, errlen);
    if (r != RD_VK_OK) rd_gpu_scene_lbvh_build_destroy(vk, b);
    return r;
}

void rd_gpu_scene_record_lbvh_place(rd_cmd *c, const rd_gpu_lbvh_builder *lbvh,
                                    const rd_pipeline *place, const rd_gpu_scene *gs,
                                    uint32_t node_base, uint32_t tri_base, uint32_t n,
                                    VkDeviceAddress positions, VkDeviceAddress source,
                                    const rd_gpu_scene_lbvh_build *b)
{
    uint32_t most = rd_gpu_lbvh_node_count(n);
    VkDeviceAddress prim = b->out.address + b->prim_at;
    rd_gpu_lbvh_record(c, lbvh, positions, n, 0, b->out.address, prim, &b->scratch, NULL);
    pc_push nodes = {
        .buf0 = b->out.address,
        .buf1 = gs->blas_nodes.address + sizeof(pc_bvh_node) * (VkDeviceAddress)node_base,
        .buf2 = b->scratch.address + RD_GPU_LBVH_COUNT_OFFSET,
        .params = {most, node_base, tri_base, 0},
    };
    rd_cmd_dispatch(c, place, &nodes, (most + PC_WG_1D - 1) / PC_WG_1D, 1, 1);
    pc_push records = {
        .globals = gs->tri_attrs.address + (VkDeviceAddress)tri_base * sizeof(pc_tri_attr),
        .buf0 = prim,
        .buf1 = source,
        .buf2 = gs->tris.address + (VkDeviceAddress)tri_base * sizeof(pc_tri),
        .params = {n, 0, 0, 1},
    };
    if (n) rd_cmd_dispatch(c, place, &records, (n + PC_WG_1D - 1) / PC_WG_1D, 1, 1);
    rd_cmd_barrier(c);
}

rd_vk_result rd_gpu_scene_place_create(rd_vk *vk, rd_pipeline *place, char *err, size_t errlen)
{
    return rd_pipeline_create(vk, place, "blas_place", pc_spv_blas_place, sizeof pc_spv_blas_place,
                              (uint32_t)sizeof(pc_push), err, errlen);
}

/* The upload's GPU state: the LBVH's pipelines and blas_place.comp's. */
typedef struct lbvh_kit {
    rd_gpu_lbvh_builder lbvh;
    rd_pipeline place;
} lbvh_kit;

/* Mesh j's BLAS built on the GPU (kit ready): 0 deep or more on success, UINT32_MAX when the
 * tree cannot be kept (a node count out of range); not RD_VK_OK when the build could not run. */
static rd_vk_result gpu_build(rd_vk *vk, rd_gpu_scene *gs, const lbvh_kit *kit,
                              const rd_gpu_scene_lbvh_mesh *j, uint32_t *depth, char *err,
                              size_t errlen)
{
    uint32_t n = j->tri_count;
    VkDeviceSize tri_bytes = sizeof(pc_tri) * (VkDeviceSize)n;
    rd_gpu_scene_lbvh_build b;
    rd_buffer pos = {0}, source = {0};
    rd_vk_result r = rd_gpu_scene_lbvh_build_create(vk, &b, &kit->lbvh, n, err, errlen);
    if (r == RD_VK_OK)
        r = rd_buffer_create(vk, &pos, sizeof(float) * 9 * (VkDeviceSize)n, RD_MEMORY_DEVICE, err,
                             errlen);
    if (r == RD_VK_OK)
        r = rd_buffer_upload(vk, &pos, 0, j->positions, sizeof(float) * 9 * (size_t)n, err, errlen);
    if (r == RD_VK_OK)
        r = rd_buffer_create(vk, &source, tri_bytes + sizeof(pc_tri_attr) * (VkDeviceSize)n,
                             RD_MEMORY_DEVICE, err, errlen);
    rd_cmd c;
    if (r == RD_VK_OK) r = rd_cmd_begin(vk, &c, err, errlen);
    if (r == RD_VK_OK) {
        /* the records as uploaded (original order), the source of their gather */
        VkBufferCopy t = {sizeof(pc_tri) * (VkDeviceSize)j->tri_base, 0, tri_bytes};
        VkBufferCopy a = {sizeof(pc_tri_attr) * (VkDeviceSize)j->tri_base, tri_bytes,
                          sizeof(pc_tri_attr) * (VkDeviceSize)n};
        vkCmdCopyBuffer(c.cb, gs->tris.buffer, source.buffer, 1, &t);
        vkCmdCopyBuffer(c.cb, gs->tri_attrs.buffer, source.buffer, 1, &a);
        rd_cmd_barrier(&c);
        rd_gpu_scene_record_lbvh_place(&c, &kit->lbvh, &kit->place, gs, j->node_base, j->tri_base,
                                       n, pos.address, source.address, &b);
        r = rd_cmd_submit_wait(vk, &c, err, errlen);
    }
    /* the depth, which the LBVH does not bound: the build writes it beside its node count */
    uint32_t words[2] = {0, 0};
    if (r == RD_VK_OK)
        r = rd_buffer_download(vk, &b.scratch, RD_GPU_LBVH_COUNT_OFFSET, words, sizeof words, err,
                               errlen);
    if (r == RD_VK_OK)
        *depth = words[0] >= 1 && words[0] <= rd_gpu_lbvh_node_count(n) ? words[1] : UINT32_MAX;
    rd_buffer_destroy(vk, &source);
    rd_buffer_destroy(vk, &pos);
    rd_gpu_scene_lbvh_build_destroy(vk, &b);
    return r;
}

/* Mesh j's BLAS built on the CPU over its local positions and written in place: nodes with the
 * bases added, the records (read back, in whatever order they are: each names its original
 * triangle in v2.w) in the CPU tree's leaf order. */
static rd_vk_result cpu_build(rd_vk *vk, rd_gpu_scene *gs, const rd_gpu_scene_lbvh_mesh *j,
                              uint32_t *depth, char *err, size_t errlen)
{
    uint32_t n = j->tri_count;
    rd_bvh bvh = {0};
    if (!rd_bvh_build_triangles(&bvh, j->positions, n, NULL)) {
        fprintf(stderr, "probecast: out of memory building a BVH\n");
        abort();
    }
    if (bvh.node_count > rd_gpu_lbvh_node_count(n)) { /* never: 2 n - 1 at most */
        rd_bvh_destroy(&bvh);
        snprintf(err, errlen, "the CPU BVH of mesh %u does not fit its slots", j->mesh);
        return RD_VK_ERR_VULKAN;
    }
    pc_tri *t = xcalloc(n, sizeof *t), *to = xcalloc(n, sizeof *to);
    pc_tri_attr *a = xcalloc(n, sizeof *a), *ao = xcalloc(n, sizeof *ao);
    uint32_t *at = xcalloc(n, sizeof *at); /* original triangle -> its record now */
    rd_vk_result r = rd_buffer_download(vk, &gs->tris, sizeof *t * (size_t)j->tri_base, t,
                                        sizeof *t * n, err, errlen);
    if (r == RD_VK_OK)
        r = rd_buffer_download(vk, &gs->tri_attrs, sizeof *a * (size_t)j->tri_base, a,
                               sizeof *a * n, err, errlen);
    for (uint32_t i = 0; r == RD_VK_OK && i < n; i++) {
        uint32_t src = pc_f2u(t[i].v2.w);
        if (src >= n) {
            snprintf(err, errlen, "mesh %u's record %u names triangle %u", j->mesh, i, src);
            r = RD_VK_ERR_VULKAN; /* a broken invariant, reported */
        } else {
            at[src] = i;
        }
    }
    for (uint32_t i = 0; r == RD_VK_OK && i < n; i++)
        to[i] = t[at[bvh.prim_index[i]]], ao[i] = a[at[bvh.prim_index[i]]];
    for (uint32_t i = 0; i < bvh.node_count; i++) {
        pc_bvh_node *nd = &bvh.nodes[i];
        uint32_t first = rd_bvh_node_first(nd), count = rd_bvh_node_count(nd);
        nd->bmin.w = pc_u2f(first + (count ? j->tri_base : j->node_base));
    }
    if (r == RD_VK_OK)
        r = rd_buffer_upload(vk, &gs->blas_nodes, sizeof *bvh.nodes * (size_t)j->node_base,
                             bvh.nodes, sizeof *bvh.nodes * bvh.node_count, err, errlen);
    if (r == RD_VK_OK)
        r = rd_buffer_upload(vk, &gs->tris, sizeof *t * (size_t)j->tri_base, to, sizeof *to * n,
                             err, errlen);
    if (r == RD_VK_OK)
        r = rd_buffer_upload(vk, &gs->tri_attrs, sizeof *a * (size_t)j->tri_base, ao,
                             sizeof *ao * n, err, errlen);
    *depth = bvh.depth;
    free(t), free(to), free(a), free(ao), free(at);
    rd_bvh_destroy(&bvh);
    return r;
}

rd_vk_result rd_gpu_scene_lbvh_run(rd_vk *vk, rd_gpu_scene *gs, char *err, size_t errlen)
{
    rd_gpu_scene_lbvh_jobs *jobs = gs->lbvh_jobs;
    if (!jobs) return RD_VK_OK;
    gs->lbvh_jobs = NULL;
    double t0 = now_ms();
    lbvh_kit kit = {0};
    rd_vk_result kr = rd_gpu_lbvh_builder_create(vk, &kit.lbvh, err, errlen);
    kit.lbvh.method = jobs->method;
    if (kr == RD_VK_OK) kr = rd_gpu_scene_place_create(vk, &kit.place, err, errlen);
    if (kr != RD_VK_OK && !vk->device_lost)
        fprintf(stderr, "probecast: no GPU BVH builds, the CPU builds them: %s\n", err);
    rd_vk_result r = RD_VK_OK;
    for (uint32_t k = 0; k < jobs->count && r == RD_VK_OK && !vk->device_lost; k++) {
        const rd_gpu_scene_lbvh_mesh *j = &jobs->meshes[k];
        uint32_t depth = UINT32_MAX;
        rd_vk_result br = kr;
        if (br == RD_VK_OK) br = gpu_build(vk, gs, &kit, j, &depth, err, errlen);
        if (vk->device_lost) {
            r = RD_VK_ERR_DEVICE_LOST;
            break;
        }
        if (br == RD_VK_OK && depth <= rd_gpu_scene_lbvh_depth_limit) {
            gs->blas_gpu_meshes++;
        } else {
            if (kr == RD_VK_OK) {
                if (br == RD_VK_OK)
                    fprintf(stderr,
                            "probecast: mesh %u's GPU BVH is deeper than %u levels (or broken): "
                            "the CPU builds it\n",
                            j->mesh, rd_gpu_scene_lbvh_depth_limit);
                else
                    fprintf(stderr,
                            "probecast: mesh %u's GPU BVH build failed, the CPU builds "
                            "it: %s\n",
                            j->mesh, err);
            }
            r = cpu_build(vk, gs, j, &depth, err, errlen);
        }
        if (r == RD_VK_OK && depth > gs->max_blas_depth) gs->max_blas_depth = depth;
    }
    rd_pipeline_destroy(vk, &kit.place);
    rd_gpu_lbvh_builder_destroy(vk, &kit.lbvh);
    rd_gpu_scene_lbvh_jobs_free(jobs);
    double ms = now_ms() - t0;
    gs->blas_gpu_build_ms += ms;
    gs->blas_build_ms += ms;
    return r;
}
