/* test_gpu_lbvh.c: the GPU LBVH builder (renderer/accel/gpu_lbvh.h) on lavapipe: for random
 * triangle soups of 0 to 5000 triangles and degenerate meshes (all centroids equal, a flat
 * plane, a few non-finite triangles) every structural promise of bvh.h (check_triangles with
 * one triangle a leaf and with subtrees of up to 4 collapsed: each triangle in exactly one leaf,
 * every box inside its parent, depth within RD_BVH_MAX_DEPTH), closest hits equal to brute force,
 * the GPU traversal (shaders/trace.glsl through test_trace.comp) agreeing with the CPU's,
 * and an SAH cost within 3x of the CPU builder's on the same mesh (printed). Prints the build time
 * (submit and wait) of each size; `test_gpu_lbvh bench` builds larger meshes and prints only the
 * table. */
#include "bvh_check.h"
#include "renderer/accel/bvh.h"
#include "renderer/accel/gpu_lbvh.h"
#include "renderer/vk/vk_context.h"
#include "shaders/test_trace.spv.h"
#include "test_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static char err[512];
static double g_worst_ratio = 0;
static uint32_t g_gpu_rays = 0, g_gpu_differ = 0;
static rd_pipeline g_trace; /* shaders/test_trace.comp: trace_ray of shaders/trace.glsl */

typedef struct gpu_hit {
    uint32_t t, u, v, hit;
    uint32_t instance, tri, backface, pad;
} gpu_hit;

/* Traces rays on the GPU with shaders/trace.glsl over bvh (one instance, identity transform,
 * under a one-leaf TLAS) and compares each closest hit with the CPU traversal of the same tree:
 * the same triangle, or t within 1e-5 relative (ties); returns the rays that differ. */
