/* trace_rig.c: see trace_rig.h. */
#include "trace_rig.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bvh_check.h"
#include "shaders/test_trace.spv.h"

void pc_trace_scene_destroy(rd_vk *vk, pc_trace_scene *ts)
{
    for (int i = 0; i < 5; i++)
        rd_buffer_destroy(vk, &ts->buf[i]);
    rd_buffer_destroy(vk, &ts->globals);
}

bool pc_trace_scene_create(rd_vk *vk, pc_trace_scene *ts, const rd_bvh *bvh, const float *pos,
                           uint32_t n, char *err, size_t errlen)
{
    memset(ts, 0, sizeof *ts);
    pc_tri *tris = malloc((size_t)(n ? n : 1) * sizeof *tris);
    if (!tris) abort();
    for (uint32_t k = 0; k < n; k++) {
        const float *p = pos + 9 * (size_t)bvh->prim_index[k];
        tris[k] = (pc_tri){{p[0], p[1], p[2], pc_u2f(0)},
                           {p[3], p[4], p[5], pc_u2f(0)},
                           {p[6], p[7], p[8], pc_u2f(bvh->prim_index[k])}};
    }
    pc_instance inst = {.info = {0, 0, 0, 0}};
    for (int r = 0; r < 3; r++) {
        float row[4] = {r == 0, r == 1, r == 2, 0};
        inst.object_to_world[r] = inst.world_to_object[r] = (pc_vec4){row[0], row[1], row[2], 0};
    }
    pc_bvh_node tlas = bvh->nodes[0];
    tlas.bmin.w = pc_u2f(0);
    tlas.bmax.w = pc_u2f(1);
    uint32_t zero = 0;
    const void *data[5] = {bvh->nodes, tris, &inst, &tlas, &zero};
    size_t bytes[5] = {(size_t)bvh->node_count * sizeof(pc_bvh_node), (size_t)n * sizeof *tris,
                       sizeof inst, sizeof tlas, sizeof zero};
    bool ok = true;
    for (int i = 0; i < 5 && ok; i++)
        ok = bytes[i] > 0 &&
             rd_buffer_create(vk, &ts->buf[i], bytes[i], RD_MEMORY_DEVICE, err, errlen) ==
                 RD_VK_OK &&
             rd_buffer_upload(vk, &ts->buf[i], 0, data[i], bytes[i], err, errlen) == RD_VK_OK;
    free(tris);
    pc_globals *g = calloc(1, sizeof *g);
    if (!g) abort();
    g->scene.blas_nodes = ts->buf[0].address;
    g->scene.tris = ts->buf[1].address;
    g->scene.instances = ts->buf[2].address;
    g->scene.tlas_nodes = ts->buf[3].address;
    g->scene.tlas_index = ts->buf[4].address;
    g->scene.counts = (pc_uvec4){1, 0, 0, 0};
    ok = ok &&
         rd_buffer_create(vk, &ts->globals, sizeof *g, RD_MEMORY_DEVICE, err, errlen) == RD_VK_OK &&
         rd_buffer_upload(vk, &ts->globals, 0, g, sizeof *g, err, errlen) == RD_VK_OK;
    free(g);
    if (!ok) pc_trace_scene_destroy(vk, ts);
    return ok;
}

rd_vk_result pc_trace_pipeline_create(rd_vk *vk, rd_pipeline *pipe, char *err, size_t errlen)
{
    return rd_pipeline_create(vk, pipe, "test_trace", pc_spv_test_trace, sizeof pc_spv_test_trace,
                              sizeof(pc_push), err, errlen);
}

bool pc_trace_rays_upload(rd_vk *vk, rd_buffer *buf, const float *orgs, const float *dirs,
                          uint32_t rays, char *err, size_t errlen)
{
    size_t bytes = (size_t)rays * 8 * sizeof(float);
    float *ray_buf = malloc(bytes);
    if (!ray_buf) abort();
    for (uint32_t i = 0; i < rays; i++) {
        const float *o = orgs + 3 * (size_t)i, *d = dirs + 3 * (size_t)i;
        float r[8] = {o[0], o[1], o[2], 0, d[0], d[1], d[2], INFINITY};
        memcpy(ray_buf + 8 * (size_t)i, r, sizeof r);
    }
    bool ok = rd_buffer_create(vk, buf, bytes, RD_MEMORY_DEVICE, err, errlen) == RD_VK_OK &&
              rd_buffer_upload(vk, buf, 0, ray_buf, bytes, err, errlen) == RD_VK_OK;
    free(ray_buf);
    return ok;
}

