/* rt_wide.c: the wide tracers' nodes on the GPU (see rt_wide.h). */
#include "rt_wide.h"

#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "bvh_cwide.h"
#include "bvh_wide.h"

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return 1e3 * (double)ts.tv_sec + 1e-6 * (double)ts.tv_nsec;
}

static void *xmalloc(size_t n)
{
    void *p = malloc(n ? n : 1);
    if (!p) {
        fprintf(stderr, "probecast_rtbench: out of memory\n");
        abort();
    }
    return p;
}

static rd_vk_result upload(rd_vk *vk, rd_buffer *b, const void *data, size_t size, char *err,
                           size_t errlen)
{
    rd_vk_result r = rd_buffer_create(vk, b, size, RD_MEMORY_DEVICE, err, errlen);
    if (r == RD_VK_OK && size > 0) r = rd_buffer_upload(vk, b, 0, data, size, err, errlen);
    return r;
}

/* Collapses to compressed 8-wide nodes and uploads them (the BLAS and TLAS nodes as read back). */
static rd_vk_result create_cwide(rd_vk *vk, rtb_wide_gpu *w, const rd_gpu_scene *gs,
                                 const pc_bvh_node *blas, const pc_bvh_node *tlas, char *err,
                                 size_t errlen)
{
    rtb_cwide cw = {0};
    uint32_t *roots = xmalloc(gs->mesh_count * sizeof *roots);
    rtb_cwide_refs refs = {0};
    double t0 = now_ms();
    for (uint32_t m = 0; m < gs->mesh_count; m++)
        roots[m] = rtb_cwide_collapse(&cw, blas, gs->mesh_root[m]);
    refs.info.x = rtb_cwide_collapse(&cw, tlas, 0);
    w->cwide.collapse_ms = now_ms() - t0;
    w->cwide.node_count = cw.node_count;
    w->cwide.leaf_count = cw.leaf_count;
    w->cwide.depth = cw.depth;
    w->cwide.node_bytes = rtb_cwide_bytes(&cw);
    rd_vk_result r = RD_VK_OK;
    if (rtb_wide_stack_need(RTB_CWIDE, cw.depth) > RTB_CWIDE_STACK) {
        snprintf(err, errlen, "compressed 8-wide BVH of %u levels needs %u stack entries (have %u)",
                 cw.depth, rtb_wide_stack_need(RTB_CWIDE, cw.depth), RTB_CWIDE_STACK);
        r = RD_VK_ERR_UNSUPPORTED;
    }
    if (r == RD_VK_OK)
        r = upload(vk, &w->cwide.nodes, cw.nodes, (size_t)cw.node_count * sizeof *cw.nodes, err,
                   errlen);
    if (r == RD_VK_OK)
        r = upload(vk, &w->cwide.leaf_first, cw.leaf_first,
                   (size_t)cw.leaf_count * sizeof *cw.leaf_first, err, errlen);
    if (r == RD_VK_OK)
        r = upload(vk, &w->cwide.mesh_root, roots, gs->mesh_count * sizeof *roots, err, errlen);
    if (r == RD_VK_OK) {
        refs.nodes = w->cwide.nodes.address;
        refs.leaf_first = w->cwide.leaf_first.address;
        refs.mesh_root = w->cwide.mesh_root.address;
        r = upload(vk, &w->cwide.refs, &refs, sizeof refs, err, errlen);
    }
    rtb_cwide_destroy(&cw);
    free(roots);
    return r;
}

rd_vk_result rtb_wide_gpu_create(rd_vk *vk, rtb_wide_gpu *w, const rd_gpu_scene *gs, char *err,
                                 size_t errlen)
{
    *w = (rtb_wide_gpu){0};
    uint64_t nb = gs->blas_node_count, nt = gs->tlas_node_count;
    pc_bvh_node *blas = xmalloc(nb * sizeof *blas), *tlas = xmalloc(nt * sizeof *tlas);
    rd_vk_result r =
        rd_buffer_download(vk, &gs->blas_nodes, 0, blas, nb * sizeof *blas, err, errlen);
    if (r == RD_VK_OK)
        r = rd_buffer_download(vk, &gs->tlas_nodes, 0, tlas, nt * sizeof *tlas, err, errlen);
    rtb_wide wide = {0};
    uint32_t *roots = xmalloc(gs->mesh_count * sizeof *roots);
    rtb_wide_refs refs = {0};
    if (r == RD_VK_OK) {
        double t0 = now_ms();
        for (uint32_t m = 0; m < gs->mesh_count; m++)
            roots[m] = rtb_wide_collapse(&wide, blas, gs->mesh_root[m]);
        refs.info.x = rtb_wide_collapse(&wide, tlas, 0);
        w->collapse_ms = now_ms() - t0;
        w->node_count = wide.node_count;
        w->depth = wide.depth;
        w->node_bytes = (uint64_t)wide.node_count * sizeof(rtb_wide_node);
        w->binary_node_bytes = (nb + nt) * sizeof(pc_bvh_node);
        if (rtb_wide_stack_need(RTB_WIDE, wide.depth) > RTB_WIDE_STACK) {
            snprintf(err, errlen, "wide BVH of %u levels needs %u stack entries (have %u)",
                     wide.depth, rtb_wide_stack_need(RTB_WIDE, wide.depth), RTB_WIDE_STACK);
            r = RD_VK_ERR_UNSUPPORTED;
        }
    }
    if (r == RD_VK_OK) r = upload(vk, &w->nodes, wide.nodes, w->node_bytes, err, errlen);
    if (r == RD_VK_OK)
        r = upload(vk, &w->mesh_root, roots, gs->mesh_count * sizeof *roots, err, errlen);
    if (r == RD_VK_OK) {
        refs.nodes = w->nodes.address;
        refs.mesh_root = w->mesh_root.address;
        r = upload(vk, &w->refs, &refs, sizeof refs, err, errlen);
    }
    if (r == RD_VK_OK) r = create_cwide(vk, w, gs, blas, tlas, err, errlen);
    rtb_wide_destroy(&wide);
    free(roots);
    free(tlas);
    free(blas);
    if (r != RD_VK_OK) rtb_wide_gpu_destroy(vk, w);
    return r;
}

void rtb_wide_gpu_destroy(rd_vk *vk, rtb_wide_gpu *w)
{
    rd_buffer_destroy(vk, &w->cwide.refs);
    rd_buffer_destroy(vk, &w->cwide.mesh_root);
    rd_buffer_destroy(vk, &w->cwide.leaf_first);
    rd_buffer_destroy(vk, &w->cwide.nodes);
    rd_buffer_destroy(vk, &w->refs);
    rd_buffer_destroy(vk, &w->mesh_root);
    rd_buffer_destroy(vk, &w->nodes);
}