static uint32_t gpu_trace_differences(rd_vk *vk, const rd_bvh *bvh, const float *pos, uint32_t n,
                                      const float *orgs, const float *dirs, uint32_t rays)
{
    pc_tri *tris = malloc((size_t)n * sizeof *tris);
    float *ray_buf = malloc((size_t)rays * 8 * sizeof(float));
    gpu_hit *res = malloc((size_t)rays * sizeof *res);
    if (!tris || !ray_buf || !res) abort();
    for (uint32_t k = 0; k < n; k++) {
        const float *p = pos + 9 * (size_t)bvh->prim_index[k];
        tris[k] = (pc_tri){{p[0], p[1], p[2], pc_u2f(0)},
                           {p[3], p[4], p[5], pc_u2f(0)},
                           {p[6], p[7], p[8], pc_u2f(bvh->prim_index[k])}};
    }
    for (uint32_t i = 0; i < rays; i++) {
        const float *o = orgs + 3 * (size_t)i, *d = dirs + 3 * (size_t)i;
        float r[8] = {o[0], o[1], o[2], 0, d[0], d[1], d[2], INFINITY};
        memcpy(ray_buf + 8 * (size_t)i, r, sizeof r);
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
    rd_buffer b[7] = {{0}};
    const void *data[6] = {bvh->nodes, tris, &inst, &tlas, &zero, ray_buf};
    size_t bytes[6] = {bvh->node_count * sizeof(pc_bvh_node),
                       n * sizeof *tris,
                       sizeof inst,
                       sizeof tlas,
                       sizeof zero,
                       (size_t)rays * 8 * sizeof(float)};
    bool ok = true;
    for (int i = 0; i < 6 && ok; i++)
        ok = rd_buffer_create(vk, &b[i], bytes[i], RD_MEMORY_DEVICE, err, sizeof err) == RD_VK_OK &&
             rd_buffer_upload(vk, &b[i], 0, data[i], bytes[i], err, sizeof err) == RD_VK_OK;
    pc_globals *g = calloc(1, sizeof *g);
    if (!g) abort();
    g->scene.blas_nodes = b[0].address;
    g->scene.tris = b[1].address;
    g->scene.instances = b[2].address;
    g->scene.tlas_nodes = b[3].address;
    g->scene.tlas_index = b[4].address;
    g->scene.counts = (pc_uvec4){1, 0, 0, 0};
    rd_buffer bg = {0};
    ok = ok &&
         rd_buffer_create(vk, &bg, sizeof *g, RD_MEMORY_DEVICE, err, sizeof err) == RD_VK_OK &&
         rd_buffer_upload(vk, &bg, 0, g, sizeof *g, err, sizeof err) == RD_VK_OK &&
         rd_buffer_create(vk, &b[6], (size_t)rays * sizeof *res, RD_MEMORY_READBACK, err,
                          sizeof err) == RD_VK_OK;
    rd_cmd c;
    ok = ok && rd_cmd_begin(vk, &c, err, sizeof err) == RD_VK_OK;
    if (ok) {
        pc_push push = {.globals = bg.address,
                        .buf0 = b[5].address,
                        .buf1 = b[6].address,
                        .params = {rays, 0, 0, 0}};
        rd_cmd_dispatch(&c, &g_trace, &push, (rays + PC_WG_1D - 1) / PC_WG_1D, 1, 1);
        rd_cmd_barrier(&c);
        ok = rd_cmd_submit_wait(vk, &c, err, sizeof err) == RD_VK_OK &&
             rd_buffer_download(vk, &b[6], 0, res, (size_t)rays * sizeof *res, err, sizeof err) ==
                 RD_VK_OK;
    }
    CHECKF(ok, "GPU trace: %s", err);
    uint32_t differ = ok ? 0 : rays;
    for (uint32_t i = 0; ok && i < rays; i++) {
        float t_cpu = 0, t_gpu;
        int64_t cpu = rd_bvh_closest_triangle(bvh, pos, orgs + 3 * (size_t)i, dirs + 3 * (size_t)i,
                                              0, INFINITY, &t_cpu);
        memcpy(&t_gpu, &res[i].t, sizeof t_gpu);
        int64_t gpu = res[i].hit ? (int64_t)pc_f2u(tris[res[i].tri].v2.w) : -1;
        bool same = gpu == cpu || (gpu >= 0 && cpu >= 0 && fabsf(t_gpu - t_cpu) <= 1e-5f * t_cpu);
        if (!same) differ++;
    }
    for (int i = 0; i < 7; i++)
        rd_buffer_destroy(vk, &b[i]);
    rd_buffer_destroy(vk, &bg);
    free(g);
    free(res);
    free(ray_buf);
    free(tris);
    return differ;
}

static void random_soup(float *pos, uint32_t n, float size)
{
    for (uint32_t i = 0; i < n; i++) {
        float c[3] = {rng_range(-1, 1), rng_range(-1, 1), rng_range(-1, 1)};
        random_tri(pos + 9 * (size_t)i, c, size);
    }
}

/* Builds pos on the GPU with leaves of at most max_leaf triangles and checks it. */
static void check_build(rd_vk *vk, const rd_gpu_lbvh_builder *b, const char *what, const float *pos,
                        uint32_t n, uint32_t rays, uint32_t max_leaf)
{
    rd_bvh gpu;
    double ms = 0;
    rd_vk_result r =
        rd_gpu_lbvh_build_download(vk, b, pos, n, max_leaf, NULL, &gpu, &ms, err, sizeof err);
    CHECKF(r == RD_VK_OK, "%s: %s", what, err);
    if (r != RD_VK_OK) return;
    if (max_leaf == 1)
        CHECKF(gpu.node_count == (n ? 2 * n - 1 : 1), "%s: %u nodes", what, gpu.node_count);
    int bad = check_triangles(what, &gpu, pos, n, max_leaf);
    CHECKF(bad == 0, "%s: %d structural problems", what, bad);

    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t i = 0; i < n; i++) {
        if (!tri_finite(pos + 9 * (size_t)i)) continue;
        for (int k = 0; k < 9; k++) {
            lo[k % 3] = fminf(lo[k % 3], pos[9 * (size_t)i + k]);
            hi[k % 3] = fmaxf(hi[k % 3], pos[9 * (size_t)i + k]);
        }
    }
    if (bad == 0 && n > 0 && rays > 0) {
        float *orgs = malloc((size_t)rays * 6 * sizeof(float));
        if (!orgs) abort();
        make_rays(orgs, orgs + 3 * (size_t)rays, rays, lo, hi, 0.5f, pos, n);
        uint32_t hits =
            compare_rays(what, &gpu, pos, n, orgs, orgs + 3 * (size_t)rays, rays, 0, INFINITY);
        CHECKF(hits > 0, "%s: no ray hit anything", what);
        if (!box_empty(&gpu.nodes[0])) {
            uint32_t differ =
                gpu_trace_differences(vk, &gpu, pos, n, orgs, orgs + 3 * (size_t)rays, rays);
            CHECKF(differ <= rays / 100, "%s: %u of %u rays traced on the GPU differ", what, differ,
                   rays);
            g_gpu_rays += rays;
            g_gpu_differ += differ;
        }
        free(orgs);
    }

    rd_bvh cpu;
    CHECK(rd_bvh_build_triangles(&cpu, pos, n, NULL));
    double sah_gpu = rd_bvh_sah_cost(&gpu), sah_cpu = rd_bvh_sah_cost(&cpu);
    double ratio = sah_cpu > 0 ? sah_gpu / sah_cpu : 0;
    fprintf(stderr,
            "%-26s %5u tris leaf<=%u %5u nodes depth %2u (CPU %2u) SAH %8.2f vs CPU %8.2f = "
            "%.2fx %7.2f ms\n",
            what, n, max_leaf, gpu.node_count, gpu.depth, cpu.depth, sah_gpu, sah_cpu, ratio, ms);
    if (sah_cpu > 0) CHECKF(ratio < 3.0, "%s: SAH %.3f over the CPU build's", what, ratio);
    if (ratio > g_worst_ratio) g_worst_ratio = ratio;
    rd_bvh_destroy(&cpu);
    rd_bvh_destroy(&gpu);
}

