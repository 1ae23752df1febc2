/* bvh_check.c: shared by the BVH tests (test_bvh.c, test_bvh_build.c): a seeded random
 * generator, brute-force closest hits, and the structural checks of every promise in bvh.h. */
#include "bvh_check.h"

#include "test_util.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- helpers --------------------------------------------------------------------------- */

static uint64_t rng_state = 0x9E3779B97F4A7C15ull;

void rng_seed(uint64_t s)
{
    rng_state = s ? s : 1;
}

uint32_t rng_u32(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (uint32_t)(rng_state >> 32);
}

float rng_f(void) /* [0, 1) */
{
    return (float)(rng_u32() >> 8) * (1.0f / 16777216.0f);
}

float rng_range(float a, float b)
{
    return a + (b - a) * rng_f();
}

void rng_unit(float d[3])
{
    for (;;) {
        d[0] = rng_range(-1, 1);
        d[1] = rng_range(-1, 1);
        d[2] = rng_range(-1, 1);
        float l2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        if (l2 > 1e-4f && l2 <= 1.0f) {
            float s = 1.0f / sqrtf(l2);
            d[0] *= s, d[1] *= s, d[2] *= s;
            return;
        }
    }
}

float *tris_alloc(uint32_t n)
{
    float *p = calloc((size_t)(n ? n : 1) * 9, sizeof(float));
    if (!p) abort();
    return p;
}

int64_t brute_closest(const float *pos, uint32_t n, const float o[3], const float d[3], float tmin,
                      float tmax, float *t_out)
{
    int64_t best = -1;
    float bt = tmax;
    for (uint32_t i = 0; i < n; i++) {
        const float *v = pos + 9 * (size_t)i;
        float t, u, vv;
        bool back;
        if (rd_ray_triangle(o, d, v, v + 3, v + 6, tmin, bt, &t, &u, &vv, &back)) {
            bt = t;
            best = i;
        }
    }
    if (best >= 0) *t_out = bt;
    return best;
}

bool tri_finite(const float *v)
{
    for (int k = 0; k < 9; k++)
        if (!isfinite(v[k])) return false;
    return true;
}

/* ---- structural checks ----------------------------------------------------------------- */

bool box_empty(const pc_bvh_node *n)
{
    return !(n->bmin.x <= n->bmax.x && n->bmin.y <= n->bmax.y && n->bmin.z <= n->bmax.z);
}

bool box_contains(const pc_bvh_node *outer, const float lo[3], const float hi[3])
{
    return outer->bmin.x <= lo[0] && outer->bmin.y <= lo[1] && outer->bmin.z <= lo[2] &&
           outer->bmax.x >= hi[0] && outer->bmax.y >= hi[1] && outer->bmax.z >= hi[2];
}

/* Double-precision slab test of the ray (o, d) over [0, tmax] against the box lo..hi grown by
 * 1e-4 on every side (tests of wide node layouts check the boxes, not float arithmetic): the
 * entry distance in *t0 and true where the ray enters. */
bool slab_enter(const double lo[3], const double hi[3], const float o[3], const float d[3],
                double tmax, double *t0)
{
    double t_in = 0, t_out = tmax;
    for (int a = 0; a < 3; a++) {
        double inv = 1.0 / d[a];
        double ta = (lo[a] - 1e-4 - o[a]) * inv, tb = (hi[a] + 1e-4 - o[a]) * inv;
        if (ta > tb) {
            double s = ta;
            ta = tb;
            tb = s;
        }
        t_in = ta > t_in ? ta : t_in;
        t_out = tb < t_out ? tb : t_out;
    }
    *t0 = t_in;
    return t_in <= t_out;
}

/* Checks every structural promise of bvh.h for a BVH built over prim boxes lo/hi (NULL for
 * count 0); valid[i] says whether prim i has a finite box. Returns the number of problems. */
