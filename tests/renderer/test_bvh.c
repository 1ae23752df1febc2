/* test_bvh.c: the CPU BVH against brute force, its structure, watertightness and the
 * self-intersection offset. Everything is seeded, so a failure reproduces. */
#include "bvh_check.h"
#include "renderer/accel/bvh.h"
#include "test_util.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- tests -------------------------------------------------------------------------------- */

static void test_ray_triangle(void)
{
    const float v0[3] = {0, 0, 0}, v1[3] = {1, 0, 0}, v2[3] = {0, 1, 0}; /* CCW seen from +z */
    float t, u, v;
    bool back;
    const float o[3] = {0.25f, 0.5f, 2.0f}, down[3] = {0, 0, -1};
    CHECK(rd_ray_triangle(o, down, v0, v1, v2, 0, INFINITY, &t, &u, &v, &back));
    CHECK(t == 2.0f && u == 0.25f && v == 0.5f && !back);
    const float ob[3] = {0.25f, 0.5f, -2.0f}, up[3] = {0, 0, 1};
    CHECK(rd_ray_triangle(ob, up, v0, v1, v2, 0, INFINITY, &t, &u, &v, &back));
    CHECK(t == 2.0f && back);
    /* tmin < t < tmax, strictly */
    CHECK(!rd_ray_triangle(o, down, v0, v1, v2, 0, 2.0f, &t, &u, &v, &back));
    CHECK(!rd_ray_triangle(o, down, v0, v1, v2, 2.0f, 3.0f, &t, &u, &v, &back));
    CHECK(rd_ray_triangle(o, down, v0, v1, v2, 1.999f, 2.001f, &t, &u, &v, &back));
    /* behind the origin */
    const float below[3] = {0.25f, 0.5f, -1.0f};
    CHECK(!rd_ray_triangle(below, down, v0, v1, v2, 0, INFINITY, &t, &u, &v, &back));
    /* through a vertex and an edge exactly: inclusive */
    const float ov[3] = {1, 0, 3};
    CHECK(rd_ray_triangle(ov, down, v0, v1, v2, 0, INFINITY, &t, &u, &v, &back));
    CHECK(u == 1.0f && v == 0.0f);
    const float oe[3] = {0.5f, 0.5f, 3};
    CHECK(rd_ray_triangle(oe, down, v0, v1, v2, 0, INFINITY, &t, &u, &v, &back));
    /* outside, parallel, zero direction, degenerate triangle */
    const float out[3] = {0.75f, 0.5f, 2.0f};
    CHECK(!rd_ray_triangle(out, down, v0, v1, v2, 0, INFINITY, &t, &u, &v, &back));
    const float side[3] = {1, 0, 0}, zero[3] = {0, 0, 0};
    const float oz[3] = {-1, 0.25f, 0};
    CHECK(!rd_ray_triangle(oz, side, v0, v1, v2, 0, INFINITY, &t, &u, &v, &back));
    CHECK(!rd_ray_triangle(o, zero, v0, v1, v2, 0, INFINITY, &t, &u, &v, &back));
    CHECK(!rd_ray_triangle(o, down, v0, v1, v1, 0, INFINITY, &t, &u, &v, &back));
    /* backface follows dot(dir, cross(v1 - v0, v2 - v0)) > 0 for any dominant axis */
    rng_seed(11);
    int wrong = 0, hits = 0;
    for (int i = 0; i < 2000; i++) {
        float tri[9], c[3] = {0, 0, 0}, d[3], org[3];
        random_tri(tri, c, 1.0f);
        rng_unit(d);
        float w0 = rng_f(), w1 = rng_f() * (1 - w0), w2 = 1 - w0 - w1;
        for (int a = 0; a < 3; a++)
            org[a] = w0 * tri[a] + w1 * tri[3 + a] + w2 * tri[6 + a] - 5 * d[a];
        if (!rd_ray_triangle(org, d, tri, tri + 3, tri + 6, 0, INFINITY, &t, &u, &v, &back))
            continue;
        hits++;
        float e1[3], e2[3];
        for (int a = 0; a < 3; a++) {
            e1[a] = tri[3 + a] - tri[a];
            e2[a] = tri[6 + a] - tri[a];
        }
        float nrm[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                        e1[0] * e2[1] - e1[1] * e2[0]};
        float dn = d[0] * nrm[0] + d[1] * nrm[1] + d[2] * nrm[2];
        if (fabsf(dn) > 1e-3f && (dn > 0) != back) wrong++;
        /* grazing hits amplify the rounding of org: check the record only when not grazing */
        if (fabsf(dn) > 1e-2f &&
            (fabsf(t - 5.0f) > 1e-3f || fabsf(u - w1) > 1e-3f || fabsf(v - w2) > 1e-3f))
            wrong++;
    }
    CHECKF(hits > 1900, "%d hits", hits);
    CHECKF(wrong == 0, "%d wrong backface flags or hit records", wrong);
}

