/* test_bvh_wide.c: the benchmark's binary to 4-wide BVH collapse (tests/bench/bvh_wide.c):
 * every primitive of a hittable leaf reachable exactly once through the same leaf ranges, child
 * boxes containing their subtrees, empty trees and non-finite triangles, and closest hits over
 * the wide tree equal to rd_bvh_closest_triangle's. Seeded, so a failure reproduces. */
#include "renderer/accel/bvh.h"
#include "tests/bench/bvh_wide.h"
#include "renderer/bvh_check.h"
#include "test_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static uint32_t rng_state = 12345u;
static float frand(void) /* [0, 1) */
{
    rng_state = rng_state * 1664525u + 1013904223u;
    return (float)(rng_state >> 8) / 16777216.0f;
}

/* count random small triangles in [-10, 10]^3; every 97th gets a NaN vertex when nonfinite. */
static float *random_tris(uint32_t count, bool nonfinite)
{
    float *p = malloc((size_t)count * 9 * sizeof *p);
    for (uint32_t i = 0; i < count; i++) {
        float c[3] = {20 * frand() - 10, 20 * frand() - 10, 20 * frand() - 10};
        for (int v = 0; v < 3; v++)
            for (int k = 0; k < 3; k++)
                p[i * 9 + v * 3 + k] = c[k] + frand() - 0.5f;
        if (nonfinite && i % 97 == 5) p[i * 9 + 4] = NAN;
    }
    return p;
}

static float lane(const pc_vec4 *v, int k)
{
    return (&v->x)[k];
}
static uint32_t lane_u(const pc_uvec4 *v, int k)
{
    return (&v->x)[k];
}

typedef struct walk {
    const rtb_wide *w;
    const float *pos; /* leaf-order triangles are pos[prim_index[i] * 9] */
    const uint32_t *prim_index;
    uint32_t *seen; /* per leaf-order primitive */
    uint32_t leaf_prims, bad_box, bad_index;
} walk;

static bool inside(const float lo[3], const float hi[3], const float *p)
{
    for (int k = 0; k < 3; k++)
        if (!(p[k] >= lo[k] && p[k] <= hi[k])) return false;
    return true;
}

/* Checks wide node n's children against the box [lo, hi] of the slot that points to it. */
static void check_node(walk *c, uint32_t n, const float lo[3], const float hi[3])
{
    if (n >= c->w->node_count) {
        c->bad_index++;
        return;
    }
    const rtb_wide_node *d = &c->w->nodes[n];
    for (int k = 0; k < RTB_WIDE; k++) {
        uint32_t count = lane_u(&d->count, k), first = lane_u(&d->child, k);
        float clo[3] = {lane(&d->lo_x, k), lane(&d->lo_y, k), lane(&d->lo_z, k)};
        float chi[3] = {lane(&d->hi_x, k), lane(&d->hi_y, k), lane(&d->hi_z, k)};
        if (count == RTB_WIDE_EMPTY) {
            if (!(clo[0] > chi[0])) c->bad_box++; /* unused slots must never be hit */
            continue;
        }
        if (lo && (!inside(lo, hi, clo) || !inside(lo, hi, chi))) c->bad_box++;
        if (count == 0) {
            check_node(c, first, clo, chi);
            continue;
        }
        for (uint32_t i = first; i < first + count; i++) {
            if (i >= c->leaf_prims) {
                c->bad_index++;
                continue;
            }
            c->seen[i]++;
            const float *t = &c->pos[(size_t)c->prim_index[i] * 9];
            for (int v = 0; v < 3; v++)
                if (!inside(clo, chi, t + 3 * v)) c->bad_box++;
        }
    }
}

/* Closest hit over the wide tree: a double-precision slab test with a little slack (the boxes
 * are under test, not the float arithmetic), rd_ray_triangle on leaf triangles. */
static float wide_closest(const walk *c, uint32_t n, const float o[3], const float d[3], float tmax)
{
    const rtb_wide_node *w = &c->w->nodes[n];
    for (int k = 0; k < RTB_WIDE; k++) {
        uint32_t count = lane_u(&w->count, k), first = lane_u(&w->child, k);
        if (count == RTB_WIDE_EMPTY) continue;
        double lo[3] = {lane(&w->lo_x, k), lane(&w->lo_y, k), lane(&w->lo_z, k)};
        double hi[3] = {lane(&w->hi_x, k), lane(&w->hi_y, k), lane(&w->hi_z, k)};
        double t0;
        if (!slab_enter(lo, hi, o, d, tmax, &t0)) continue;
        if (count == 0) {
            tmax = wide_closest(c, first, o, d, tmax);
            continue;
        }
        for (uint32_t i = first; i < first + count; i++) {
            const float *t = &c->pos[(size_t)c->prim_index[i] * 9];
            float th, u, v;
            bool back;
            if (rd_ray_triangle(o, d, t, t + 3, t + 6, 0, tmax, &th, &u, &v, &back)) tmax = th;
        }
    }
    return tmax;
}

