/* test_gpu_blas_build.c: static meshes' BLASes built by the GPU LBVH at upload
 * (PROBECAST_BLAS_BUILD, gpu_scene_lbvh.c), on lavapipe. The variable's parse and the policy;
 * a scene of random soups (one far from its origin, so that it has a local origin; one with a
 * non-finite vertex) and an empty mesh uploaded with PROBECAST_BLAS_BUILD=gpu (and =ploc, the
 * builder's PLOC method) and =cpu: every
 * non-empty mesh built by the GPU in the first, none in the second, the same local frames, and
 * each mesh's BLAS as the scene holds it (nodes and records read back) gives the same closest hit
 * (triangle and t) ray by ray as the CPU-built scene's, and the deepest walks as many levels as
 * the depth the builds wrote (the LBVH's, no read-back); the same through the CPU fallback (every
 * GPU tree taken as too deep by a test hook); and an image of a builtin scene rendered
 * end to end (test_render) matches the CPU-built one's within float tolerance. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/accel/gpu_scene.h"
#include "renderer/accel/gpu_scene_internal.h"
#include "test_render_util.h"
#include "test_util.h"

static char err[512];
static uint32_t rng = 12345u;

static float rnd(void)
{
    rng = rng * 1664525u + 1013904223u;
    return (float)(rng >> 8) / 16777216.0f;
}

static void test_parse(void)
{
    CHECK(rd_blas_build_parse(NULL) == RD_BLAS_BUILD_AUTO);
    CHECK(rd_blas_build_parse("") == RD_BLAS_BUILD_AUTO);
    CHECK(rd_blas_build_parse("auto") == RD_BLAS_BUILD_AUTO);
    CHECK(rd_blas_build_parse("cpu") == RD_BLAS_BUILD_CPU);
    CHECK(rd_blas_build_parse("gpu") == RD_BLAS_BUILD_GPU);
    CHECK(rd_blas_build_parse("ploc") == RD_BLAS_BUILD_GPU_PLOC);
    CHECK(rd_blas_build_on_gpu(RD_BLAS_BUILD_GPU_PLOC, false, 1));
    CHECK(rd_blas_build_parse("GPU!") == RD_BLAS_BUILD_AUTO); /* a warning, then auto */
    const uint32_t big = 8000000;
    CHECK(!rd_blas_build_on_gpu(RD_BLAS_BUILD_AUTO, false, big)); /* lavapipe keeps the CPU */
    CHECK(!rd_blas_build_on_gpu(RD_BLAS_BUILD_AUTO, true, big));  /* auto: the CPU for now */
    CHECK(!rd_blas_build_on_gpu(RD_BLAS_BUILD_CPU, true, big));
    CHECK(rd_blas_build_on_gpu(RD_BLAS_BUILD_GPU, false, 1));
    CHECK(!rd_blas_build_on_gpu(RD_BLAS_BUILD_GPU, true, 0));
    CHECK(!rd_blas_build_on_gpu(RD_BLAS_BUILD_GPU, true, RD_GPU_LBVH_MAX_TRIANGLES + 1));
}

/* A soup of n small triangles in a cube of side 4 at c, on a node of its own. */
static void add_soup(rd_scene *s, uint32_t n, float c, bool non_finite)
{
    uint32_t m = rd_scene_add_mesh(s, "soup", n);
    rd_mesh *mesh = &s->meshes[m];
    for (uint32_t t = 0; t < n; t++) {
        float o[3] = {c + 4 * rnd(), c + 4 * rnd(), c + 4 * rnd()};
        for (int v = 0; v < 3; v++)
            for (int k = 0; k < 3; k++)
                mesh->positions[9 * t + 3 * v + k] = o[k] + 0.3f * rnd();
        for (int v = 0; v < 3; v++)
            mesh->normals[9 * t + 3 * v + 2] = 1;
    }
    if (non_finite) mesh->positions[9 * 7 + 4] = NAN;
    rd_node node = {.parent = -1, .mesh = (int32_t)m, .rotation = {0, 0, 0, 1}, .scale = {1, 1, 1}};
    rd_scene_add_node(s, &node);
}

/* Mesh m's BLAS as gs holds it (indices back to the mesh's own) and its records' positions (9
 * floats a triangle, original order, from each record's original index). */