static void test_small_counts(void)
{
    rd_bvh bvh;
    CHECK(build_checked("count 0", &bvh, NULL, 0, NULL));
    const float o[3] = {0, 0, 5}, d[3] = {0, 0, -1};
    float t;
    CHECK(rd_bvh_closest_triangle(&bvh, NULL, o, d, 0, INFINITY, &t) == -1);
    rd_bvh_destroy(&bvh);
    rd_bvh_destroy(&bvh); /* idempotent */

    float tri[9] = {-1, -1, 0, 1, -1, 0, 0, 1, 0};
    CHECK(build_checked("count 1", &bvh, tri, 1, NULL));
    CHECK(bvh.node_count == 1 && bvh.depth == 0);
    CHECK(rd_bvh_closest_triangle(&bvh, tri, o, d, 0, INFINITY, &t) == 0 && t == 5.0f);
    const float o2[3] = {3, 0, 5};
    CHECK(rd_bvh_closest_triangle(&bvh, tri, o2, d, 0, INFINITY, &t) == -1);
    rd_bvh_destroy(&bvh);

    /* one triangle that is not finite: root splits into nothing but an empty leaf */
    float bad[9] = {NAN, 0, 0, 1, 0, 0, 0, 1, 0};
    CHECK(build_checked("count 1 NaN", &bvh, bad, 1, NULL));
    CHECK(rd_bvh_closest_triangle(&bvh, bad, o, d, 0, INFINITY, &t) == -1);
    rd_bvh_destroy(&bvh);
}

static void test_random_soups(void)
{
    const uint32_t n = 2000;
    float *pos = tris_alloc(n);
    rng_seed(1);
    for (uint32_t i = 0; i < n; i++) {
        float c[3] = {rng_f(), rng_f(), rng_f()};
        random_tri(pos + 9 * i, c, i % 50 == 0 ? 0.4f : 0.04f);
    }
    soup_case("soup default", pos, n, 2000, NULL, 0, 800);
    soup_case("soup leaf 1", pos, n, 1000, &(rd_bvh_options){.max_leaf = 1}, 0, 400);
    soup_case("soup leaf 8 bins 4", pos, n, 1000, &(rd_bvh_options){.max_leaf = 8, .bins = 4}, 0,
              400);
    soup_case("soup bins 64", pos, n, 1000, &(rd_bvh_options){.bins = 64}, 0.01f, 400);
    soup_case("soup options clamped", pos, n, 500, &(rd_bvh_options){.max_leaf = 100, .bins = 1000},
              0, 200);

    /* elongated: long thin slivers along all axes */
    rng_seed(2);
    for (uint32_t i = 0; i < n; i++) {
        float *v = pos + 9 * i;
        float c[3] = {rng_f() * 10, rng_f(), rng_f()};
        random_tri(v, c, 0.02f);
        v[3 + i % 3] += rng_range(-2, 2);
    }
    soup_case("slivers", pos, n, 1500, NULL, 0, 300);
    free(pos);
}

