/* ploc_ref.c: see ploc_ref.h. */
#include "ploc_ref.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct cluster {
    float lo[3], hi[3];
    int32_t left, right; /* children; -1 for a triangle */
    uint32_t tri, count; /* the triangle (leaves), triangles below */
    uint32_t nonfinite;  /* triangles below with a non-finite vertex (kept out of mixed leaves) */
    bool leaf;           /* a triangle, or a collapsed subtree (one output leaf) */
} cluster;

typedef struct builder {
    cluster *c;
    uint32_t used;
    pc_bvh_node *nodes;
    uint32_t node_count, *prim, prim_count, depth;
} builder;

static void *xmalloc(size_t bytes)
{
    void *p = malloc(bytes ? bytes : 1);
    if (!p) {
        fprintf(stderr, "ploc_ref: out of memory\n");
        abort();
    }
    return p;
}

static float half_area(const float lo[3], const float hi[3])
{
    if (!(lo[0] <= hi[0] && lo[1] <= hi[1] && lo[2] <= hi[2])) return 0; /* empty */
    float d[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
    return d[0] * d[1] + d[1] * d[2] + d[2] * d[0];
}

static float union_area(const cluster *a, const cluster *b)
{
    float lo[3], hi[3];
    for (int k = 0; k < 3; k++) {
        lo[k] = fminf(a->lo[k], b->lo[k]);
        hi[k] = fmaxf(a->hi[k], b->hi[k]);
    }
    return half_area(lo, hi);
}

/* 10 bits spread to every third bit of 30 (lbvh_morton.comp's lbvh_expand_bits). */
static uint32_t expand_bits(uint32_t v)
{
    v = (v * 0x00010001u) & 0xFF0000FFu;
    v = (v * 0x00000101u) & 0x0F00F00Fu;
    v = (v * 0x00000011u) & 0xC30C30C3u;
    v = (v * 0x00000005u) & 0x49249249u;
    return v;
}

typedef struct key {
    uint32_t code, tri;
} key;

static int key_order(const void *a, const void *b)
{
    const key *x = a, *y = b;
    if (x->code != y->code) return x->code < y->code ? -1 : 1;
    return x->tri < y->tri ? -1 : x->tri > y->tri;
}

static bool finite_tri(const float *v)
{
    for (int k = 0; k < 9; k++)
        if (!isfinite(v[k])) return false;
    return true;
}

/* The leaves' clusters (boxes; empty for a non-finite triangle) and their Morton order. */
static key *leaves(builder *b, const float *pos, uint32_t n)
{
    float clo[3] = {INFINITY, INFINITY, INFINITY}, chi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t t = 0; t < n; t++) {
        const float *v = pos + 9 * (size_t)t;
        cluster *c = &b->c[t];
        bool fin = finite_tri(v);
        *c = (cluster){
            .left = -1, .right = -1, .tri = t, .count = 1, .nonfinite = !fin, .leaf = true};
        for (int k = 0; k < 3; k++) {
            c->lo[k] = fin ? fminf(v[k], fminf(v[3 + k], v[6 + k])) : INFINITY;
            c->hi[k] = fin ? fmaxf(v[k], fmaxf(v[3 + k], v[6 + k])) : -INFINITY;
            float m = (v[k] + v[3 + k] + v[6 + k]) * (1.0f / 3.0f);
            if (fin) clo[k] = fminf(clo[k], m), chi[k] = fmaxf(chi[k], m);
        }
    }
    key *keys = xmalloc((size_t)n * sizeof *keys);
    for (uint32_t t = 0; t < n; t++) {
        const float *v = pos + 9 * (size_t)t;
        uint32_t code = 1u << 30, q[3];
        if (finite_tri(v)) {
            for (int k = 0; k < 3; k++) {
                float ext = chi[k] - clo[k], m = (v[k] + v[3 + k] + v[6 + k]) * (1.0f / 3.0f);
                float u = ext > 0 ? (m - clo[k]) / ext * 1024.0f : 0;
                q[k] = u < 0 ? 0 : u > 1023 ? 1023 : (uint32_t)u;
            }
            code = expand_bits(q[0]) * 4 + expand_bits(q[1]) * 2 + expand_bits(q[2]);
        }
        keys[t] = (key){code, t};
    }
    qsort(keys, n, sizeof *keys, key_order);
    return keys;
}

/* The SAH cost of cluster i's subtree with its best collapses (post-order, by an explicit stack
 * of cluster indices; children are always created before their parent, so a parent's index is
 * larger and one pass upward over the indices in creation order suffices). */
static void collapse(builder *b, uint32_t max_leaf, float leaf_weight, float *cost)
{
    for (uint32_t i = 0; i < b->used; i++) {
        cluster *c = &b->c[i];
        float a = half_area(c->lo, c->hi);
        if (c->left < 0) {
            cost[i] = a;
            continue;
        }
        cost[i] = a + cost[c->left] + cost[c->right];
        bool mixed = c->nonfinite != 0 && c->nonfinite != c->count;
        if (!mixed && c->count <= max_leaf && leaf_weight * a * (float)c->count <= cost[i]) {
            cost[i] = a * (float)c->count;
            c->leaf = true;
        }
    }
}

/* Writes the triangles under cluster i to b->prim (depth-first, left first). */
static void gather(builder *b, uint32_t i)
{
    uint32_t stack[2 * RD_BVH_MAX_LEAF + 2], sp = 0;
    stack[sp++] = i;
    while (sp) {
        const cluster *c = &b->c[stack[--sp]];
        if (c->left < 0) {
            b->prim[b->prim_count++] = c->tri;
            continue;
        }
        stack[sp++] = (uint32_t)c->right;
        stack[sp++] = (uint32_t)c->left;
    }
}