/* Both leaf policies: one triangle a leaf, and subtrees of up to 4 collapsed. */
static void check_mesh(rd_vk *vk, const rd_gpu_lbvh_builder *b, const char *what, const float *pos,
                       uint32_t n, uint32_t rays)
{
    check_build(vk, b, what, pos, n, rays, 1);
    check_build(vk, b, what, pos, n, rays, 4);
}

static void run_tests(rd_vk *vk, const rd_gpu_lbvh_builder *b)
{
    static const uint32_t sizes[] = {0, 1, 2, 3, 7, 100, 5000};
    float *pos = tris_alloc(5000);
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        char what[64];
        snprintf(what, sizeof what, "random soup %u", sizes[s]);
        rng_seed(17 + s);
        random_soup(pos, sizes[s], sizes[s] > 100 ? 0.05f : 0.3f);
        check_mesh(vk, b, what, pos, sizes[s], sizes[s] ? 1000 : 0);
    }

    /* all centroids at one point: the keys differ only in their triangle index */
    rng_seed(5);
    for (uint32_t i = 0; i < 600; i++) {
        float a[3], d[3], *v = pos + 9 * (size_t)i;
        rng_unit(a), rng_unit(d);
        for (int k = 0; k < 3; k++) {
            v[k] = 0.25f + a[k];
            v[3 + k] = 0.25f + d[k];
            v[6 + k] = 0.25f - a[k] - d[k];
        }
    }
    check_mesh(vk, b, "equal centroids", pos, 600, 500);

    /* a flat 40 x 40 grid of quads in z = 0 (the centroid box has no depth) */
    uint32_t g = 40, n = 0;
    for (uint32_t y = 0; y < g; y++)
        for (uint32_t x = 0; x < g; x++) {
            float x0 = (float)x / g, x1 = (float)(x + 1) / g;
            float y0 = (float)y / g, y1 = (float)(y + 1) / g;
            float q[18] = {x0, y0, 0, x1, y0, 0, x1, y1, 0, x0, y0, 0, x1, y1, 0, x0, y1, 0};
            memcpy(pos + 9 * (size_t)n, q, sizeof q);
            n += 2;
        }
    check_mesh(vk, b, "flat plane", pos, n, 1000);

    /* one identical triangle many times over */
    for (uint32_t i = 1; i < 64; i++)
        memcpy(pos + 9 * (size_t)i, pos, 9 * sizeof(float));
    check_mesh(vk, b, "64 copies of one triangle", pos, 64, 100);

    /* a few non-finite triangles among finite ones */
    rng_seed(11);
    random_soup(pos, 300, 0.2f);
    for (uint32_t i = 0; i < 300; i += 37)
        pos[9 * i + (i % 9)] = (i % 2) ? NAN : INFINITY;
    check_mesh(vk, b, "non-finite among 300", pos, 300, 500);

    /* finite and non-finite triangles in a subtree small enough to collapse */
    rng_seed(12);
    random_soup(pos, 7, 0.2f);
    pos[9 * 1 + 4] = NAN;
    pos[9 * 5] = -INFINITY;
    check_mesh(vk, b, "2 non-finite among 7", pos, 7, 200);
    check_mesh(vk, b, "1 non-finite among 3", pos + 9 * 3, 3, 100);

    /* too many triangles: an error before anything is read or allocated */
    rd_bvh none;
    CHECK(rd_gpu_lbvh_build_download(vk, b, NULL, RD_GPU_LBVH_MAX_TRIANGLES + 1, 0, NULL, &none,
                                     NULL, err, sizeof err) == RD_VK_ERR_UNSUPPORTED);
    CHECK(none.nodes == NULL && none.node_count == 0);
    free(pos);
}

