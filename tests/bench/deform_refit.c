/* deform_refit.c (probecast_deformbench): GPU ms of deform.comp and the per-level BLAS refit
 * (renderer/accel/gpu_deform.h, gpu_refit.h) for a skinned sheet of N triangles bent by its
 * second joint, the refitted tree's SAH cost over a fresh CPU build's, and the CPU rebuild's ms;
 * then a swing cycle refitted for 10 s without a rebuild, its trees' SAH cost and traversal speed
 * against fresh builds (swing). Usage: probecast_deformbench [triangles ...] (default 65536
 * 1048576). A benchmark: prints two tables, asserts nothing about time. */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "renderer/accel/bvh.h"
#include "renderer/accel/gpu_deform.h"
#include "renderer/accel/gpu_refit.h"
#include "renderer/scene/deform.h"
#include "tests/renderer/skinned_sheet.h"
#include "tests/renderer/trace_rig.h"

static char err[512];

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

/* The sheet's two joint matrices (column-major 4x4 each): the first still, the second turned by
 * a radians about +Z through x = 1. */
static void bend(float mats[32], double a)
{
    float cs = (float)cos(a), sn = (float)sin(a);
    const float m[32] = {1,  0,  0, 0, 0,   1,  0, 0, 0, 0, 1, 0, 0,      0,   0, 1,
                         cs, sn, 0, 0, -sn, cs, 0, 0, 0, 0, 1, 0, 1 - cs, -sn, 0, 1};
    memcpy(mats, m, sizeof m);
}

/* Poses gm by mats and refits b on the GPU; when tm is given, the deform and refit are timed. */
static bool pose_refit(rd_vk *vk, const rd_gpu_deformer *gd, const rd_gpu_refitter *gr,
                       rd_timer *tm, const rd_mesh *m, rd_gpu_deform_mesh *gm, rd_gpu_refit_blas *b,
                       const float mats[32])
{
    rd_gpu_deform_set_pose(gm, m->deform, NULL, 0, mats, 2);
    rd_cmd c;
    if (rd_cmd_begin(vk, &c, err, sizeof err) != RD_VK_OK) return false;
    if (tm) rd_timer_begin(&c, tm);
    rd_gpu_deform_record(&c, gd, gm);
    if (tm) rd_timer_mark(&c, tm, "deform");
    rd_gpu_refit_record(&c, gr, b, gm->out.address + gm->out_positions);
    if (tm) rd_timer_mark(&c, tm, "refit");
    return rd_cmd_submit_wait(vk, &c, err, sizeof err) == RD_VK_OK &&
           (!tm || rd_timer_resolve(vk, tm, err, sizeof err) == RD_VK_OK);
}

/* The posed positions (9 floats a triangle, malloc'd) and the refitted tree (rest's topology and
 * prim_index, b's nodes; free its nodes only) as they are on the GPU now. */
static float *download_pose(rd_vk *vk, const rd_mesh *m, const rd_bvh *rest,
                            const rd_gpu_deform_mesh *gm, const rd_gpu_refit_blas *b, rd_bvh *refit)
{
    size_t nv = (size_t)m->tri_count * 3;
    float *p = malloc(nv * 3 * sizeof(float));
    *refit = *rest;
    refit->nodes = malloc(rest->node_count * sizeof(pc_bvh_node));
    if (!p || !refit->nodes) abort();
    rd_buffer_download(vk, &gm->out, gm->out_positions, p, nv * 12, err, sizeof err);
    rd_buffer_download(vk, &b->nodes, 0, refit->nodes, rest->node_count * sizeof(pc_bvh_node), err,
                       sizeof err);
    return p;
}

/* Refit only through a swing cycle (the stand-in for a walk: the second joint swings 90 degrees
 * each way, 1.1 s a period, posed and refitted 60 times a second for 10 s, never rebuilt): every
 * 2 s of it, the refitted tree's SAH cost and traversal speed (1 M rays from a sphere around the
 * pose, shaders/trace.glsl; PROBECAST_TRACE_RAYS overrides the count) against a fresh CPU build
 * of the same pose. The refit starts from the rest pose's topology each time, so what a swing
 * leaves is the rest tree's boxes around the pose it reached. */
