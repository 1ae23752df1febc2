/* test_bvh_cwide.c: the benchmark's binary to compressed 8-wide BVH collapse
 * (tests/bench/bvh_cwide.c) on generated scenes (random triangles, with non-finite ones, flat,
 * far from the origin, instance boxes): every child's quantised box, decoded in float as the
 * tracer decodes it and in double, contains the child's exact binary box and is the tightest
 * such box of its grid; every primitive of a hittable leaf reachable exactly once, every node
 * and leaf entry used once; the depth, and the stack a nearest-first traversal uses, within
 * rtb_wide_stack_need; closest hits over the compressed tree equal to rd_bvh_closest_triangle's,
 * walked nearest first (cwide) and as node groups in octant order (cwide2). The slot order the
 * group traversal relies on: the slots hold exactly the node's non-empty children, a child's
 * rank (its node or leaf entry) is the count of its kind in lower slots, and no child and slot
 * would both be cheaper together (rtb_cwide_slot_cost) than with what they got.
 * Seeded, so a failure reproduces. */
#include "renderer/accel/bvh.h"
#include "tests/bench/bvh_cwide.h"
#include "tests/bench/bvh_wide.h"
#include "renderer/bvh_check.h"
#include "test_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static uint32_t rng_state = 4242u;
static float frand(void) /* [0, 1) */
{
    rng_state = rng_state * 1664525u + 1013904223u;
    return (float)(rng_state >> 8) / 16777216.0f;
}

typedef enum shape { SHAPE_RANDOM, SHAPE_NONFINITE, SHAPE_FLAT, SHAPE_FAR, SHAPE_CAGE } shape;

/* count small triangles: in [-10, 10]^3; with every 97th given a NaN vertex; in the plane
 * z = 0; or of size 0.01 around (1e5, -3e4, 7). Or a cage: triangles one after another along x
 * (a balanced tree) whose boxes all span [-1, 1] in y and z but which cover only y + z <= 0
 * there, so that the spine ray along x through y = z = 0.5 enters every box and hits nothing:
 * the most a traversal pushes. */
static float *make_tris(uint32_t count, shape s)
{
    float *p = malloc((size_t)count * 9 * sizeof *p);
    for (uint32_t i = 0; i < count; i++) {
        float c[3] = {20 * frand() - 10, 20 * frand() - 10, 20 * frand() - 10};
        float size = 1;
        if (s == SHAPE_FAR) {
            c[0] = 1e5f + c[0], c[1] = -3e4f + c[1], c[2] = 7 + c[2];
            size = 0.01f;
        }
        for (int v = 0; v < 3; v++)
            for (int k = 0; k < 3; k++)
                p[i * 9 + v * 3 + k] = c[k] + size * (frand() - 0.5f);
        if (s == SHAPE_FLAT)
            for (int v = 0; v < 3; v++)
                p[i * 9 + v * 3 + 2] = 0;
        if (s == SHAPE_NONFINITE && i % 97 == 5) p[i * 9 + 4] = NAN;
        if (s == SHAPE_CAGE) {
            const float yz[9] = {0, -1, -1, 0, 1, -1, 0, -1, 1};
            for (int k = 0; k < 9; k++)
                p[i * 9 + k] = k % 3 == 0 ? (i + 0.9f * frand()) * 20 / count - 10 : yz[k];
        }
    }
    return p;
}

static uint32_t byte_of(const pc_uvec4 *v, int word, int byte)
{
    return ((&v->x)[word] >> (8 * byte)) & 0xffu;
}

/* The plane p + q * 2^(e - 127) of axis a of node n in double. */
static double plane(const rtb_cwide_node *n, int a, uint32_t q)
{
    uint32_t ebits;
    memcpy(&ebits, &n->origin.w, sizeof ebits);
    int e = (int)((ebits >> (8 * a)) & 0xffu);
    return (double)(&n->origin.x)[a] + q * ldexp(1.0, e - 127);
}

typedef struct walk {
    const rtb_cwide *w;
    const pc_bvh_node *bin;
    const float *pmin, *pmax; /* primitive boxes, original order */
    const uint32_t *prim_index;
    uint32_t prim_count;
    uint32_t *seen_prim, *seen_node, *seen_leaf;
    uint32_t bad_box, loose_box, bad_scale, bad_ref, bad_index, max_level;
    uint32_t bad_slots, bad_rank, unstable;
} walk;

