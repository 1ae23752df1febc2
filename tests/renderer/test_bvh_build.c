/* test_bvh_build.c: the multi-threaded builder on inputs large enough to take its parallel
 * path (more than RD_BVH_PAR_MIN_PRIMS primitives): the same nodes and prim_index at 1, 2, 3
 * and 8 threads, every structural promise of bvh.h, closest hits equal to brute force, and
 * an SAH cost within 2% of the single-threaded reference builder measured here. */
#include "bvh_check.h"
#include "renderer/accel/bvh.h"
#include "bvh_build_ref.h"
#include "renderer/builtin/procedural.h"
#include "test_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const uint32_t THREADS[] = {1, 2, 3, 8};
#define THREAD_COUNTS 4

static bool same_bvh(const rd_bvh *a, const rd_bvh *b)
{
    return a->node_count == b->node_count && a->prim_count == b->prim_count &&
           a->depth == b->depth &&
           !memcmp(a->nodes, b->nodes, (size_t)a->node_count * sizeof *a->nodes) &&
           !memcmp(a->prim_index, b->prim_index, (size_t)a->prim_count * sizeof *a->prim_index);
}

/* Builds at every thread count: structure checked once, the others compared bit for bit.
 * Returns the 1-thread BVH in out (caller destroys) or false when a build failed. */
static bool build_all_threads(const char *what, const float *pos, uint32_t n, rd_bvh *out)
{
    rd_bvh_options opt = {.threads = 1};
    if (!rd_bvh_build_triangles(out, pos, n, &opt)) {
        CHECKF(false, "%s: build failed", what);
        return false;
    }
    int bad = check_triangles(what, out, pos, n, 4);
    CHECKF(bad == 0, "%s: %d structural problems", what, bad);
    for (int i = 1; i < THREAD_COUNTS; i++) {
        rd_bvh b;
        opt.threads = THREADS[i];
        bool ok = rd_bvh_build_triangles(&b, pos, n, &opt);
        CHECKF(ok, "%s: build at %u threads failed", what, THREADS[i]);
        if (!ok) continue;
        CHECKF(same_bvh(out, &b), "%s: %u threads give other nodes than 1", what, THREADS[i]);
        rd_bvh_destroy(&b);
    }
    return true;
}

/* Closest hits of random rays against brute force. */
static void rays_vs_brute(const char *what, const rd_bvh *bvh, const float *pos, uint32_t n,
                          uint32_t rays, uint32_t min_hits)
{
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t i = 0; i < n; i++) {
        const float *v = pos + 9 * (size_t)i;
        if (!tri_finite(v)) continue;
        for (int k = 0; k < 9; k++) {
            lo[k % 3] = fminf(lo[k % 3], v[k]);
            hi[k % 3] = fmaxf(hi[k % 3], v[k]);
        }
    }
    float *orgs = malloc((size_t)rays * 6 * sizeof(float));
    if (!orgs) abort();
    make_rays(orgs, orgs + 3 * (size_t)rays, rays, lo, hi, 0.5f, pos, n);
    uint32_t hits =
        compare_rays(what, bvh, pos, n, orgs, orgs + 3 * (size_t)rays, rays, 0, INFINITY);
    CHECKF(hits >= min_hits, "%s: only %u hits of %u rays", what, hits, rays);
    free(orgs);
}

/* SAH cost of the new builder against the reference builder on the same triangles. */
static void sah_vs_reference(const char *what, const rd_bvh *bvh, const float *pos, uint32_t n)
{
    float *lo = malloc((size_t)n * 6 * sizeof(float));
    if (!lo) abort();
    rd_bvh_triangle_boxes(pos, n, lo, lo + 3 * (size_t)n);
    rd_bvh ref;
    bool ok = rd_bvh_build_reference(&ref, lo, lo + 3 * (size_t)n, n, NULL);
    CHECKF(ok, "%s: reference build failed", what);
    if (ok) {
        double c_new = rd_bvh_sah_cost(bvh), c_ref = rd_bvh_sah_cost(&ref);
        printf("%s: SAH cost %.4f (reference %.4f), nodes %u (%u)\n", what, c_new, c_ref,
               bvh->node_count, ref.node_count);
        CHECKF(c_ref > 1.0 && c_new <= 1.02 * c_ref, "%s: SAH %.4f vs reference %.4f", what, c_new,
               c_ref);
        rd_bvh_destroy(&ref);
    }
    free(lo);
}