bool pc_trace_rays(rd_vk *vk, const rd_pipeline *pipe, const pc_trace_scene *ts,
                   const rd_buffer *ray_buf, const rd_buffer *res, uint32_t rays, rd_timer *timer,
                   char *err, size_t errlen)
{
    rd_cmd c;
    if (rd_cmd_begin(vk, &c, err, errlen) != RD_VK_OK) return false;
    if (timer) rd_timer_begin(&c, timer);
    pc_push push = {.globals = ts->globals.address,
                    .buf0 = ray_buf->address,
                    .buf1 = res->address,
                    .params = {rays, 0, 0, 0}};
    rd_cmd_dispatch(&c, pipe, &push, (rays + PC_WG_1D - 1) / PC_WG_1D, 1, 1);
    rd_cmd_barrier(&c);
    if (timer) rd_timer_mark(&c, timer, "trace");
    return rd_cmd_submit_wait(vk, &c, err, errlen) == RD_VK_OK &&
           (!timer || rd_timer_resolve(vk, timer, err, errlen) == RD_VK_OK);
}

double pc_trace_speed(rd_vk *vk, const rd_pipeline *pipe, rd_timer *timer, const rd_bvh *bvh,
                      const float *pos, uint32_t n, const rd_buffer *ray_buf, const rd_buffer *res,
                      uint32_t rays, int reps, pc_trace_hit *hits)
{
    char err[512];
    pc_trace_scene ts;
    if (!pc_trace_scene_create(vk, &ts, bvh, pos, n, err, sizeof err)) {
        fprintf(stderr, "trace scene: %s\n", err);
        return 0;
    }
    double best = 1e30;
    bool ok = true;
    for (int rep = 0; rep < reps && ok; rep++) {
        struct timespec t0, t1;
        clock_gettime(CLOCK_MONOTONIC, &t0);
        ok = pc_trace_rays(vk, pipe, &ts, ray_buf, res, rays, timer, err, sizeof err);
        clock_gettime(CLOCK_MONOTONIC, &t1);
        double ms = timer->valid && timer->count > 1
                        ? timer->ms[1]
                        : (double)(t1.tv_sec - t0.tv_sec) * 1e3 + (t1.tv_nsec - t0.tv_nsec) * 1e-6;
        best = ms < best ? ms : best;
    }
    if (ok && hits)
        ok = rd_buffer_download(vk, res, 0, hits, (size_t)rays * sizeof *hits, err, sizeof err) ==
             RD_VK_OK;
    if (!ok) fprintf(stderr, "trace: %s\n", err);
    pc_trace_scene_destroy(vk, &ts);
    return ok && best > 0 ? rays / (best * 1e3) : 0;
}

void pc_sphere_rays(float *orgs, float *dirs, uint32_t rays, const float lo[3], const float hi[3])
{
    float c[3], r = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5f * (lo[k] + hi[k]);
        r += (hi[k] - c[k]) * (hi[k] - c[k]);
    }
    r = 1.5f * sqrtf(r);
    rng_seed(99);
    for (uint32_t i = 0; i < rays; i++) {
        float u[3], *o = orgs + 3 * (size_t)i, *d = dirs + 3 * (size_t)i, len = 0;
        rng_unit(u);
        for (int k = 0; k < 3; k++)
            o[k] = c[k] + r * u[k];
        for (int k = 0; k < 3; k++) {
            d[k] = rng_range(lo[k], hi[k]) - o[k];
            len += d[k] * d[k];
        }
        len = sqrtf(len);
        for (int k = 0; k < 3; k++)
            d[k] /= len;
    }
}