/* The slot order of node d, made from binary node b whose children by slot are slots: every
 * non-empty child of rtb_bvh_open once, ranks in slot order, a stable assignment. */
static void check_slots(walk *c, const rtb_cwide_node *d, uint32_t b, const uint32_t *slots)
{
    uint32_t kids[RTB_CWIDE];
    int n = rtb_bvh_open(c->bin, b, RTB_CWIDE, kids), want = 0, have = 0;
    for (int i = 0; i < n; i++) {
        if (rtb_bvh_box_empty(&c->bin[kids[i]])) continue;
        want++;
        int found = 0;
        for (int k = 0; k < RTB_CWIDE; k++)
            found += slots[k] == kids[i];
        if (found != 1) c->bad_slots++;
    }
    for (int k = 0; k < RTB_CWIDE; k++)
        have += slots[k] != RTB_CWIDE_NONE;
    if (have != want) c->bad_slots++;

    uint32_t below[2] = {0, 0}; /* leaves, interior children in lower slots */
    for (int k = 0; k < RTB_CWIDE; k++) {
        uint32_t meta = byte_of(&d->refs, 2 + (k >> 2), k & 3);
        if (meta == 0) continue;
        int inner = (meta & RTB_CWIDE_INTERIOR) != 0;
        if ((meta & 7) != below[inner]++) c->bad_rank++;
    }

    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int k = 0; k < RTB_CWIDE; k++) {
        if (slots[k] == RTB_CWIDE_NONE) continue;
        for (int a = 0; a < 3; a++) {
            lo[a] = fminf(lo[a], (&c->bin[slots[k]].bmin.x)[a]);
            hi[a] = fmaxf(hi[a], (&c->bin[slots[k]].bmax.x)[a]);
        }
    }
    for (int k = 0; k < RTB_CWIDE; k++) { /* child in k against every other slot j */
        if (slots[k] == RTB_CWIDE_NONE) continue;
        const pc_bvh_node *ck = &c->bin[slots[k]];
        double mine = rtb_cwide_slot_cost(lo, hi, ck, k);
        for (int j = 0; j < RTB_CWIDE; j++) {
            double there = rtb_cwide_slot_cost(lo, hi, ck, j);
            double holder = slots[j] == RTB_CWIDE_NONE
                                ? INFINITY
                                : rtb_cwide_slot_cost(lo, hi, &c->bin[slots[j]], j);
            if (there < mine && there < holder) c->unstable++;
        }
    }
}

static bool box_in(const float *lo, const float *hi, const float *ilo, const float *ihi)
{
    for (int a = 0; a < 3; a++)
        if (!(lo[a] <= ilo[a] && hi[a] >= ihi[a])) return false;
    return true;
}

