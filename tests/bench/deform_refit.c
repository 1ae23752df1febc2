/* deform_refit.c (probecast_deformbench): GPU ms of deform.comp and the per-level BLAS refit
 * (renderer/accel/gpu_deform.h, gpu_refit.h) for a skinned sheet of N triangles bent by its
 * second joint, the refitted tree's SAH cost over a fresh CPU build's, and the CPU rebuild's ms.
 * Usage: probecast_deformbench [triangles ...] (default 65536 1048576). A benchmark: prints a
 * table, asserts nothing about time. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "renderer/accel/bvh.h"
#include "renderer/accel/gpu_deform.h"
#include "renderer/accel/gpu_refit.h"
#include "renderer/scene/deform.h"
#include "tests/renderer/skinned_sheet.h"

static char err[512];

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

static int run(rd_vk *vk, const rd_gpu_deformer *gd, const rd_gpu_refitter *gr, rd_timer *tm,
               uint32_t tris)
{
    uint32_t rows = (uint32_t)sqrt(tris / 8.0);
    if (rows < 1) rows = 1;
    uint32_t cols = (tris / 2 + rows - 1) / rows;
    rd_mesh m;
    pc_skinned_sheet(&m, cols, rows);
    rd_bvh rest, fresh;
    if (!rd_bvh_build_triangles(&rest, m.deform->rest_positions, m.tri_count, NULL)) abort();
    rd_gpu_deform_mesh gm;
    rd_gpu_refit_blas b;
    if (rd_gpu_deform_mesh_create(vk, &gm, &m, 2, err, sizeof err) != RD_VK_OK ||
        rd_gpu_refit_blas_create(vk, &b, &rest, err, sizeof err) != RD_VK_OK) {
        fprintf(stderr, "deformbench: %s\n", err);
        return 1;
    }
    const double angles[] = {10, 45, 90, 150};
    for (size_t i = 0; i < sizeof angles / sizeof angles[0]; i++) {
        double a = angles[i] * M_PI / 180, dms = 0, rms = 0;
        float cs = (float)cos(a), sn = (float)sin(a);
        float mats[32] = {1,  0,  0, 0, 0,   1,  0, 0, 0, 0, 1, 0, 0,      0,   0, 1,
                          cs, sn, 0, 0, -sn, cs, 0, 0, 0, 0, 1, 0, 1 - cs, -sn, 0, 1};
        const int runs = 5;
        for (int r = 0; r < runs; r++) {
            /* the same pose each run: refit from the rest topology is idempotent */
            rd_gpu_deform_set_pose(&gm, m.deform, NULL, 0, mats, 2);
            rd_cmd c;
            if (rd_cmd_begin(vk, &c, err, sizeof err) != RD_VK_OK) return 1;
            rd_timer_begin(&c, tm);
            rd_gpu_deform_record(&c, gd, &gm);
            rd_timer_mark(&c, tm, "deform");
            rd_gpu_refit_record(&c, gr, &b, gm.out.address + gm.out_positions);
            rd_timer_mark(&c, tm, "refit");
            if (rd_cmd_submit_wait(vk, &c, err, sizeof err) != RD_VK_OK ||
                rd_timer_resolve(vk, tm, err, sizeof err) != RD_VK_OK)
                return 1;
            if (r > 0) { /* the first run warms up */
                dms += tm->ms[1] / (runs - 1);
                rms += tm->ms[2] / (runs - 1);
            }
        }
        size_t nv = (size_t)m.tri_count * 3;
        float *p = malloc(nv * 3 * sizeof(float));
        rd_bvh refit = rest;
        refit.nodes = malloc(rest.node_count * sizeof(pc_bvh_node));
        if (!p || !refit.nodes) abort();
        rd_buffer_download(vk, &gm.out, gm.out_positions, p, nv * 12, err, sizeof err);
        rd_buffer_download(vk, &b.nodes, 0, refit.nodes, rest.node_count * sizeof(pc_bvh_node), err,
                           sizeof err);
        double t0 = now_ms();
        if (!rd_bvh_build_triangles(&fresh, p, m.tri_count, NULL)) abort();
        double cpu_ms = now_ms() - t0;
        printf("%10u %6.0f %10.4f %10.4f %7u %9.3f %12.2f\n", m.tri_count, angles[i], dms, rms,
               b.level_count, rd_bvh_sah_cost(&refit) / rd_bvh_sah_cost(&fresh), cpu_ms);
        free(refit.nodes);
        free(p);
        rd_bvh_destroy(&fresh);
    }
    rd_gpu_refit_blas_destroy(vk, &b);
    rd_gpu_deform_mesh_destroy(vk, &gm);
    rd_bvh_destroy(&rest);
    rd_mesh_deform_free(m.deform);
    free(m.positions);
    free(m.normals);
    return 0;
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
    printf("%10s %6s %10s %10s %7s %9s %12s\n", "triangles", "angle", "deform_ms", "refit_ms",
           "levels", "sah_ratio", "cpu_build_ms");
    for (int i = 1; rc == 0 && i <= (argc > 1 ? argc - 1 : 2); i++) {
        uint32_t n = argc > 1 ? (uint32_t)strtoul(argv[i], NULL, 10) : (i == 1 ? 65536u : 1048576u);
        rc = run(&vk, &gd, &gr, &tm, n);
    }
    rd_timer_destroy(&vk, &tm);
    rd_gpu_refitter_destroy(&vk, &gr);
    rd_gpu_deformer_destroy(&vk, &gd);
    rd_vk_destroy(&vk);
    return rc;
}