static void test_degenerate_soups(void)
{
    const uint32_t n = 2400;
    float *pos = tris_alloc(n);

    /* zero-area triangles: a third collinear, a third single points */
    rng_seed(3);
    for (uint32_t i = 0; i < n; i++) {
        float *v = pos + 9 * i;
        float c[3] = {rng_f(), rng_f(), rng_f()};
        random_tri(v, c, 0.05f);
        if (i % 3 == 0) {
            for (int a = 0; a < 3; a++)
                v[6 + a] = v[a] + 0.5f * (v[3 + a] - v[a]);
        } else if (i % 3 == 1) {
            memcpy(v + 3, v, 3 * sizeof(float));
            memcpy(v + 6, v, 3 * sizeof(float));
        }
    }
    soup_case("zero-area", pos, n, 1500, NULL, 0, 100);

    /* many coincident triangles (ties), plus a few others */
    rng_seed(4);
    float shared[9] = {0.1f, 0.2f, 0.3f, 0.9f, 0.25f, 0.35f, 0.4f, 0.8f, 0.6f};
    for (uint32_t i = 0; i < n; i++) {
        if (i % 5 == 4) {
            float c[3] = {rng_f(), rng_f(), rng_f()};
            random_tri(pos + 9 * i, c, 0.05f);
        } else {
            memcpy(pos + 9 * i, shared, sizeof shared);
        }
    }
    soup_case("coincident", pos, n, 1000, NULL, 0, 300);
    soup_case("coincident leaf 1", pos, n, 300, &(rd_bvh_options){.max_leaf = 1}, 0, 100);
    /* all coincident: median splits by index must terminate */
    for (uint32_t i = 0; i < n; i++)
        memcpy(pos + 9 * i, shared, sizeof shared);
    soup_case("all coincident", pos, n, 300, NULL, 0, 100);

    /* all in one plane z = 0.5; rays from both sides, some grazing */
    rng_seed(5);
    for (uint32_t i = 0; i < n; i++) {
        float *v = pos + 9 * i;
        float c[3] = {rng_f(), rng_f(), 0.5f};
        random_tri(v, c, 0.05f);
        v[2] = v[5] = v[8] = 0.5f;
    }
    soup_case("coplanar", pos, n, 1500, NULL, 0, 500);

    /* huge coordinates, rays from far away */
    const float scales[] = {1e7f, 1e15f, 1e20f};
    for (int s = 0; s < 3; s++) {
        rng_seed(6 + s);
        float sc = scales[s];
        for (uint32_t i = 0; i < n; i++) {
            float c[3] = {sc * (1 + rng_f()), sc * (1 + rng_f()), sc * (-1 - rng_f())};
            random_tri(pos + 9 * i, c, sc * 0.04f);
        }
        rd_bvh bvh;
        char what[64];
        snprintf(what, sizeof what, "huge %g", sc);
        if (!build_checked(what, &bvh, pos, n, NULL)) continue;
        const uint32_t rays = 800;
        float *orgs = malloc(rays * 6 * sizeof(float)), *dirs = orgs + 3 * rays;
        for (uint32_t r = 0; r < rays; r++) {
            float dir[3];
            rng_unit(dir);
            const float *target = pos + 9 * (rng_u32() % n) + 3 * (r % 3);
            for (int a = 0; a < 3; a++) {
                /* 10x the scene size away, aimed near a vertex */
                float aim = target[a] + sc * 0.03f * rng_range(-1, 1);
                orgs[3 * r + a] = aim - 10 * sc * dir[a];
                dirs[3 * r + a] = (r % 2) ? dir[a] * sc : dir[a];
            }
            if (r % 2) /* direction not normalised: t scale changes, hits do not */
                for (int a = 0; a < 3; a++)
                    orgs[3 * r + a] = target[a] - 10 * dirs[3 * r + a];
        }
        uint32_t hits = compare_rays(what, &bvh, pos, n, orgs, dirs, rays, 0, INFINITY);
        /* At 1e20 the edge functions' products overflow float: misses are expected there,
         * only agreement with brute force is checked. */
        CHECKF(sc > 1e16f || hits > rays / 4, "%s: %u hits", what, hits);
        free(orgs);
        rd_bvh_destroy(&bvh);
    }
    free(pos);
}

static void test_non_finite(void)
{
    const uint32_t n = 2000;
    float *pos = tris_alloc(n);
    rng_seed(9);
    const float specials[] = {NAN, INFINITY, -INFINITY, -NAN};
    for (uint32_t i = 0; i < n; i++) {
        float c[3] = {rng_f(), rng_f(), rng_f()};
        random_tri(pos + 9 * i, c, 0.05f);
        if (i % 7 == 0) pos[9 * i + rng_u32() % 9] = specials[rng_u32() % 4];
        if (i % 97 == 0) /* a triangle of nothing but infinities */
            for (int k = 0; k < 9; k++)
                pos[9 * i + k] = (k & 1) ? INFINITY : -INFINITY;
    }
    soup_case("non-finite mixed", pos, n, 1500, NULL, 0, 500);
    soup_case("non-finite mixed leaf 1", pos, n, 500, &(rd_bvh_options){.max_leaf = 1}, 0, 100);
    for (uint32_t i = 0; i < n; i++)
        pos[9 * i + i % 9] = NAN;
    soup_case("all non-finite", pos, n, 200, NULL, 0, 0);

    /* raw boxes: inverted finite boxes count as empty, too */
    float lo[6] = {0, 0, 0, 2, 2, 2}, hi[6] = {1, 1, 1, 1, 3, 3};
    rd_bvh bvh;
    CHECK(rd_bvh_build(&bvh, lo, hi, 2, NULL));
    bool valid[2] = {true, false};
    CHECK(check_structure("inverted box", &bvh, lo, hi, valid, 2, 4) == 0);
    CHECK(bvh.nodes[0].bmax.x >= 1.0f && bvh.nodes[0].bmax.x < 1.001f);
    rd_bvh_destroy(&bvh);

    /* a ray with a NaN origin returns nothing */
    float tri[9] = {-1, -1, 0, 1, -1, 0, 0, 1, 0};
    CHECK(rd_bvh_build_triangles(&bvh, tri, 1, NULL));
    const float o[3] = {NAN, 0, 5}, d[3] = {0, 0, -1};
    float t;
    CHECK(rd_bvh_closest_triangle(&bvh, tri, o, d, 0, INFINITY, &t) == -1);
    rd_bvh_destroy(&bvh);
    free(pos);
}