/* Checks compressed node n, made from binary node b, and everything below it. */
static void check_node(walk *c, uint32_t n, uint32_t b, uint32_t level)
{
    if (n >= c->w->node_count) {
        c->bad_index++;
        return;
    }
    c->seen_node[n]++;
    if (level > c->max_level) c->max_level = level;
    const rtb_cwide_node *d = &c->w->nodes[n];
    uint32_t slots[RTB_CWIDE];
    float ulo[3], uhi[3];
    rtb_cwide_slots(c->bin, b, slots, ulo, uhi);
    check_slots(c, d, b, slots);
    float nlo[3] = {INFINITY, INFINITY, INFINITY}, nhi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int k = 0; k < RTB_CWIDE; k++) {
        float lo[3], hi[3];
        uint32_t child, count;
        bool used = rtb_cwide_child(c->w, d, k, lo, hi, &child, &count);
        bool expect = slots[k] != RTB_CWIDE_NONE;
        if (used != expect) c->bad_ref++;
        if (!used || !expect) continue;
        const pc_bvh_node *e = &c->bin[slots[k]];
        const float *elo = &e->bmin.x, *ehi = &e->bmax.x;
        for (int a = 0; a < 3; a++) {
            nlo[a] = fminf(nlo[a], elo[a]);
            nhi[a] = fmaxf(nhi[a], ehi[a]);
        }
        /* (a) the float box the tracer tests and the exact (double) box contain e's box, and
         * one grid step less on any side would not */
        if (!box_in(lo, hi, elo, ehi)) c->bad_box++;
        int word = k >> 2, byte = k & 3;
        const pc_uvec4 *q[3] = {&d->q_x, &d->q_y, &d->q_z};
        for (int a = 0; a < 3; a++) {
            uint32_t ql = byte_of(q[a], word, byte), qh = byte_of(q[a], 2 + word, byte);
            if (!(plane(d, a, ql) <= elo[a] && plane(d, a, qh) >= ehi[a])) c->bad_box++;
            if (ql < 255 && plane(d, a, ql + 1) <= elo[a]) c->loose_box++;
            if (qh > 0 && plane(d, a, qh - 1) >= ehi[a]) c->loose_box++;
        }
        uint32_t meta = byte_of(&d->refs, 2 + word, byte);
        if (count != rd_bvh_node_count(e)) {
            c->bad_ref++;
        } else if (count == 0) {
            if (child != d->refs.x + (meta & 7)) c->bad_ref++;
            check_node(c, child, slots[k], level + 1);
        } else { /* (b) a leaf: the binary leaf's range, through a leaf entry used once */
            uint32_t entry = d->refs.y + (meta & 7);
            if (entry >= c->w->leaf_count) {
                c->bad_index++;
                continue;
            }
            c->seen_leaf[entry]++;
            if (child != rd_bvh_node_first(e)) c->bad_ref++;
            for (uint32_t i = child; i < child + count; i++) {
                if (i >= c->prim_count) {
                    c->bad_index++;
                    continue;
                }
                c->seen_prim[i]++;
                uint32_t p = c->prim_index[i];
                if (c->pmin[3 * p] <= c->pmax[3 * p] && /* a hittable primitive */
                    !box_in(lo, hi, &c->pmin[3 * p], &c->pmax[3 * p]))
                    c->bad_box++;
            }
        }
    }
    /* the node's origin is its children's low corner and each scale the smallest that spans
     * its children with 255 steps */
    for (int a = 0; a < 3 && nlo[a] <= nhi[a]; a++) {
        if ((&d->origin.x)[a] != nlo[a]) c->bad_scale++;
        uint32_t ebits;
        memcpy(&ebits, &d->origin.w, sizeof ebits);
        int ea = (int)((ebits >> (8 * a)) & 0xffu);
        if (ea < 1 || ea > 254 || plane(d, a, 255) < nhi[a]) c->bad_scale++;
        if (ea > 1 && (double)nlo[a] + 255 * ldexp(1.0, ea - 128) >= nhi[a]) c->bad_scale++;
    }
}

typedef struct entry {
    uint32_t x, count;
    double t;
} entry;

/* The slab test of the walks below on child k of node n: entry distance *t0, or false. */
static bool child_hit(const rtb_cwide *w, const rtb_cwide_node *n, int k, const float o[3],
                      const float d[3], float tmax, double *t0, uint32_t *child, uint32_t *count)
{
    float lo[3], hi[3];
    if (!rtb_cwide_child(w, n, k, lo, hi, child, count)) return false;
    const double dlo[3] = {lo[0], lo[1], lo[2]}, dhi[3] = {hi[0], hi[1], hi[2]};
    return slab_enter(dlo, dhi, o, d, tmax, t0);
}

/* Closest hit over the compressed tree as rtb_trace_cwide.comp walks it (one level): a stack of
 * hit children pushed far to near, popped entries culled against the closest hit; a
 * double-precision slab test with a little slack on the decoded boxes (the boxes are under
 * test, not the float arithmetic). *max_sp: the most entries the stack held. */
static float cwide_closest(const rtb_cwide *w, const float *pos, const uint32_t *prim_index,
                           uint32_t root, const float o[3], const float d[3], uint32_t *max_sp)
{
    entry stack[1024];
    uint32_t sp = 0;
    stack[sp++] = (entry){root, 0, 0};
    float tmax = INFINITY;
    while (sp > 0) {
        entry e = stack[--sp];
        if (e.t > tmax) continue;
        if (e.count > 0) {
            for (uint32_t i = e.x; i < e.x + e.count; i++) {
                const float *t = &pos[(size_t)prim_index[i] * 9];
                float th, u, v;
                bool back;
                if (rd_ray_triangle(o, d, t, t + 3, t + 6, 0, tmax, &th, &u, &v, &back)) tmax = th;
            }
            continue;
        }
        entry hits[RTB_CWIDE];
        int nh = 0;
        for (int k = 0; k < RTB_CWIDE; k++) {
            uint32_t child, count;
            double t0;
            if (!child_hit(w, &w->nodes[e.x], k, o, d, tmax, &t0, &child, &count)) continue;
            int j = nh++; /* insertion, farthest first */
            while (j > 0 && hits[j - 1].t < t0) {
                hits[j] = hits[j - 1];
                j--;
            }
            hits[j] = (entry){child, count, t0};
        }
        for (int j = 0; j < nh && sp < 1024; j++)
            stack[sp++] = hits[j];
        if (sp > *max_sp) *max_sp = sp;
    }
    return tmax;
}