static void test_collapse(uint32_t count, bool nonfinite, uint32_t max_leaf)
{
    float *pos = random_tris(count, nonfinite);
    rd_bvh bvh;
    rd_bvh_options opt = {.max_leaf = max_leaf, .threads = 1};
    CHECK(rd_bvh_build_triangles(&bvh, pos, count, &opt));
    /* twice, as the benchmark appends every mesh's tree to one array: the second tree's
     * indices must not depend on the first */
    rtb_wide w = {0};
    uint32_t pad = rtb_wide_collapse(&w, bvh.nodes, 0);
    uint32_t root = rtb_wide_collapse(&w, bvh.nodes, 0);
    CHECK(pad == 0 && root > 0 && root < w.node_count);
    CHECKF(w.depth <= bvh.depth, "wide depth %u, binary %u", w.depth, bvh.depth);
    CHECK(w.node_count == 2 * (root - pad));

    walk c = {.w = &w,
              .pos = pos,
              .prim_index = bvh.prim_index,
              .seen = calloc(bvh.prim_count, sizeof(uint32_t)),
              .leaf_prims = bvh.prim_count};
    check_node(&c, root, NULL, NULL);
    CHECK(c.bad_box == 0 && c.bad_index == 0);
    uint32_t once = 0, never = 0, twice = 0;
    for (uint32_t i = 0; i < bvh.prim_count; i++) {
        once += c.seen[i] == 1;
        never += c.seen[i] == 0;
        twice += c.seen[i] > 1;
        /* only a triangle the builder can never hit (a non-finite vertex) may be left out */
        if (c.seen[i] == 0) CHECK(nonfinite && isnan(pos[(size_t)bvh.prim_index[i] * 9 + 4]));
    }
    CHECKF(twice == 0 && once + never == count, "once %u never %u twice %u", once, never, twice);
    CHECK(nonfinite ? never > 0 : never == 0);

    uint32_t rays = 2000, same = 0;
    for (uint32_t r = 0; r < rays; r++) {
        float o[3] = {24 * frand() - 12, 24 * frand() - 12, 24 * frand() - 12};
        float d[3] = {frand() - 0.5f, frand() - 0.5f, frand() - 0.5f};
        float tb = INFINITY;
        int64_t hit = rd_bvh_closest_triangle(&bvh, pos, o, d, 0, INFINITY, &tb);
        float tw = wide_closest(&c, root, o, d, INFINITY);
        same += hit < 0 ? tw == INFINITY : tw == tb;
    }
    CHECKF(same == rays, "%u of %u rays agree", same, rays);
    free(c.seen);
    rtb_wide_destroy(&w);
    rd_bvh_destroy(&bvh);
    free(pos);
}

static void test_small_trees(void)
{
    rtb_wide w = {0};
    rd_bvh bvh;
    CHECK(rd_bvh_build_triangles(&bvh, NULL, 0, NULL)); /* empty: one node, empty box */
    uint32_t root = rtb_wide_collapse(&w, bvh.nodes, 0);
    CHECK(w.node_count == 1);
    for (int k = 0; k < RTB_WIDE; k++)
        CHECK(lane_u(&w.nodes[root].count, k) == RTB_WIDE_EMPTY);
    rd_bvh_destroy(&bvh);
    rtb_wide_destroy(&w);

    float *pos = random_tris(1, false); /* a single leaf root */
    CHECK(rd_bvh_build_triangles(&bvh, pos, 1, NULL));
    CHECK(bvh.node_count == 1);
    root = rtb_wide_collapse(&w, bvh.nodes, 0);
    CHECK(w.node_count == 1 && w.nodes[root].count.x == 1 && w.nodes[root].child.x == 0);
    CHECK(w.nodes[root].count.y == RTB_WIDE_EMPTY);
    rd_bvh_destroy(&bvh);
    rtb_wide_destroy(&w);
    free(pos);
    CHECK(rtb_wide_stack_need(RTB_WIDE, 0) <= RTB_WIDE_STACK);
}

int main(void)
{
    test_small_trees();
    test_collapse(17, false, 1);
    test_collapse(5000, false, 0);
    test_collapse(5000, true, 4);
    test_collapse(20000, false, 8);
    return test_finish();
}