/* Triangles growing geometrically (x_i = 1e-30 * 1.55^i, size ~ x_i) make binned SAH with few
 * bins peel off one triangle per level: ~100 levels without the cap. The cap must hold, leaves
 * must still respect max_leaf, and traversal must agree with brute force. */
static void test_depth_cap(void)
{
    const uint32_t n = 200;
    float *pos = tris_alloc(n);
    double x = 1e-30;
    for (uint32_t i = 0; i < n; i++, x *= 1.55) {
        float f = (float)x, s = f * 0.001f;
        float tri[9] = {f, -f, -f, f + s, f, -f, f, 0, f};
        memcpy(pos + 9 * i, tri, sizeof tri);
    }
    const rd_bvh_options opts[4] = {
        {.bins = 2, .max_leaf = 1}, {.bins = 2, .max_leaf = 4}, {.bins = 4, .max_leaf = 1}, {0}};
    uint32_t deepest = 0;
    rng_seed(10);
    for (int oi = 0; oi < 4; oi++) {
        rd_bvh bvh;
        if (!build_checked("geometric", &bvh, pos, n, &opts[oi])) continue;
        deepest = bvh.depth > deepest ? bvh.depth : deepest;
        const uint32_t rays = 300;
        float *orgs = malloc(rays * 6 * sizeof(float)), *dirs = orgs + 3 * rays;
        for (uint32_t r = 0; r < rays; r++) {
            const float *v = pos + 9 * (rng_u32() % n);
            float *o = orgs + 3 * r, *d = dirs + 3 * r;
            o[0] = v[0] * 0.999f;
            o[1] = v[0] * rng_range(-0.5f, 0.5f);
            o[2] = v[0] * rng_range(-0.5f, 0.3f);
            d[0] = (r % 3) ? 1.0f : -1.0f;
            d[1] = (r % 5) ? 0.0f : 1e-3f;
            d[2] = 0.0f;
        }
        uint32_t hits = compare_rays("geometric", &bvh, pos, n, orgs, dirs, rays, 0, INFINITY);
        CHECKF(hits > rays / 2, "geometric: %u hits", hits);
        free(orgs);
        rd_bvh_destroy(&bvh);
    }
    /* the input really is deep: the cap was reached */
    CHECKF(deepest == RD_BVH_MAX_DEPTH, "deepest BVH %u", deepest);
    free(pos);
}

static int watertight_rays(const char *what, const rd_bvh *bvh, const float *pos, uint32_t n,
                           const float o[3], const float target[3], bool expect_front)
{
    float d[3] = {target[0] - o[0], target[1] - o[1], target[2] - o[2]};
    float t, tf;
    int64_t b = rd_bvh_closest_triangle(bvh, pos, o, d, 0, INFINITY, &t);
    int64_t f = brute_closest(pos, n, o, d, 0, INFINITY, &tf);
    int misses = (b < 0) + (f < 0);
    if (misses)
        fprintf(stderr, "%s: miss o=(%.9g %.9g %.9g) target=(%.9g %.9g %.9g)\n", what, o[0], o[1],
                o[2], target[0], target[1], target[2]);
    if (b >= 0) {
        const float *v = pos + 9 * b;
        float u, vv;
        bool back;
        rd_ray_triangle(o, d, v, v + 3, v + 6, 0, INFINITY, &t, &u, &vv, &back);
        if (back == expect_front) {
            fprintf(stderr, "%s: unexpected facing\n", what);
            misses++;
        }
    }
    return misses;
}