static int msb(uint32_t x)
{
    int b = 31;
    while (!(x >> b))
        b--;
    return b;
}

static int popcount(uint32_t x)
{
    int n = 0;
    for (; x; x &= x - 1)
        n++;
    return n;
}

/* Closest hit as rtb_trace_cwide.comp's group traversal walks it (one level): entries
 * (child_base, hits << 8 | imask), hits in octant order (slot s at bit s ^ (7 - octant)), the
 * next child the highest bit and its node index the base plus the interior slots below it
 * (which is what the slot order must make right: a wrong rank visits the wrong node and loses
 * hits); a node's hit leaves intersected at once. *max_sp: the most groups the stack held. */
static float cwide_groups_closest(const rtb_cwide *w, const float *pos, const uint32_t *prim_index,
                                  uint32_t root, const float o[3], const float d[3],
                                  uint32_t *max_sp)
{
    uint32_t x = (d[0] < 0 ? 0u : 1u) | (d[1] < 0 ? 0u : 2u) | (d[2] < 0 ? 0u : 4u);
    uint32_t stack[1024][2], sp = 0;
    uint32_t gx = root, gy = (1u << (8 + x)) | 1u;
    float tmax = INFINITY;
    for (;;) {
        if ((gy & 0xff00u) == 0) {
            if (sp == 0) break;
            sp--;
            gx = stack[sp][0], gy = stack[sp][1];
            continue;
        }
        int bit = msb(gy);
        gy &= ~(1u << bit);
        uint32_t slot = ((uint32_t)bit - 8) ^ x;
        uint32_t node = gx + (uint32_t)popcount(gy & ((1u << slot) - 1));
        if ((gy & 0xff00u) && sp < 1024) {
            stack[sp][0] = gx, stack[sp][1] = gy;
            sp++;
            if (sp > *max_sp) *max_sp = sp;
        }
        const rtb_cwide_node *n = &w->nodes[node];
        uint32_t ihits = 0, lhits = 0, imask = 0, first[RTB_CWIDE], cnt[RTB_CWIDE];
        for (int k = 0; k < RTB_CWIDE; k++) {
            uint32_t meta = byte_of(&n->refs, 2 + (k >> 2), k & 3);
            if (meta & RTB_CWIDE_INTERIOR) imask |= 1u << k;
            double t0;
            if (!child_hit(w, n, k, o, d, tmax, &t0, &first[k], &cnt[k])) continue;
            if (cnt[k] == 0)
                ihits |= 1u << (k ^ x);
            else
                lhits |= 1u << (k ^ x);
        }
        gx = n->refs.x, gy = ihits << 8 | imask;
        while (lhits) {
            int b = msb(lhits);
            lhits &= ~(1u << b);
            uint32_t k = (uint32_t)b ^ x;
            for (uint32_t i = first[k]; i < first[k] + cnt[k]; i++) {
                const float *t = &pos[(size_t)prim_index[i] * 9];
                float th, u, v;
                bool back;
                if (rd_ray_triangle(o, d, t, t + 3, t + 6, 0, tmax, &th, &u, &v, &back)) tmax = th;
            }
        }
    }
    return tmax;
}

/* Collapses bvh (over count primitives with boxes pmin/pmax; triangles pos when not NULL) and
 * checks it. */