static int swing(rd_vk *vk, const rd_gpu_deformer *gd, const rd_gpu_refitter *gr,
                 const rd_pipeline *trace, rd_timer *tm, const rd_mesh *m, const rd_bvh *rest,
                 rd_gpu_deform_mesh *gm, rd_gpu_refit_blas *b)
{
    const char *env = getenv("PROBECAST_TRACE_RAYS");
    uint32_t rays = env ? (uint32_t)strtoul(env, NULL, 10) : 1u << 20;
    if (rays == 0) rays = 1;
    float *orgs = malloc((size_t)rays * 6 * sizeof(float)), mats[32];
    rd_buffer res = {0};
    if (!orgs) abort();
    if (rd_buffer_create(vk, &res, (size_t)rays * sizeof(pc_trace_hit), RD_MEMORY_READBACK, err,
                         sizeof err) != RD_VK_OK) {
        fprintf(stderr, "deformbench: %s\n", err);
        free(orgs);
        return 1;
    }
    int rc = 0;
    for (int tick = 1; tick <= 600 && rc == 0; tick++) {
        double t = tick / 60.0, a = 0.5 * M_PI * sin(2 * M_PI * t / 1.1);
        bend(mats, a);
        if (!pose_refit(vk, gd, gr, NULL, m, gm, b, mats)) rc = 1;
        if (rc || tick % 120 != 0) continue;
        rd_bvh refit, fresh;
        float *p = download_pose(vk, m, rest, gm, b, &refit);
        if (!rd_bvh_build_triangles(&fresh, p, m->tri_count, NULL)) abort();
        const pc_bvh_node *root = &fresh.nodes[0];
        const float lo[3] = {root->bmin.x, root->bmin.y, root->bmin.z};
        const float hi[3] = {root->bmax.x, root->bmax.y, root->bmax.z};
        pc_sphere_rays(orgs, orgs + 3 * (size_t)rays, rays, lo, hi);
        rd_buffer ray_buf = {0};
        double r_mrays = 0, f_mrays = 0;
        if (pc_trace_rays_upload(vk, &ray_buf, orgs, orgs + 3 * (size_t)rays, rays, err,
                                 sizeof err)) {
            r_mrays = pc_trace_speed(vk, trace, tm, &refit, p, m->tri_count, &ray_buf, &res, rays,
                                     3, NULL);
            f_mrays = pc_trace_speed(vk, trace, tm, &fresh, p, m->tri_count, &ray_buf, &res, rays,
                                     3, NULL);
        } else {
            fprintf(stderr, "deformbench: %s\n", err);
        }
        rd_buffer_destroy(vk, &ray_buf);
        printf("%10u %6.1f %6.0f %9.3f %11.2f %11.2f %6.3f\n", m->tri_count, t, a * 180 / M_PI,
               rd_bvh_sah_cost(&refit) / rd_bvh_sah_cost(&fresh), r_mrays, f_mrays,
               f_mrays > 0 ? r_mrays / f_mrays : 0);
        fflush(stdout);
        if (r_mrays <= 0 || f_mrays <= 0) rc = 1;
        free(refit.nodes);
        free(p);
        rd_bvh_destroy(&fresh);
    }
    rd_buffer_destroy(vk, &res);
    free(orgs);
    return rc;
}

/* One table row a bend angle (deform_ms, refit_ms, sah_ratio, cpu_build_ms) for a sheet of about
 * tris triangles, or (with the_swing) its swing cycle's rows. */