static void run_bench(rd_vk *vk, const rd_gpu_lbvh_builder *b, int argc, char **argv)
{
    uint32_t sizes[16] = {1000, 5000, 20000, 100000}, count = 4, most = 0;
    if (argc > 0) /* sizes given: `test_gpu_lbvh bench 100000 1000000` */
        for (count = 0; count < (uint32_t)argc && count < 16; count++)
            sizes[count] = (uint32_t)strtoul(argv[count], NULL, 10);
    for (uint32_t s = 0; s < count; s++)
        most = sizes[s] > most ? sizes[s] : most;
    float *pos = tris_alloc(most);
    rd_timer timer;
    if (rd_timer_create(vk, &timer, err, sizeof err) != RD_VK_OK) {
        fprintf(stderr, "%s\n", err);
        free(pos);
        return;
    }
    /* PROBECAST_LBVH_LEAF: the leaf policy (max_leaf; default 0: up to 4) */
    const char *leaf_env = getenv("PROBECAST_LBVH_LEAF");
    uint32_t max_leaf = leaf_env ? (uint32_t)strtoul(leaf_env, NULL, 10) : 0;
    printf("leaves of up to %u; ms: submit and wait (best of 3), then GPU timestamps of the last\n",
           max_leaf ? max_leaf : 4);
    printf("%8s %8s %8s %8s %8s %8s %8s %9s %6s\n", "tris", "wall_ms", "keys", "sort", "hierarchy",
           "boxes", "collapse", "sah_ratio", "depth");
    for (uint32_t s = 0; s < count; s++) {
        rng_seed(3 + s);
        random_soup(pos, sizes[s], 0.02f);
        rd_bvh gpu, cpu;
        double ms = 0, best = 1e30;
        for (int rep = 0; rep < 3; rep++) {
            rd_vk_result r = rd_gpu_lbvh_build_download(vk, b, pos, sizes[s], max_leaf, &timer,
                                                        &gpu, &ms, err, sizeof err);
            if (r != RD_VK_OK) {
                fprintf(stderr, "%s\n", err);
                rd_timer_destroy(vk, &timer);
                free(pos);
                return;
            }
            best = ms < best ? ms : best;
            if (rep < 2) rd_bvh_destroy(&gpu);
        }
        if (!rd_bvh_build_triangles(&cpu, pos, sizes[s], NULL)) abort();
        printf("%8u %8.2f", sizes[s], best);
        for (uint32_t k = 1; k <= 5; k++)
            printf(" %8.2f", timer.valid && k < timer.count ? timer.ms[k] : -1.0);
        printf(" %9.3f %6u\n", rd_bvh_sah_cost(&gpu) / rd_bvh_sah_cost(&cpu), gpu.depth);
        rd_bvh_destroy(&gpu);
        rd_bvh_destroy(&cpu);
    }
    rd_timer_destroy(vk, &timer);
    free(pos);
}

int main(int argc, char **argv)
{
    bool bench = argc > 1 && strcmp(argv[1], "bench") == 0;
    rd_vk vk;
    rd_vk_result rc = rd_vk_create(&vk, NULL, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    if (rc != RD_VK_OK) return test_finish();
    rd_gpu_lbvh_builder b;
    rc = rd_gpu_lbvh_builder_create(&vk, &b, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    if (rc == RD_VK_OK)
        rc = rd_pipeline_create(&vk, &g_trace, "test_trace", pc_spv_test_trace,
                                sizeof pc_spv_test_trace, sizeof(pc_push), err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    if (rc == RD_VK_OK) {
        if (bench)
            run_bench(&vk, &b, argc - 2, argv + 2);
        else
            run_tests(&vk, &b);
    }
    if (!bench) {
        fprintf(stderr, "worst SAH ratio GPU LBVH / CPU binned SAH: %.3f\n", g_worst_ratio);
        fprintf(stderr,
                "GPU traversal (trace.glsl) over the LBVH: %u of %u rays differ from the CPU\n",
                g_gpu_differ, g_gpu_rays);
    }
    rd_pipeline_destroy(&vk, &g_trace);
    rd_gpu_lbvh_builder_destroy(&vk, &b);
    rd_gpu_lbvh_builder_destroy(&vk, &b); /* idempotent */
    CHECK(rd_vk_validation_messages(&vk) == 0);
    rd_vk_destroy(&vk);
    return test_finish();
}