static void check_tree(const rd_bvh *bvh, const float *pmin, const float *pmax, uint32_t count,
                       const float *pos)
{
    /* twice, as the benchmark appends every mesh's tree to one array: the second tree's
     * indices must not depend on the first */
    rtb_cwide w = {0};
    uint32_t pad = rtb_cwide_collapse(&w, bvh->nodes, 0);
    uint32_t leaves_pad = w.leaf_count, nodes_pad = w.node_count;
    uint32_t root = rtb_cwide_collapse(&w, bvh->nodes, 0);
    CHECK(pad == 0 && root == nodes_pad && root < w.node_count);
    CHECK(w.node_count == 2 * nodes_pad && w.leaf_count == 2 * leaves_pad);
    CHECK(rtb_cwide_bytes(&w) == 80ull * w.node_count + 4ull * w.leaf_count);

    walk c = {.w = &w,
              .bin = bvh->nodes,
              .pmin = pmin,
              .pmax = pmax,
              .prim_index = bvh->prim_index,
              .prim_count = bvh->prim_count,
              .seen_prim = calloc(bvh->prim_count + 1, sizeof(uint32_t)),
              .seen_node = calloc(w.node_count, sizeof(uint32_t)),
              .seen_leaf = calloc(w.leaf_count + 1, sizeof(uint32_t))};
    check_node(&c, root, 0, 0);
    CHECKF(c.bad_box == 0 && c.loose_box == 0 && c.bad_scale == 0,
           "boxes: %u not containing, %u loose, %u bad scales", c.bad_box, c.loose_box,
           c.bad_scale);
    CHECKF(c.bad_ref == 0 && c.bad_index == 0, "%u bad references, %u bad indices", c.bad_ref,
           c.bad_index);
    CHECKF(c.bad_slots == 0 && c.bad_rank == 0 && c.unstable == 0,
           "slot order: %u bad child sets, %u ranks out of slot order, %u unstable pairs",
           c.bad_slots, c.bad_rank, c.unstable);
    uint32_t once = 0, never = 0, twice = 0;
    for (uint32_t i = 0; i < bvh->prim_count; i++) {
        once += c.seen_prim[i] == 1;
        never += c.seen_prim[i] == 0;
        twice += c.seen_prim[i] > 1;
        /* only a primitive the builder can never hit (a non-finite box) may be left out */
        uint32_t p = bvh->prim_index[i];
        if (c.seen_prim[i] == 0) CHECK(!(pmin[3 * p] <= pmax[3 * p]));
    }
    CHECKF(twice == 0 && once + never == count, "once %u never %u twice %u", once, never, twice);
    uint32_t nodes_once = 0, leaves_once = 0;
    for (uint32_t i = nodes_pad; i < w.node_count; i++)
        nodes_once += c.seen_node[i] == 1;
    for (uint32_t i = leaves_pad; i < w.leaf_count; i++)
        leaves_once += c.seen_leaf[i] == 1;
    CHECKF(nodes_once == nodes_pad && leaves_once == w.leaf_count - leaves_pad,
           "%u of %u nodes and %u of %u leaf entries used once", nodes_once, nodes_pad, leaves_once,
           w.leaf_count - leaves_pad);

    /* (c) depth: as walked, no deeper than the binary tree, within the tracer's stack */
    CHECKF(c.max_level == w.depth, "walked %u levels, collapse says %u", c.max_level, w.depth);
    CHECKF(w.depth <= bvh->depth, "compressed depth %u, binary %u", w.depth, bvh->depth);
    CHECK(rtb_wide_stack_need(RTB_CWIDE, w.depth) <= RTB_CWIDE_STACK);

    if (pos) {
        uint32_t rays = 2000, same = 0, same_groups = 0, max_sp = 0, max_groups = 0;
        for (uint32_t r = 0; r < rays; r++) {
            /* from inside and around the scene's box, towards random points in it; the first
             * ray the cage's spine */
            const pc_bvh_node *rb = &bvh->nodes[0];
            float o[3] = {-20, 0.5f, 0.5f}, d[3] = {1, 0, 0};
            for (int a = 0; a < 3 && r > 0; a++) {
                float lo = (&rb->bmin.x)[a], hi = (&rb->bmax.x)[a], ext = hi - lo + 1;
                o[a] = lo - 0.2f * ext + 1.4f * ext * frand();
                d[a] = lo + (hi - lo) * frand() - o[a];
            }
            float tb = INFINITY;
            int64_t hit = rd_bvh_closest_triangle(bvh, pos, o, d, 0, INFINITY, &tb);
            float tw = cwide_closest(&w, pos, bvh->prim_index, root, o, d, &max_sp);
            same += hit < 0 ? tw == INFINITY : tw == tb;
            float tg = cwide_groups_closest(&w, pos, bvh->prim_index, root, o, d, &max_groups);
            same_groups += hit < 0 ? tg == INFINITY : tg == tb;
        }
        CHECKF(same == rays, "%u of %u rays agree", same, rays);
        CHECKF(same_groups == rays, "groups: %u of %u rays agree", same_groups, rays);
        /* a group per level at most, within RTB_CWIDE_STACK's bound for groups */
        CHECKF(max_groups <= w.depth + 1, "%u groups at depth %u", max_groups, w.depth);
        /* one level's share of the two-level bound */
        CHECKF(2 * max_sp + RD_BVH_MAX_LEAF <= rtb_wide_stack_need(RTB_CWIDE, w.depth),
               "stack held %u entries at depth %u", max_sp, w.depth);
    }
    free(c.seen_prim);
    free(c.seen_node);
    free(c.seen_leaf);
    rtb_cwide_destroy(&w);
}