static int run(rd_vk *vk, const rd_gpu_deformer *gd, const rd_gpu_refitter *gr,
               const rd_pipeline *trace, rd_timer *tm, uint32_t tris, bool the_swing)
{
    uint32_t rows = (uint32_t)sqrt(tris / 8.0);
    if (rows < 1) rows = 1;
    uint32_t cols = (tris / 2 + rows - 1) / rows;
    rd_mesh m;
    pc_skinned_sheet(&m, cols, rows);
    rd_bvh rest;
    if (!rd_bvh_build_triangles(&rest, m.deform->rest_positions, m.tri_count, NULL)) abort();
    rd_gpu_deform_mesh gm;
    rd_gpu_refit_blas b;
    if (rd_gpu_deform_mesh_create(vk, &gm, &m, 2, err, sizeof err) != RD_VK_OK ||
        rd_gpu_refit_blas_create(vk, &b, &rest, err, sizeof err) != RD_VK_OK) {
        fprintf(stderr, "deformbench: %s\n", err);
        return 1;
    }
    const double angles[] = {10, 45, 90, 150};
    int rc = the_swing ? swing(vk, gd, gr, trace, tm, &m, &rest, &gm, &b) : 0;
    for (size_t i = 0; !the_swing && rc == 0 && i < sizeof angles / sizeof angles[0]; i++) {
        double dms = 0, rms = 0;
        float mats[32];
        bend(mats, angles[i] * M_PI / 180);
        const int runs = 5;
        for (int r = 0; r < runs && rc == 0; r++) {
            /* the same pose each run: refit from the rest topology is idempotent */
            if (!pose_refit(vk, gd, gr, tm, &m, &gm, &b, mats)) rc = 1;
            if (r > 0) { /* the first run warms up */
                dms += tm->ms[1] / (runs - 1);
                rms += tm->ms[2] / (runs - 1);
            }
        }
        if (rc) break;
        rd_bvh refit, fresh;
        float *p = download_pose(vk, &m, &rest, &gm, &b, &refit);
        double t0 = now_ms();
        if (!rd_bvh_build_triangles(&fresh, p, m.tri_count, NULL)) abort();
        double cpu_ms = now_ms() - t0;
        printf("%10u %6.0f %10.4f %10.4f %7u %9.3f %12.2f\n", m.tri_count, angles[i], dms, rms,
               b.level_count, rd_bvh_sah_cost(&refit) / rd_bvh_sah_cost(&fresh), cpu_ms);
        free(refit.nodes);
        free(p);
        rd_bvh_destroy(&fresh);
    }
    if (rc) fprintf(stderr, "deformbench: %s\n", err);
    rd_gpu_refit_blas_destroy(vk, &b);
    rd_gpu_deform_mesh_destroy(vk, &gm);
    rd_bvh_destroy(&rest);
    rd_mesh_deform_free(m.deform);
    free(m.positions);
    free(m.normals);
    return rc;
}

int main(int argc, char **argv)
{
    rd_vk vk;
    if (rd_vk_create(&vk, NULL, err, sizeof err) != RD_VK_OK) {
        fprintf(stderr, "deformbench: %s\n", err);
        return 1;
    }
    rd_vk_log_device(&vk, stderr);
    rd_gpu_deformer gd;
    rd_gpu_refitter gr;
    rd_timer tm;
    int rc = 0;
    if (rd_gpu_deformer_create(&vk, &gd, err, sizeof err) != RD_VK_OK ||
        rd_gpu_refitter_create(&vk, &gr, err, sizeof err) != RD_VK_OK ||
        rd_timer_create(&vk, &tm, err, sizeof err) != RD_VK_OK) {
        fprintf(stderr, "deformbench: %s\n", err);
        rc = 1;
    }
    rd_pipeline trace = {0};
    if (rc == 0 && pc_trace_pipeline_create(&vk, &trace, err, sizeof err) != RD_VK_OK) {
        fprintf(stderr, "deformbench: %s\n", err);
        rc = 1;
    }
    uint32_t sizes[16], count = 0;
    for (int i = 1; i < argc && count < 16; i++)
        sizes[count++] = (uint32_t)strtoul(argv[i], NULL, 10);
    if (count == 0) sizes[count++] = 65536, sizes[count++] = 1048576;
    printf("%10s %6s %10s %10s %7s %9s %12s\n", "triangles", "angle", "deform_ms", "refit_ms",
           "levels", "sah_ratio", "cpu_build_ms");
    for (uint32_t i = 0; rc == 0 && i < count; i++)
        rc = run(&vk, &gd, &gr, &trace, &tm, sizes[i], false);
    printf("\nswing cycle, refit only (no rebuild): the refitted tree against a fresh CPU build of "
           "the pose\n%10s %6s %6s %9s %11s %11s %6s\n",
           "triangles", "t_s", "angle", "sah_ratio", "refit_Mrays", "fresh_Mrays", "ratio");
    for (uint32_t i = 0; rc == 0 && i < count; i++)
        rc = run(&vk, &gd, &gr, &trace, &tm, sizes[i], true);
    rd_pipeline_destroy(&vk, &trace);
    rd_timer_destroy(&vk, &tm);
    rd_gpu_refitter_destroy(&vk, &gr);
    rd_gpu_deformer_destroy(&vk, &gd);
    rd_vk_destroy(&vk);
    return rc;
}
