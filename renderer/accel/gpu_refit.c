/* gpu_refit.c: BLAS refit on the GPU, one dispatch per level (see gpu_refit.h). */
#include "renderer/accel/gpu_refit.h"

#include <assert.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "shaders/gpu_types.h"
#include "shaders/refit.spv.h"

static const rd_pipeline_desc kPipelines[] = {
    RD_PIPELINE_DESC(rd_gpu_refitter, refit, "refit", pc_spv_refit, (uint32_t)sizeof(pc_push)),
};
#define PIPELINE_COUNT (sizeof kPipelines / sizeof kPipelines[0])

rd_vk_result rd_gpu_refitter_create(rd_vk *vk, rd_gpu_refitter *g, char *err, size_t errlen)
{
    memset(g, 0, sizeof *g);
    return rd_pipelines_create(vk, g, kPipelines, PIPELINE_COUNT, err, errlen);
}

void rd_gpu_refitter_destroy(rd_vk *vk, rd_gpu_refitter *g)
{
    rd_pipelines_destroy(vk, g, kPipelines, PIPELINE_COUNT);
}

static void *xcalloc(size_t n, size_t size)
{
    void *p = calloc(n ? n : 1, size);
    if (!p) {
        fprintf(stderr, "probecast: out of memory (%zu x %zu bytes of BLAS refit)\n", n, size);
        abort();
    }
    return p;
}

/* The topology of bvh (node indices plus node_base), uploaded; nodes: upload bvh's own too. */
static rd_vk_result blas_create(rd_vk *vk, rd_gpu_refit_blas *b, const rd_bvh *bvh, bool nodes,
                                uint32_t node_base, uint32_t tri_base, char *err, size_t errlen)
{
    memset(b, 0, sizeof *b);
    b->node_base = node_base;
    b->tri_base = tri_base;
    uint32_t nn = bvh->node_count, np = bvh->prim_count;
    b->node_count = nn;
    b->prim_count = np;
    /* depth of every node reachable from the root, walked with an explicit stack (any node
     * order: the CPU builder's children come after their parent, the LBVH's may come before;
     * an LBVH is up to 64 levels deep); a level reads only deeper, earlier-refitted nodes.
     * Nodes off the tree (none in a valid one) and bad child indices are left out. */
    uint32_t *depth = xcalloc(nn, sizeof *depth), max_depth = 0;
    uint32_t *stack = xcalloc(nn, sizeof *stack), sp = 0, visits = 0;
    for (uint32_t i = 0; i < nn; i++)
        depth[i] = UINT32_MAX;
    if (nn && np) depth[0] = 0, stack[sp++] = 0;
    while (sp > 0 && visits++ < nn) {
        uint32_t i = stack[--sp];
        if (rd_bvh_node_count(&bvh->nodes[i]) != 0) continue;
        uint32_t c = rd_bvh_node_first(&bvh->nodes[i]);
        if (c + 1 >= nn || c + 1 < c || depth[c] != UINT32_MAX || depth[c + 1] != UINT32_MAX ||
            sp + 2 > nn)
            continue;
        depth[c] = depth[c + 1] = depth[i] + 1;
        if (depth[c] > max_depth) max_depth = depth[c];
        stack[sp++] = c, stack[sp++] = c + 1;
    }
    free(stack);
    b->level_count = np ? max_depth + 1 : 0;
    b->level_start = xcalloc((size_t)b->level_count + 1, sizeof *b->level_start);
    uint32_t *topo = xcalloc((size_t)nn + np, sizeof *topo);
    uint32_t at = 0;
    for (uint32_t l = 0; l < b->level_count; l++) {
        b->level_start[l] = at;
        uint32_t want = max_depth - l; /* deepest first */
        for (uint32_t i = 0; i < nn; i++)
            if (depth[i] == want) topo[at++] = node_base + i;
    }
    b->level_start[b->level_count] = at;
    memcpy(topo + nn, bvh->prim_index, (size_t)np * sizeof *topo);
    free(depth);

    size_t node_bytes = (size_t)nn * sizeof(pc_bvh_node), topo_bytes = ((size_t)nn + np) * 4;
    rd_vk_result r = RD_VK_OK;
    if (nodes) {
        r = rd_buffer_create(vk, &b->nodes, node_bytes, RD_MEMORY_DEVICE, err, errlen);
        if (r == RD_VK_OK)
            r = rd_buffer_upload(vk, &b->nodes, 0, bvh->nodes, node_bytes, err, errlen);
        b->node_address = b->nodes.address;
    }
    if (r == RD_VK_OK)
        r = rd_buffer_create(vk, &b->topology, topo_bytes, RD_MEMORY_DEVICE, err, errlen);
    if (r == RD_VK_OK) r = rd_buffer_upload(vk, &b->topology, 0, topo, topo_bytes, err, errlen);
    free(topo);
    if (r != RD_VK_OK) rd_gpu_refit_blas_destroy(vk, b);
    return r;
}

rd_vk_result rd_gpu_refit_blas_create(rd_vk *vk, rd_gpu_refit_blas *b, const rd_bvh *bvh, char *err,
                                      size_t errlen)
{
    return blas_create(vk, b, bvh, true, 0, 0, err, errlen);
}

rd_vk_result rd_gpu_refit_blas_create_at(rd_vk *vk, rd_gpu_refit_blas *b, const rd_bvh *bvh,
                                         VkDeviceAddress node_address, uint32_t node_base,
                                         uint32_t tri_base, char *err, size_t errlen)
{
    rd_vk_result r = blas_create(vk, b, bvh, false, node_base, tri_base, err, errlen);
    b->node_address = r == RD_VK_OK ? node_address : 0;
    return r;
}

void rd_gpu_refit_blas_destroy(rd_vk *vk, rd_gpu_refit_blas *b)
{
    rd_buffer_destroy(vk, &b->topology);
    rd_buffer_destroy(vk, &b->nodes);
    free(b->level_start);
    b->level_start = NULL;
    b->level_count = 0;
}

void rd_gpu_refit_record(rd_cmd *c, const rd_gpu_refitter *g, const rd_gpu_refit_blas *b,
                         VkDeviceAddress positions)
{
    for (uint32_t l = 0; l < b->level_count; l++) {
        uint32_t n = b->level_start[l + 1] - b->level_start[l];
        pc_push push = {
            .buf0 = b->node_address,
            .buf1 = b->topology.address,
            .buf2 = positions,
            .params = {n, b->level_start[l], b->node_count, b->tri_base},
        };
        if (n) rd_cmd_dispatch(c, &g->refit, &push, (n + PC_WG_1D - 1) / PC_WG_1D, 1, 1);
        rd_cmd_barrier(c);
    }
}

bool rd_gpu_refit_should_rebuild(double sah_refitted, double sah_fresh)
{
    if (!(sah_fresh > 0) || !isfinite(sah_fresh) || !isfinite(sah_refitted)) return true;
    return sah_refitted > RD_GPU_REFIT_REBUILD_SAH_RATIO * sah_fresh;
}