static void random_soup(float *pos, uint32_t n, uint64_t seed)
{
    rng_seed(seed);
    for (uint32_t i = 0; i < n; i++) {
        float c[3] = {rng_f(), rng_f(), rng_f()};
        random_tri(pos + 9 * i, c, i % 97 == 0 ? 0.2f : 0.004f);
    }
}

/* ---- tests -------------------------------------------------------------------------------- */

/* Three horizontal levels (RD_BVH_PAR_MIN_PRIMS * 4.5 triangles), non-finite triangles
 * mixed in: determinism, structure, brute force, SAH; then the box entry point. */
static void test_soup(void)
{
    const uint32_t n = RD_BVH_PAR_MIN_PRIMS * 9 / 2;
    float *pos = tris_alloc(n);
    random_soup(pos, n, 21);
    for (uint32_t i = 0; i < n; i += 211)
        pos[9 * i + (i % 9)] = (i % 2) ? NAN : -INFINITY;
    rd_bvh bvh;
    if (build_all_threads("soup", pos, n, &bvh)) {
        CHECK(bvh.depth > 10 && bvh.depth <= RD_BVH_MAX_DEPTH);
        rays_vs_brute("soup", &bvh, pos, n, 120, 40);
        sah_vs_reference("soup", &bvh, pos, n);
        /* The same boxes through rd_bvh_build give the same tree. */
        float *lo = malloc((size_t)n * 6 * sizeof(float));
        if (!lo) abort();
        rd_bvh_triangle_boxes(pos, n, lo, lo + 3 * (size_t)n);
        rd_bvh boxes;
        CHECK(rd_bvh_build(&boxes, lo, lo + 3 * (size_t)n, n, &(rd_bvh_options){.threads = 3}));
        CHECK(same_bvh(&bvh, &boxes));
        rd_bvh_destroy(&boxes);
        free(lo);
        rd_bvh_destroy(&bvh);
    }
    free(pos);
}

/* The benchmark scene's geometry (tessellated spheres) and elongated slivers: SAH. */
static void test_sah_meshes(void)
{
    rd_scene s;
    char err[128];
    CHECK(rd_procedural_build("spheres:150000", &s, err, sizeof err));
    const rd_mesh *big = &s.meshes[0];
    for (uint32_t m = 1; m < s.mesh_count; m++)
        if (s.meshes[m].tri_count > big->tri_count) big = &s.meshes[m];
    CHECK(big->tri_count > RD_BVH_PAR_MIN_PRIMS);
    rd_bvh bvh;
    if (build_all_threads("spheres", big->positions, big->tri_count, &bvh)) {
        rays_vs_brute("spheres", &bvh, big->positions, big->tri_count, 60, 20);
        sah_vs_reference("spheres", &bvh, big->positions, big->tri_count);
        rd_bvh_destroy(&bvh);
    }
    rd_scene_destroy(&s);

    const uint32_t n = RD_BVH_PAR_MIN_PRIMS * 2;
    float *pos = tris_alloc(n);
    rng_seed(22);
    for (uint32_t i = 0; i < n; i++) {
        float *v = pos + 9 * i;
        float c[3] = {rng_f() * 10, rng_f(), rng_f()};
        random_tri(v, c, 0.01f);
        v[3 + i % 3] += rng_range(-1, 1);
    }
    if (build_all_threads("slivers", pos, n, &bvh)) {
        sah_vs_reference("slivers", &bvh, pos, n);
        rd_bvh_destroy(&bvh);
    }
    free(pos);
}