int check_structure(const char *what, const rd_bvh *bvh, const float *lo, const float *hi,
                    const bool *valid, uint32_t count, uint32_t max_leaf)
{
    int bad = 0;
#define SCHECK(cond, ...)                                                                          \
    do {                                                                                           \
        if (!(cond)) {                                                                             \
            if (bad < 5)                                                                           \
                fprintf(stderr, "%s: %s: ", what, #cond), fprintf(stderr, __VA_ARGS__),            \
                    fputc('\n', stderr);                                                           \
            bad++;                                                                                 \
        }                                                                                          \
    } while (0)

    SCHECK(bvh->nodes && bvh->node_count >= 1, "no nodes");
    SCHECK(bvh->prim_count == count, "prim_count %u", bvh->prim_count);
    if (bad) return bad;
    if (count == 0) {
        SCHECK(bvh->node_count == 1 && box_empty(&bvh->nodes[0]), "empty BVH root not empty");
        return bad;
    }
    SCHECK(bvh->node_count <= 2 * count - 1, "node_count %u for %u prims", bvh->node_count, count);

    uint32_t *seen_prim = calloc(count, sizeof *seen_prim);
    uint32_t *seen_node = calloc(bvh->node_count, sizeof *seen_node);
    uint32_t *node_depth = calloc(bvh->node_count, sizeof *node_depth);
    uint32_t *stack = malloc(bvh->node_count * sizeof *stack);
    if (!seen_prim || !seen_node || !node_depth || !stack) abort();
    for (uint32_t i = 0; i < count; i++) {
        SCHECK(bvh->prim_index[i] < count, "prim_index[%u] = %u", i, bvh->prim_index[i]);
        if (bvh->prim_index[i] < count) seen_prim[bvh->prim_index[i]]++;
    }
    for (uint32_t i = 0; i < count; i++)
        SCHECK(seen_prim[i] == 1, "prim %u appears %u times in prim_index", i, seen_prim[i]);
    memset(seen_prim, 0, count * sizeof *seen_prim);

    uint32_t sp = 0, max_depth = 0, forced = 0;
    stack[sp++] = 0;
    while (sp > 0 && bad < 50) {
        uint32_t ni = stack[--sp];
        const pc_bvh_node *n = &bvh->nodes[ni];
        seen_node[ni]++;
        SCHECK(seen_node[ni] == 1, "node %u reached twice", ni);
        if (seen_node[ni] != 1) continue;
        uint32_t first = rd_bvh_node_first(n), cnt = rd_bvh_node_count(n);
        uint32_t depth = node_depth[ni];
        max_depth = depth > max_depth ? depth : max_depth;
        if (cnt == 0) {
            SCHECK(first >= 1 && first + 1 < bvh->node_count, "node %u children %u", ni, first);
            if (!(first >= 1 && first + 1 < bvh->node_count)) continue;
            for (uint32_t c = first; c <= first + 1; c++) {
                const pc_bvh_node *ch = &bvh->nodes[c];
                float clo[3] = {ch->bmin.x, ch->bmin.y, ch->bmin.z};
                float chi[3] = {ch->bmax.x, ch->bmax.y, ch->bmax.z};
                SCHECK(box_empty(ch) || box_contains(n, clo, chi),
                       "node %u does not contain child %u", ni, c);
                node_depth[c] = depth + 1;
                stack[sp++] = c;
            }
        } else {
            SCHECK(first + cnt <= count, "leaf %u range %u+%u", ni, first, cnt);
            if (first + cnt > count) continue;
            if (cnt > max_leaf) forced++;
            bool any_valid = false, any_invalid = false;
            for (uint32_t k = first; k < first + cnt; k++) {
                uint32_t p = bvh->prim_index[k];
                seen_prim[k]++;
                if (valid[p]) {
                    any_valid = true;
                    SCHECK(box_contains(n, lo + 3 * (size_t)p, hi + 3 * (size_t)p),
                           "leaf %u does not contain prim %u", ni, p);
                } else {
                    any_invalid = true;
                }
            }
            SCHECK(!(any_valid && any_invalid), "leaf %u mixes finite and non-finite prims", ni);
            SCHECK(!any_invalid || box_empty(n), "leaf %u of non-finite prims has a box", ni);
        }
    }
    for (uint32_t i = 0; i < bvh->node_count; i++)
        SCHECK(seen_node[i] == 1, "node %u reached %u times", i, seen_node[i]);
    for (uint32_t i = 0; i < count; i++)
        SCHECK(seen_prim[i] == 1, "leaf slot %u covered %u times", i, seen_prim[i]);
    SCHECK(max_depth <= RD_BVH_MAX_DEPTH, "depth %u", max_depth);
    SCHECK(max_depth == bvh->depth, "depth %u but bvh->depth %u", max_depth, bvh->depth);
    SCHECK(forced == 0, "%u leaves over max_leaf %u", forced, max_leaf);
    /* Every finite prim lies inside the root box, however the tree looks. */
    for (uint32_t i = 0; i < count; i++) {
        if (valid[i])
            SCHECK(box_contains(&bvh->nodes[0], lo + 3 * (size_t)i, hi + 3 * (size_t)i),
                   "root misses prim %u", i);
    }
    free(seen_prim);
    free(seen_node);
    free(node_depth);
    free(stack);
#undef SCHECK
    return bad;
}

/* Checks a BVH built over triangles against the triangles' boxes; returns the problems. */
int check_triangles(const char *what, const rd_bvh *bvh, const float *pos, uint32_t n,
                    uint32_t max_leaf)
{
    float *lo = malloc((size_t)(n ? n : 1) * 6 * sizeof(float));
    bool *valid = malloc((n ? n : 1) * sizeof(bool));
    if (!lo || !valid) abort();
    float *hi = lo + 3 * (size_t)n;
    for (uint32_t i = 0; i < n; i++) {
        const float *v = pos + 9 * (size_t)i;
        valid[i] = tri_finite(v);
        for (int a = 0; a < 3; a++) {
            lo[3 * i + a] = fminf(v[a], fminf(v[3 + a], v[6 + a]));
            hi[3 * i + a] = fmaxf(v[a], fmaxf(v[3 + a], v[6 + a]));
        }
    }
    int bad = check_structure(what, bvh, lo, hi, valid, n, max_leaf);
    free(lo);
    free(valid);
    return bad;
}

/* Builds over triangles and checks the structure against the triangles' boxes. */
bool build_checked(const char *what, rd_bvh *bvh, const float *pos, uint32_t n,
                   const rd_bvh_options *opt)
{
    bool ok = rd_bvh_build_triangles(bvh, pos, n, opt);
    CHECKF(ok, "%s: build failed", what);
    if (!ok) return false;
    uint32_t max_leaf = opt && opt->max_leaf ? opt->max_leaf : 4;
    int bad = check_triangles(what, bvh, pos, n, max_leaf);
    CHECKF(bad == 0, "%s: %d structural problems", what, bad);
    return true;
}

/* Traces rays against the BVH and brute force: same triangle, or the same t on ties.
 * Returns the number of hits (so callers can check the rays were not all misses). */
uint32_t compare_rays(const char *what, const rd_bvh *bvh, const float *pos, uint32_t n,
                      const float *orgs, const float *dirs, uint32_t ray_count, float tmin,
                      float tmax)
{
    uint32_t hits = 0, mismatches = 0;
    for (uint32_t r = 0; r < ray_count; r++) {
        const float *o = orgs + 3 * (size_t)r, *d = dirs + 3 * (size_t)r;
        float tb = -1, tf = -1;
        int64_t b = rd_bvh_closest_triangle(bvh, pos, o, d, tmin, tmax, &tb);
        int64_t f = brute_closest(pos, n, o, d, tmin, tmax, &tf);
        bool ok = (b < 0 && f < 0) || (b >= 0 && f >= 0 && (b == f || tb == tf));
        if (ok && b >= 0) ok = tb == tf;
        if (f >= 0) {
            hits++;
            CHECKF(tri_finite(pos + 9 * (size_t)f), "%s: brute force hit non-finite tri %lld", what,
                   (long long)f);
        }
        if (!ok) {
            if (mismatches < 5)
                fprintf(stderr,
                        "%s: ray %u o=(%g %g %g) d=(%g %g %g): bvh %lld t=%.9g, brute %lld "
                        "t=%.9g\n",
                        what, r, o[0], o[1], o[2], d[0], d[1], d[2], (long long)b, tb, (long long)f,
                        tf);
            mismatches++;
        }
    }
    CHECKF(mismatches == 0, "%s: %u of %u rays differ from brute force", what, mismatches,
           ray_count);
    return hits;
}

/* Rays from random points of an enlarged box: half aimed at random points of random finite
 * triangles (most hit), a quarter at random points of the scene box, a quarter in random
 * directions. */
void make_rays(float *orgs, float *dirs, uint32_t count, const float lo[3], const float hi[3],
               float margin, const float *pos, uint32_t n)
{
    float ext = 0;
    for (int a = 0; a < 3; a++)
        ext = fmaxf(ext, hi[a] - lo[a]);
    for (uint32_t r = 0; r < count; r++) {
        float *o = orgs + 3 * (size_t)r, *d = dirs + 3 * (size_t)r;
        float target[3];
        for (int a = 0; a < 3; a++) {
            o[a] = rng_range(lo[a] - margin * ext, hi[a] + margin * ext);
            target[a] = rng_range(lo[a], hi[a]);
        }
        const float *v = pos + 9 * (size_t)(rng_u32() % (n ? n : 1));
        if (r % 4 < 2 && n && tri_finite(v)) {
            float w1 = rng_f(), w2 = rng_f() * (1 - w1), w0 = 1 - w1 - w2;
            for (int a = 0; a < 3; a++)
                target[a] = w0 * v[a] + w1 * v[3 + a] + w2 * v[6 + a];
        }
        if (r % 4 == 3) {
            rng_unit(d);
        } else {
            for (int a = 0; a < 3; a++)
                d[a] = target[a] - o[a];
        }
    }
}

/* A random triangle around centre c with vertices within size of it. */
void random_tri(float *v, const float c[3], float size)
{
    for (int k = 0; k < 3; k++)
        for (int a = 0; a < 3; a++)
            v[3 * k + a] = c[a] + rng_range(-size, size);
}

void soup_case(const char *what, float *pos, uint32_t n, uint32_t ray_count,
               const rd_bvh_options *opt, float tmin, uint32_t min_hits)
{
    rd_bvh bvh;
    if (!build_checked(what, &bvh, pos, n, opt)) return;
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t i = 0; i < 3 * n; i++) {
        const float *v = pos + 3 * (size_t)i;
        if (!tri_finite(pos + 9 * (size_t)(i / 3))) continue;
        for (int a = 0; a < 3; a++) {
            lo[a] = fminf(lo[a], v[a]);
            hi[a] = fmaxf(hi[a], v[a]);
        }
    }
    float *orgs = malloc((size_t)ray_count * 6 * sizeof(float));
    if (!orgs) abort();
    float *dirs = orgs + 3 * (size_t)ray_count;
    make_rays(orgs, dirs, ray_count, lo, hi, 0.5f, pos, n);
    uint32_t hits = compare_rays(what, &bvh, pos, n, orgs, dirs, ray_count, tmin, INFINITY);
    CHECKF(hits >= min_hits, "%s: only %u hits of %u rays", what, hits, ray_count);
    free(orgs);
    rd_bvh_destroy(&bvh);
}

void tri_soup(float *pos, uint32_t n, float size)
{
    for (uint32_t i = 0; i < n; i++) {
        float c[3] = {rng_range(-1, 1), rng_range(-1, 1), rng_range(-1, 1)};
        random_tri(pos + 9 * (size_t)i, c, size);
    }
}