/* The output tree from root: each node at its slot, an interior node's children at the next
 * free pair (depth-first by an explicit stack of (cluster, slot, level)). */
static void emit(builder *b, uint32_t root)
{
    uint32_t *stack = xmalloc(3 * (size_t)(b->used + 1) * sizeof *stack), sp = 0;
    stack[sp++] = root, stack[sp++] = 0, stack[sp++] = 0;
    b->node_count = 1;
    while (sp) {
        uint32_t level = stack[--sp], slot = stack[--sp], i = stack[--sp];
        const cluster *c = &b->c[i];
        pc_bvh_node *o = &b->nodes[slot];
        o->bmin = (pc_vec4){c->lo[0], c->lo[1], c->lo[2], 0};
        o->bmax = (pc_vec4){c->hi[0], c->hi[1], c->hi[2], 0};
        b->depth = level > b->depth ? level : b->depth;
        if (c->count == 0) /* the empty root: an empty box, no triangles */
            continue;
        if (c->leaf) {
            uint32_t first = b->prim_count;
            gather(b, i);
            o->bmin.w = pc_u2f(first);
            o->bmax.w = pc_u2f(b->prim_count - first);
            continue;
        }
        uint32_t f = b->node_count;
        b->node_count += 2;
        o->bmin.w = pc_u2f(f);
        o->bmax.w = pc_u2f(0);
        stack[sp++] = (uint32_t)c->right, stack[sp++] = f + 1, stack[sp++] = level + 1;
        stack[sp++] = (uint32_t)c->left, stack[sp++] = f, stack[sp++] = level + 1;
    }
    free(stack);
}

bool pc_ploc_build(rd_bvh *out, const float *pos, uint32_t n, uint32_t radius, uint32_t max_leaf,
                   float leaf_weight, uint32_t *iterations)
{
    memset(out, 0, sizeof *out);
    if (radius < 1 || max_leaf < 1 || max_leaf > RD_BVH_MAX_LEAF || (n && !pos)) return false;
    builder b = {.c = xmalloc((2 * (size_t)n + 1) * sizeof(cluster))};
    uint32_t rounds = 0;
    if (n == 0) { /* an empty root, as the other builders give */
        b.c[0] = (cluster){.lo = {INFINITY, INFINITY, INFINITY},
                           .hi = {-INFINITY, -INFINITY, -INFINITY},
                           .left = -1,
                           .right = -1};
        b.used = 1;
    } else {
        key *keys = leaves(&b, pos, n);
        b.used = n;
        uint32_t *cur = xmalloc((size_t)n * sizeof *cur), *next = xmalloc((size_t)n * sizeof *next);
        int64_t *nn = xmalloc((size_t)n * sizeof *nn);
        for (uint32_t i = 0; i < n; i++)
            cur[i] = keys[i].tri;
        free(keys);
        for (uint32_t count = n; count > 1; rounds++) {
            for (uint32_t i = 0; i < count; i++) {
                uint32_t lo = i > radius ? i - radius : 0;
                uint32_t hi = i + radius < count ? i + radius : count - 1;
                float best = INFINITY;
                uint32_t best_d = UINT32_MAX;
                nn[i] = -1;
                for (uint32_t j = lo; j <= hi; j++) {
                    if (j == i) continue;
                    /* ties: the nearer place; between the two at distance 1, i's partner in its
                     * aligned pair (i ^ 1), so that equal boxes pair up instead of chaining */
                    float a = union_area(&b.c[cur[i]], &b.c[cur[j]]);
                    uint32_t d = j > i ? j - i : i - j;
                    bool nearer = d < best_d || (d == best_d && d == 1 && j == (i ^ 1u));
                    if (nn[i] < 0 || a < best || (a == best && nearer))
                        best = a, best_d = d, nn[i] = j;
                }
            }
            uint32_t m = 0;
            for (uint32_t i = 0; i < count; i++) {
                uint32_t j = (uint32_t)nn[i];
                if ((uint32_t)nn[j] != i) {
                    next[m++] = cur[i];
                } else if (i < j) { /* mutual: merged at the lower place */
                    cluster *p = &b.c[b.used], *l = &b.c[cur[i]], *r = &b.c[cur[j]];
                    *p = (cluster){.left = (int32_t)cur[i],
                                   .right = (int32_t)cur[j],
                                   .count = l->count + r->count,
                                   .nonfinite = l->nonfinite + r->nonfinite};
                    for (int k = 0; k < 3; k++) {
                        p->lo[k] = fminf(l->lo[k], r->lo[k]);
                        p->hi[k] = fmaxf(l->hi[k], r->hi[k]);
                    }
                    next[m++] = b.used++;
                }
            }
            uint32_t *t = cur;
            cur = next, next = t;
            count = m;
        }
        free(cur), free(next), free(nn);
        float *cost = xmalloc((size_t)b.used * sizeof *cost);
        collapse(&b, max_leaf, leaf_weight, cost);
        free(cost);
    }
    b.nodes = xmalloc((2 * (size_t)n + 1) * sizeof *b.nodes);
    b.prim = xmalloc((size_t)(n ? n : 1) * sizeof *b.prim);
    emit(&b, b.used - 1); /* the root: the last cluster made */
    free(b.c);
    *out = (rd_bvh){.nodes = b.nodes,
                    .node_count = b.node_count,
                    .prim_index = b.prim,
                    .prim_count = b.prim_count,
                    .depth = b.depth};
    if (iterations) *iterations = rounds;
    return true;
}