static void test_degenerate(void)
{
    const uint32_t n = RD_BVH_PAR_MIN_PRIMS + RD_BVH_CHUNK_PRIMS + 17;
    float *pos = tris_alloc(n);
    rd_bvh bvh;
    const float shared[9] = {0.1f, 0.2f, 0.3f, 0.9f, 0.25f, 0.35f, 0.4f, 0.8f, 0.6f};

    /* every centroid equal */
    for (uint32_t i = 0; i < n; i++)
        memcpy(pos + 9 * i, shared, sizeof shared);
    if (build_all_threads("all identical", pos, n, &bvh)) {
        rays_vs_brute("all identical", &bvh, pos, n, 40, 10);
        rd_bvh_destroy(&bvh);
    }

    /* huge counts of identical triangles among others */
    random_soup(pos, n, 23);
    for (uint32_t i = 0; i < n; i++)
        if (i % 10) memcpy(pos + 9 * i, shared, sizeof shared);
    if (build_all_threads("mostly identical", pos, n, &bvh)) {
        rays_vs_brute("mostly identical", &bvh, pos, n, 60, 20);
        rd_bvh_destroy(&bvh);
    }

    /* coplanar, z = 0.5 */
    random_soup(pos, n, 24);
    for (uint32_t i = 0; i < n; i++)
        pos[9 * i + 2] = pos[9 * i + 5] = pos[9 * i + 8] = 0.5f;
    if (build_all_threads("coplanar", pos, n, &bvh)) {
        rays_vs_brute("coplanar", &bvh, pos, n, 60, 20);
        rd_bvh_destroy(&bvh);
    }

    /* a third non-finite; then every one */
    random_soup(pos, n, 25);
    for (uint32_t i = 0; i < n; i += 3)
        pos[9 * i + 4] = (i % 2) ? INFINITY : NAN;
    if (build_all_threads("third non-finite", pos, n, &bvh)) {
        rays_vs_brute("third non-finite", &bvh, pos, n, 60, 10);
        rd_bvh_destroy(&bvh);
    }
    for (uint32_t i = 0; i < n; i++)
        pos[9 * i] = NAN;
    if (build_all_threads("all non-finite", pos, n, &bvh)) {
        const float o[3] = {0.5f, 0.5f, -1}, d[3] = {0, 0, 1};
        float t;
        CHECK(rd_bvh_closest_triangle(&bvh, pos, o, d, 0, INFINITY, &t) == -1);
        rd_bvh_destroy(&bvh);
    }

    /* 0, 1 and 2 triangles with threads: the documented small cases */
    random_soup(pos, 2, 26);
    for (uint32_t k = 0; k <= 2; k++) {
        char what[32];
        snprintf(what, sizeof what, "%u triangles", k);
        if (build_all_threads(what, pos, k, &bvh)) {
            CHECK(bvh.prim_count == k);
            rd_bvh_destroy(&bvh);
        }
    }
    free(pos);
}

/* rd_bvh_build_many: each mesh's BVH equals its own single build, at any thread count. */
static void test_many(void)
{
    const uint32_t sizes[] = {RD_BVH_PAR_MIN_PRIMS + 5, 0, 1, 2, 300, RD_BVH_CHUNK_PRIMS * 3};
    enum { M = 6 };
    uint32_t total = 0;
    for (int m = 0; m < M; m++)
        total += sizes[m];
    float *pos = tris_alloc(total);
    random_soup(pos, total, 27);
    rd_bvh_mesh meshes[M];
    rd_bvh single[M];
    uint32_t at = 0;
    for (int m = 0; m < M; m++) {
        meshes[m] = (rd_bvh_mesh){pos + 9 * (size_t)at, sizes[m]};
        CHECK(rd_bvh_build_triangles(&single[m], meshes[m].positions, sizes[m],
                                     &(rd_bvh_options){.threads = 1}));
        at += sizes[m];
    }
    for (int i = 0; i < THREAD_COUNTS; i++) {
        rd_bvh many[M];
        bool ok = rd_bvh_build_many(many, meshes, M, &(rd_bvh_options){.threads = THREADS[i]});
        CHECKF(ok, "build_many at %u threads failed", THREADS[i]);
        if (!ok) continue;
        for (int m = 0; m < M; m++) {
            CHECKF(same_bvh(&single[m], &many[m]), "build_many at %u threads: mesh %d differs",
                   THREADS[i], m);
            rd_bvh_destroy(&many[m]);
        }
    }
    for (int m = 0; m < M; m++)
        rd_bvh_destroy(&single[m]);
    CHECK(rd_bvh_build_many(NULL, NULL, 0, NULL));
    free(pos);
}

int main(void)
{
    test_soup();
    test_sah_meshes();
    test_degenerate();
    test_many();
    return test_finish();
}