static void test_watertight(void)
{
    const int g = 8;
    float *pos = tris_alloc(6 * g * g * 2);
    uint32_t n = test_make_cube(pos, g);
    rd_bvh bvh;
    if (!build_checked("cube", &bvh, pos, n, NULL)) {
        free(pos);
        return;
    }
    int misses = 0, rays = 0;
    rng_seed(12);
    /* From inside, exactly through every grid vertex and edge midpoint (x.5 cells). */
    const float inside[4][3] = {
        {0, 0, 0}, {0.25f, -0.5f, 0.125f}, {0.3f, 0.7f, -0.1f}, {-0.9f, 0.9f, 0.9f}};
    for (int oi = 0; oi < 4; oi++) {
        for (int axis = 0; axis < 3; axis++) {
            for (int side = -1; side <= 1; side += 2) {
                for (int i = 0; i <= 2 * g; i++) {
                    for (int j = 0; j <= 2 * g; j++) {
                        float tgt[3];
                        tgt[axis] = (float)side;
                        tgt[(axis + 1) % 3] = -1.0f + (float)i / (float)g;
                        tgt[(axis + 2) % 3] = -1.0f + (float)j / (float)g;
                        misses +=
                            watertight_rays("cube inside", &bvh, pos, n, inside[oi], tgt, false);
                        rays++;
                    }
                }
            }
        }
    }
    /* From outside, aimed at grid vertices on the faces facing the origin. */
    for (int r = 0; r < 2000; r++) {
        float o[3], tgt[3];
        int axis = r % 3, side = (r / 3) % 2 ? 1 : -1;
        for (int a = 0; a < 3; a++)
            o[a] = rng_range(-1.5f, 1.5f);
        o[axis] = side * rng_range(2, 6);
        tgt[axis] = (float)side;
        tgt[(axis + 1) % 3] = -1.0f + (float)(rng_u32() % (g + 1)) * 2.0f / g;
        tgt[(axis + 2) % 3] = -1.0f + (float)(rng_u32() % (g + 1)) * 2.0f / g;
        /* skip targets on the cube's own edges seen from outside the face's slab: grazing */
        if (fabsf(tgt[(axis + 1) % 3]) == 1.0f || fabsf(tgt[(axis + 2) % 3]) == 1.0f) continue;
        misses += watertight_rays("cube outside", &bvh, pos, n, o, tgt, true);
        rays++;
    }
    /* Axis-aligned rays (zero direction components) from origins on the grid planes. */
    for (int i = 0; i <= g; i++) {
        for (int j = 0; j <= g; j++) {
            float a = -1.0f + 2.0f * i / g, b = -1.0f + 2.0f * j / g;
            float o[3] = {a, b, 0.0f}, tgt[3] = {a, b, 1.0f};
            if (fabsf(a) == 1.0f || fabsf(b) == 1.0f)
                continue; /* inside the cube's side walls: grazing */
            misses += watertight_rays("cube axis", &bvh, pos, n, o, tgt, false);
            rays++;
        }
    }
    CHECKF(misses == 0, "cube: %d misses of %d rays", misses, rays);
    rd_bvh_destroy(&bvh);
    free(pos);

    /* A fan of triangles around a vertex, not planar; rays from origins that make the ray
     * pass exactly through the centre vertex (dyadic coordinates), and rays through points
     * near the shared edges. Only directions that see every fan triangle from the front are
     * used: otherwise the fan folds in the ray's projection and a ray passing an ulp beside
     * the vertex may rightly miss. */
    const int k = 11;
    const float c[3] = {0.375f, -0.25f, 0.625f};
    float *fan = tris_alloc((uint32_t)k);
    float ring[11][3];
    for (int i = 0; i < k; i++) {
        float ang = 6.2831853f * (float)i / (float)k + rng_range(-0.1f, 0.1f);
        ring[i][0] = c[0] + cosf(ang);
        ring[i][1] = c[1] + sinf(ang);
        ring[i][2] = c[2] + rng_range(-0.3f, 0.3f);
    }
    for (int i = 0; i < k; i++) {
        memcpy(fan + 9 * i, c, sizeof c);
        memcpy(fan + 9 * i + 3, ring[i], sizeof c);
        memcpy(fan + 9 * i + 6, ring[(i + 1) % k], sizeof c);
    }
    if (build_checked("fan", &bvh, fan, (uint32_t)k, &(rd_bvh_options){.max_leaf = 1})) {
        misses = rays = 0;
        while (rays < 4000) {
            /* direction: multiples of 1/8, so o = c - 4 d is exact */
            float d[3], o[3];
            for (int a = 0; a < 3; a++)
                d[a] = (float)((int)(rng_u32() % 17) - 8) / 8.0f;
            bool all_front = true;
            for (int i = 0; i < k && all_front; i++) {
                const float *v = fan + 9 * i;
                float e1[3], e2[3];
                for (int a = 0; a < 3; a++) {
                    e1[a] = v[3 + a] - v[a];
                    e2[a] = v[6 + a] - v[a];
                }
                float nn[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                               e1[0] * e2[1] - e1[1] * e2[0]};
                all_front = d[0] * nn[0] + d[1] * nn[1] + d[2] * nn[2] < -1e-3f;
            }
            if (!all_front) continue;
            for (int a = 0; a < 3; a++)
                o[a] = c[a] - 4.0f * d[a];
            float t, tf;
            int64_t b = rd_bvh_closest_triangle(&bvh, fan, o, d, 0, INFINITY, &t);
            int64_t f = brute_closest(fan, (uint32_t)k, o, d, 0, INFINITY, &tf);
            misses += (b < 0) + (f < 0);
            CHECK(b < 0 || fabsf(t - 4.0f) < 1e-5f);
            rays++;
            /* through a point near a shared edge */
            int e = rays % k;
            float sc = 0.01f + 0.98f * rng_f();
            float dir[3];
            for (int a = 0; a < 3; a++)
                dir[a] = c[a] + sc * (ring[e][a] - c[a]) - o[a];
            b = rd_bvh_closest_triangle(&bvh, fan, o, dir, 0, INFINITY, &t);
            f = brute_closest(fan, (uint32_t)k, o, dir, 0, INFINITY, &tf);
            misses += (b < 0) + (f < 0);
            rays++;
        }
        CHECKF(misses == 0, "fan: %d misses of %d rays", misses, rays);
        rd_bvh_destroy(&bvh);
    }
    free(fan);

    /* A closed, randomly rotated and perturbed octahedron sphere: rays from inside in random
     * directions and through its vertices never escape. */
    const int sub = 12;
    uint32_t sn = 8 * sub * sub;
    float *sph = tris_alloc(sn);
    uint32_t m = 0;
    float rot[3][3];
    {
        float a = 0.7f, b = 1.1f, cc = -0.4f;
        float ca = cosf(a), sa = sinf(a), cb = cosf(b), sb = sinf(b), cg = cosf(cc), sg = sinf(cc);
        float r[3][3] = {{cb * cg, -cb * sg, sb},
                         {sa * sb * cg + ca * sg, -sa * sb * sg + ca * cg, -sa * cb},
                         {-ca * sb * cg + sa * sg, ca * sb * sg + sa * cg, ca * cb}};
        memcpy(rot, r, sizeof r);
    }
    /* vertex (i, j) of an octant face, shared exactly between neighbouring faces because
     * it is computed from the same integers */
    for (int oct = 0; oct < 8; oct++) {
        float sx = (oct & 1) ? -1.0f : 1.0f, sy = (oct & 2) ? -1.0f : 1.0f,
              sz = (oct & 4) ? -1.0f : 1.0f;
        bool flip = (sx * sy * sz) < 0;
        for (int i = 0; i < sub; i++) {
            for (int j = 0; i + j < sub; j++) {
                int tri_ij[2][3][2] = {{{i, j}, {i + 1, j}, {i, j + 1}},
                                       {{i + 1, j}, {i + 1, j + 1}, {i, j + 1}}};
                for (int t = 0; t < (i + j + 1 < sub ? 2 : 1); t++) {
                    for (int q = 0; q < 3; q++) {
                        int qi = tri_ij[t][flip ? 2 - q : q][0],
                            qj = tri_ij[t][flip ? 2 - q : q][1];
                        int qk = sub - qi - qj;
                        float p[3] = {sx * (float)qi, sy * (float)qj, sz * (float)qk};
                        /* zero coordinates keep one sign so shared vertices are identical */
                        if (qi == 0) p[0] = 0;
                        if (qj == 0) p[1] = 0;
                        if (qk == 0) p[2] = 0;
                        float len = sqrtf(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
                        float rad = 1.0f + 0.1f * sinf((float)(qi * 3 + qj * 5 + qk * 7));
                        float s = rad / len;
                        float w[3];
                        for (int a = 0; a < 3; a++)
                            w[a] = rot[a][0] * p[0] * s + rot[a][1] * p[1] * s +
                                   rot[a][2] * p[2] * s + 0.123f;
                        memcpy(sph + 9 * m + 3 * q, w, sizeof w);
                    }
                    m++;
                }
            }
        }
    }
    CHECK(m == sn);
    if (build_checked("sphere", &bvh, sph, m, NULL)) {
        misses = rays = 0;
        for (int r = 0; r < 4000; r++) {
            float o[3], d[3], t;
            rng_unit(o);
            for (int a = 0; a < 3; a++)
                o[a] = 0.123f + 0.5f * o[a] * rng_f();
            if (r % 2) {
                rng_unit(d);
            } else {
                const float *vtx = sph + 9 * (rng_u32() % m) + 3 * (rng_u32() % 3);
                for (int a = 0; a < 3; a++)
                    d[a] = vtx[a] - o[a];
            }
            if (rd_bvh_closest_triangle(&bvh, sph, o, d, 0, INFINITY, &t) < 0) {
                misses++;
                fprintf(stderr, "sphere: miss o=(%.9g %.9g %.9g) d=(%.9g %.9g %.9g)\n", o[0], o[1],
                        o[2], d[0], d[1], d[2]);
            }
            rays++;
        }
        CHECKF(misses == 0, "sphere: %d misses of %d rays", misses, rays);
        rd_bvh_destroy(&bvh);
    }
    free(sph);
}

/* Axis-aligned boxes hit by rays with zero direction components whose origins lie exactly on
 * box planes: the NaN from 0 * inf in the slab test must not lose hits. */
static void test_axis_aligned(void)
{
    const int cells = 6;
    float *pos = tris_alloc(cells * cells * cells * 12);
    uint32_t n = 0;
    float cube[6 * 8 * 8 * 2 * 9];
    uint32_t cn = test_make_cube(cube, 1);
    for (int i = 0; i < cells; i++)
        for (int j = 0; j < cells; j++)
            for (int k = 0; k < cells; k++) {
                if ((i + j + k) % 2) continue;
                for (uint32_t t = 0; t < cn; t++, n++)
                    for (int q = 0; q < 3; q++) {
                        /* unit cubes [i, i+1] x ... (cube is [-1, 1]) */
                        pos[9 * n + 3 * q + 0] = (float)i + 0.5f + 0.5f * cube[9 * t + 3 * q];
                        pos[9 * n + 3 * q + 1] = (float)j + 0.5f + 0.5f * cube[9 * t + 3 * q + 1];
                        pos[9 * n + 3 * q + 2] = (float)k + 0.5f + 0.5f * cube[9 * t + 3 * q + 2];
                    }
            }
    rd_bvh bvh;
    if (!build_checked("grid", &bvh, pos, n, NULL)) {
        free(pos);
        return;
    }
    rng_seed(13);
    const uint32_t rays = 1500;
    float *orgs = malloc(rays * 6 * sizeof(float)), *dirs = orgs + 3 * rays;
    for (uint32_t r = 0; r < rays; r++) {
        float *o = orgs + 3 * r, *d = dirs + 3 * r;
        for (int a = 0; a < 3; a++) {
            /* on an integer plane or a quarter inside a cell */
            o[a] = (float)(rng_u32() % (cells + 1)) + ((rng_u32() % 2) ? 0.25f : 0.0f);
            d[a] = 0.0f;
        }
        int axis = (int)(r % 3);
        o[axis] = (r % 2) ? -1.0f : (float)cells + 1.0f;
        d[axis] = (r % 2) ? 1.0f : -1.0f;
        if (r % 5 == 0) /* -0 components pick the other slab plane */
            d[(axis + 1) % 3] = -0.0f;
        if (r % 7 == 0) /* two non-zero components */
            d[(axis + 2) % 3] = 1.0f;
    }
    uint32_t hits = compare_rays("grid", &bvh, pos, n, orgs, dirs, rays, 0, INFINITY);
    CHECKF(hits > rays / 4, "grid: %u hits", hits);
    free(orgs);
    rd_bvh_destroy(&bvh);
    free(pos);
}

/* Ray offsets (Wächter & Binder's 256 ulps of the magnitudes met): a ray leaving the offset hit
 * point into the hemisphere of the normal never hits its own triangle, at several magnitudes,
 * and the surface stays reachable from the other side. */
static void test_offset(void)
{
    const float mags[] = {1e-3f, 1.0f, 1e3f, 1e5f};
    rng_seed(14);
    for (int mi = 0; mi < 4; mi++) {
        float M = mags[mi];
        int self_hits = 0, unmoved = 0, tested = 0;
        for (int trial = 0; trial < 300; trial++) {
            float c[3] = {M * 0.6f, -M * 0.8f, M * 0.7f}, tri[9];
            random_tri(tri, c, M * 0.1f);
            float w0 = 0.1f + 0.8f * rng_f(), w1 = (1 - w0) * (0.1f + 0.8f * rng_f());
            float w2 = 1 - w0 - w1;
            float p[3], nrm[3], e1[3], e2[3];
            for (int a = 0; a < 3; a++) {
                p[a] = w0 * tri[a] + w1 * tri[3 + a] + w2 * tri[6 + a];
                e1[a] = tri[3 + a] - tri[a];
                e2[a] = tri[6 + a] - tri[a];
            }
            nrm[0] = e1[1] * e2[2] - e1[2] * e2[1];
            nrm[1] = e1[2] * e2[0] - e1[0] * e2[2];
            nrm[2] = e1[0] * e2[1] - e1[1] * e2[0];
            float len = sqrtf(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
            if (!(len > 0)) continue;
            for (int side = -1; side <= 1; side += 2) {
                float n[3] = {side * nrm[0] / len, side * nrm[1] / len, side * nrm[2] / len};
                float q[3], scale = 0;
                for (int a = 0; a < 9; a++) /* ray_offset_scale without a transform */
                    scale = fmaxf(scale, fabsf(tri[a]));
                scale += fmaxf(fabsf(p[0]), fmaxf(fabsf(p[1]), fabsf(p[2])));
                rd_offset_ray_origin(p, n, rd_ray_offset_distance(scale), q);
                if (q[0] == p[0] && q[1] == p[1] && q[2] == p[2]) unmoved++;
                for (int r = 0; r < 20; r++) {
                    float d[3];
                    rng_unit(d);
                    float dn = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
                    if (dn < 0)
                        for (int a = 0; a < 3; a++)
                            d[a] -= 2 * dn * n[a];
                    if (r < 5) { /* grazing: tilt almost into the plane */
                        dn = fabsf(dn);
                        for (int a = 0; a < 3; a++)
                            d[a] -= (dn - 1e-3f) * n[a];
                    }
                    float t, u, v;
                    bool back;
                    if (rd_ray_triangle(q, d, tri, tri + 3, tri + 6, 0, INFINITY, &t, &u, &v,
                                        &back))
                        self_hits++;
                    tested++;
                }
                /* and the surface stays reachable from the other side */
                float back_dir[3] = {-n[0], -n[1], -n[2]};
                float t, u, v;
                bool back;
                if (!rd_ray_triangle(q, back_dir, tri, tri + 3, tri + 6, 0, INFINITY, &t, &u, &v,
                                     &back))
                    self_hits++;
            }
        }
        CHECKF(self_hits == 0, "offset at magnitude %g: %d self hits of %d rays", M, self_hits,
               tested);
        CHECKF(unmoved == 0, "offset at magnitude %g: %d points did not move", M, unmoved);
    }
    /* The offset is PC_RAY_OFFSET_REL of the scale at every magnitude, only along n; a
     * non-finite scale gives none. */
    const float p[3] = {0.0f, 1.0f, -1000.0f}, n[3] = {0, 0, 1};
    float q[3];
    rd_offset_ray_origin(p, n, rd_ray_offset_distance(2000.0f), q);
    CHECK(q[0] == 0.0f && q[1] == 1.0f && q[2] == -1000.0f + 2000.0f / 65536.0f);
    CHECK(rd_ray_offset_distance(1e-3f) == 1e-3f / 65536.0f);
    CHECK(rd_ray_offset_distance(INFINITY) == 0.0f && rd_ray_offset_distance(NAN) == 0.0f);
    CHECK(rd_ray_offset_distance(0.0f) > 0.0f);
}

int main(void)
{
    test_ray_triangle();
    test_small_counts();
    test_random_soups();
    test_degenerate_soups();
    test_non_finite();
    test_depth_cap();
    test_watertight();
    test_axis_aligned();
    test_offset();
    return test_finish();
}