static void read_mesh(rd_vk *vk, const rd_gpu_scene *gs, const rd_scene *s, uint32_t m,
                      rd_bvh *tree, float **pos)
{
    uint32_t n = s->meshes[m].tri_count, base = 0, root = gs->mesh_root[m];
    for (uint32_t k = 0; k < m; k++)
        base += s->meshes[k].tri_count;
    uint32_t end = m + 1 < gs->mesh_count ? gs->mesh_root[m + 1] : (uint32_t)gs->blas_node_count;
    *tree = (rd_bvh){.node_count = end - root, .prim_count = n};
    tree->nodes = calloc(tree->node_count, sizeof *tree->nodes);
    tree->prim_index = calloc(n, sizeof *tree->prim_index);
    pc_tri *t = calloc(n, sizeof *t);
    *pos = calloc((size_t)n * 9, sizeof **pos);
    if (!tree->nodes || !tree->prim_index || !t || !*pos) abort();
    CHECK(rd_buffer_download(vk, &gs->blas_nodes, sizeof *tree->nodes * root, tree->nodes,
                             sizeof *tree->nodes * tree->node_count, err, sizeof err) == RD_VK_OK);
    CHECK(rd_buffer_download(vk, &gs->tris, sizeof *t * base, t, sizeof *t * n, err, sizeof err) ==
          RD_VK_OK);
    for (uint32_t i = 0; i < n; i++) {
        uint32_t src = pc_f2u(t[i].v2.w);
        CHECKF(src < n, "mesh %u record %u names triangle %u", m, i, src);
        tree->prim_index[i] = src < n ? src : 0;
        const pc_vec4 *v[3] = {&t[i].v0, &t[i].v1, &t[i].v2};
        for (int c = 0; src < n && c < 3; c++)
            memcpy(&(*pos)[9 * (size_t)src + 3 * c], &v[c]->x, 3 * sizeof(float));
    }
    for (uint32_t i = 0; i < tree->node_count; i++) {
        pc_bvh_node *nd = &tree->nodes[i];
        uint32_t first = pc_f2u(nd->bmin.w), count = pc_f2u(nd->bmax.w);
        nd->bmin.w = pc_u2f(count ? first - base : first - root);
    }
    free(t);
}

/* Levels below the root of tree, walked. */
static uint32_t walked_depth(const rd_bvh *tree)
{
    uint32_t *stack = calloc(2 * (size_t)tree->node_count + 2, sizeof *stack), top = 0, depth = 0;
    if (!stack) abort();
    stack[top++] = 0, stack[top++] = 0;
    while (top) {
        uint32_t level = stack[--top], i = stack[--top];
        depth = level > depth ? level : depth;
        uint32_t first = pc_f2u(tree->nodes[i].bmin.w), count = pc_f2u(tree->nodes[i].bmax.w);
        if (count || first + 1 >= tree->node_count) continue;
        stack[top++] = first, stack[top++] = level + 1;
        stack[top++] = first + 1, stack[top++] = level + 1;
    }
    free(stack);
    return depth;
}

/* Rays from a sphere around mesh m's box through points inside it: the same closest hit through
 * both scenes' BLASes of m. Returns the depth of the first's BLAS of m, walked. */
static uint32_t compare_mesh(rd_vk *vk, const rd_gpu_scene *gpu, const rd_gpu_scene *cpu,
                             const rd_scene *s, uint32_t m)
{
    rd_bvh a, b;
    float *pa, *pb;
    read_mesh(vk, gpu, s, m, &a, &pa);
    read_mesh(vk, cpu, s, m, &b, &pb);
    uint32_t n = s->meshes[m].tri_count;
    CHECKF(memcmp(pa, pb, sizeof(float) * 9 * n) == 0 || n == 0,
           "mesh %u: the records' positions differ", m);
    const float *lo = &gpu->mesh_local_bounds[6 * m], *hi = lo + 3;
    uint32_t bad = 0, hits = 0, rays = 500;
    for (uint32_t i = 0; i < rays; i++) {
        float org[3], dir[3], rad = 0;
        for (int k = 0; k < 3; k++)
            rad += (hi[k] - lo[k]) * (hi[k] - lo[k]);
        float z = 2 * rnd() - 1, ph = 6.2831853f * rnd(), sn = sqrtf(fmaxf(0, 1 - z * z));
        const float sd[3] = {sn * cosf(ph), sn * sinf(ph), z};
        for (int k = 0; k < 3; k++) {
            org[k] = 0.5f * (lo[k] + hi[k]) + 2 * sqrtf(rad) * sd[k];
            dir[k] = lo[k] + rnd() * (hi[k] - lo[k]) - org[k];
        }
        float ta = 0, tb = 0;
        int64_t ha = rd_bvh_closest_triangle(&a, pa, org, dir, 0, 1e30f, &ta);
        int64_t hb = rd_bvh_closest_triangle(&b, pb, org, dir, 0, 1e30f, &tb);
        hits += hb >= 0;
        bad += ha != hb || (ha >= 0 && ta != tb);
    }
    printf("mesh %u (%u triangles): %u of %u rays hit, %u differ\n", m, n, hits, rays, bad);
    CHECKF(bad == 0, "mesh %u: %u of %u rays differ between the GPU and CPU builds", m, bad, rays);
    CHECKF(hits > 0 || n == 0, "mesh %u: no ray hit", m);
    uint32_t depth = walked_depth(&a);
    rd_bvh_destroy(&a);
    rd_bvh_destroy(&b);
    free(pa);
    free(pb);
    return depth;
}