static void test_tris(uint32_t count, shape s, uint32_t max_leaf)
{
    float *pos = make_tris(count, s);
    float *pmin = malloc((size_t)count * 3 * sizeof *pmin);
    float *pmax = malloc((size_t)count * 3 * sizeof *pmax);
    rd_bvh_triangle_boxes(pos, count, pmin, pmax);
    rd_bvh bvh;
    rd_bvh_options opt = {.max_leaf = max_leaf, .threads = 1};
    CHECK(rd_bvh_build_triangles(&bvh, pos, count, &opt));
    check_tree(&bvh, pmin, pmax, count, pos);
    rd_bvh_destroy(&bvh);
    free(pmax);
    free(pmin);
    free(pos);
}

/* A TLAS-like tree over count instance boxes of very different sizes. */
static void test_boxes(uint32_t count)
{
    float *pmin = malloc((size_t)count * 3 * sizeof *pmin);
    float *pmax = malloc((size_t)count * 3 * sizeof *pmax);
    for (uint32_t i = 0; i < count; i++) {
        float size = i % 10 == 0 ? 50 * frand() : frand();
        for (int a = 0; a < 3; a++) {
            pmin[3 * i + a] = 200 * frand() - 100;
            pmax[3 * i + a] = pmin[3 * i + a] + size;
        }
    }
    rd_bvh bvh;
    rd_bvh_options opt = {.max_leaf = RD_BVH_MAX_LEAF, .threads = 1};
    CHECK(rd_bvh_build(&bvh, pmin, pmax, count, &opt));
    check_tree(&bvh, pmin, pmax, count, NULL);
    rd_bvh_destroy(&bvh);
    free(pmax);
    free(pmin);
}

static void test_small_trees(void)
{
    rtb_cwide w = {0};
    rd_bvh bvh;
    CHECK(rd_bvh_build_triangles(&bvh, NULL, 0, NULL)); /* empty: one node, empty box */
    uint32_t root = rtb_cwide_collapse(&w, bvh.nodes, 0);
    CHECK(w.node_count == 1 && w.leaf_count == 0 && w.depth == 0);
    for (int k = 0; k < RTB_CWIDE; k++) {
        float lo[3], hi[3];
        uint32_t child, count;
        CHECK(!rtb_cwide_child(&w, &w.nodes[root], k, lo, hi, &child, &count));
    }
    rd_bvh_destroy(&bvh);
    rtb_cwide_destroy(&w);

    float *pos = make_tris(1, SHAPE_RANDOM); /* a single leaf root */
    CHECK(rd_bvh_build_triangles(&bvh, pos, 1, NULL));
    CHECK(bvh.node_count == 1);
    root = rtb_cwide_collapse(&w, bvh.nodes, 0);
    CHECK(w.node_count == 1 && w.leaf_count == 1);
    float lo[3], hi[3];
    uint32_t child = 99, count = 99;
    CHECK(rtb_cwide_child(&w, &w.nodes[root], 0, lo, hi, &child, &count));
    CHECK(child == 0 && count == 1 && box_in(lo, hi, &bvh.nodes[0].bmin.x, &bvh.nodes[0].bmax.x));
    CHECK(!rtb_cwide_child(&w, &w.nodes[root], 1, lo, hi, &child, &count));
    rd_bvh_destroy(&bvh);
    rtb_cwide_destroy(&w);
    free(pos);
    CHECK(rtb_wide_stack_need(RTB_CWIDE, 0) <= RTB_CWIDE_STACK);
}

int main(void)
{
    test_small_trees();
    test_tris(17, SHAPE_RANDOM, 1);
    test_tris(5000, SHAPE_RANDOM, 0);
    test_tris(5000, SHAPE_NONFINITE, 4);
    test_tris(20000, SHAPE_RANDOM, 8);
    test_tris(3000, SHAPE_FLAT, 4);
    test_tris(3000, SHAPE_FAR, 2);
    test_tris(4096, SHAPE_CAGE, 1);
    test_boxes(300);
    return test_finish();
}