/* fallback: every GPU tree counts as too deep (the test hook), so the CPU builds each mesh
 * after the GPU placed its records in the LBVH's leaf order, and reorders them. */
static void test_scene(rd_vk *vk, bool fallback, const char *policy)
{
    rd_scene s;
    rd_scene_init(&s);
    add_soup(&s, 3000, -2, false);
    add_soup(&s, 2000, 1000, false); /* far from its origin: a local origin of its own */
    add_soup(&s, 500, 5, true);
    uint32_t empty = rd_scene_add_mesh(&s, "empty", 0);
    rd_node node = {
        .parent = -1, .mesh = (int32_t)empty, .rotation = {0, 0, 0, 1}, .scale = {1, 1, 1}};
    rd_scene_add_node(&s, &node);
    CHECKF(rd_scene_update(&s, err, sizeof err), "%s", err);
    rd_gpu_scene gpu = {0}, cpu = {0};
    setenv("PROBECAST_BLAS_BUILD", policy, 1);
    rd_gpu_scene_lbvh_depth_limit = fallback ? 0 : RD_BVH_MAX_DEPTH;
    VK_CHECK(rd_gpu_scene_create(vk, &gpu, &s, err, sizeof err));
    rd_gpu_scene_lbvh_depth_limit = RD_BVH_MAX_DEPTH;
    setenv("PROBECAST_BLAS_BUILD", "cpu", 1);
    VK_CHECK(rd_gpu_scene_create(vk, &cpu, &s, err, sizeof err));
    unsetenv("PROBECAST_BLAS_BUILD");
    CHECKF(gpu.blas_gpu_meshes == (fallback ? 0u : 3u) && cpu.blas_gpu_meshes == 0,
           "GPU builds: %u and %u", gpu.blas_gpu_meshes, cpu.blas_gpu_meshes);
    CHECK(memcmp(gpu.mesh_origin, cpu.mesh_origin, sizeof(float) * 3 * s.mesh_count) == 0);
    CHECK(gpu.mesh_origin[3] != 0); /* the far soup's */
    CHECKF(gpu.max_blas_depth > 0 && gpu.max_blas_depth <= RD_BVH_MAX_DEPTH, "depth %u",
           gpu.max_blas_depth);
    uint32_t deepest = 0; /* the LBVH writes its depth; the scene keeps the deepest */
    for (uint32_t m = 0; m < s.mesh_count; m++) {
        uint32_t d = compare_mesh(vk, &gpu, &cpu, &s, m);
        deepest = d > deepest ? d : deepest;
    }
    CHECKF(deepest == gpu.max_blas_depth, "the deepest BLAS walks %u levels, the scene says %u",
           deepest, gpu.max_blas_depth);
done:
    unsetenv("PROBECAST_BLAS_BUILD");
    rd_gpu_scene_destroy(vk, &gpu);
    rd_gpu_scene_destroy(vk, &cpu);
    rd_scene_destroy(&s);
}

/* A builtin scene rendered end to end with both builds: the same image within float tolerance
 * (the same hits; only the traversal order differs). Spheres, not cornell: the box's walls meet
 * in edges shared by triangles of different materials, where a hit at equal t may go to either
 * (5 of cornell's 1728 pixels did). */
static void test_image(rd_vk *vk, const char *policy)
{
    test_render_desc d = {.scene = "spheres:4000", .width = 48, .height = 36};
    setenv("PROBECAST_BLAS_BUILD", policy, 1);
    float *a = test_render(vk, &d, NULL, NULL);
    setenv("PROBECAST_BLAS_BUILD", "cpu", 1);
    float *b = test_render(vk, &d, NULL, NULL);
    unsetenv("PROBECAST_BLAS_BUILD");
    CHECK(a && b);
    size_t floats = (size_t)d.width * d.height * 3, bad = 0, nf = 0;
    double worst = 0;
    for (size_t i = 0; a && b && i < floats; i++) {
        double e = fabs((double)a[i] - b[i]) / (1e-3 + fabs((double)b[i]));
        worst = e > worst ? e : worst;
        bad += e > 1e-3;
    }
    double mean = a ? test_image_mean(a, floats, &nf) : 0;
    printf("image (%s): mean %.4f, worst relative difference %.2e, %zu values past 1e-3\n", policy,
           mean, worst, bad);
    CHECKF(bad == 0 && nf == 0 && mean > 0, "image (%s): %zu values differ, %zu non-finite",
           policy, bad, nf);
    free(a);
    free(b);
}

int main(void)
{
    test_parse();
    rd_vk vk;
    if (!test_vk_open(&vk)) return test_finish();
    test_scene(&vk, false, "gpu");
    test_scene(&vk, true, "gpu");
    test_scene(&vk, false, "ploc"); /* the builder's PLOC method (gpu_ploc.h) */
    test_image(&vk, "gpu");
    test_image(&vk, "ploc");
    return test_vk_close(&vk);
}
