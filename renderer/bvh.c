/* bvh.c: binned-SAH BVH builder, watertight ray/triangle test and CPU traversal.
 *
 * Builder (Wald, "On fast Construction of SAH-based Bounding Volume Hierarchies", 2007):
 * primitives are copied once into an array of {box, centroid, id} records that is partitioned
 * in place level by level, so every pass over a node's range is sequential in memory and no
 * level sorts anything. Each interior node does one binning pass and one partition pass; the
 * partition pass also accumulates both children's boxes and centroid bounds.
 *
 * Axis choice: we bin all three axes in the same pass and take the cheapest split. Binning
 * only the widest centroid axis is ~2x faster per level but loses 5-15% SAH cost on
 * elongated or diagonal geometry; the build stays well inside the 2M-triangles-in-seconds
 * budget with all three, and traversal time is what the renderer pays every frame.
 */
#include "bvh.h"

#include <assert.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define BVH_MAX_BINS 64
/* SAH constants: one traversal step (two box tests) costs about as much as one watertight
 * triangle test on the GPU. */
#define SAH_TRAVERSAL 1.0
#define SAH_INTERSECT 1.0
/* Ize, "Robust BVH Ray Traversal" (JCGT 2013): scaling the far slab distance by 1 + 2*gamma(3)
 * makes the float slab test conservative. */
#define BOX_TFAR_SCALE 1.0000004f
/* Boxes are culled against the closest hit plus this relative slack: a triangle's computed t
 * can lie a few ulps before the entry distance of its own (conservative) box, so culling at
 * exactly t_best could lose a coplanar, overlapping triangle that brute force returns. */
#define CULL_SLACK (1.0f / 65536.0f)

typedef struct bvh_prim {
    float lo[3], hi[3];
    float c[3];
    uint32_t id;
} bvh_prim;

typedef struct bvh_bounds {
    float lo[3], hi[3];   /* box */
    float clo[3], chi[3]; /* centroid bounds */
} bvh_bounds;

typedef struct bvh_bin {
    float lo[3], hi[3];
    uint32_t count;
} bvh_bin;

typedef struct bvh_builder {
    bvh_prim *p;
    pc_bvh_node *nodes;
    uint32_t node_count;
    uint32_t node_cap;
    uint32_t bins;
    uint32_t max_leaf;
    uint32_t depth;
    bvh_bin bin[3][BVH_MAX_BINS];
} bvh_builder;


uint32_t rd_bvh_node_first(const pc_bvh_node *n)
{
    return pc_f2u(n->bmin.w);
}

uint32_t rd_bvh_node_count(const pc_bvh_node *n)
{
    return pc_f2u(n->bmax.w);
}

static void node_set(pc_bvh_node *n, const float lo[3], const float hi[3], uint32_t first,
                     uint32_t count)
{
    n->bmin.x = lo[0];
    n->bmin.y = lo[1];
    n->bmin.z = lo[2];
    n->bmax.x = hi[0];
    n->bmax.y = hi[1];
    n->bmax.z = hi[2];
    n->bmin.w = pc_u2f(first);
    n->bmax.w = pc_u2f(count);
}

/* ---- bounds ---------------------------------------------------------------------------- */

static void bounds_empty(bvh_bounds *b)
{
    for (int a = 0; a < 3; a++) {
        b->lo[a] = b->clo[a] = INFINITY;
        b->hi[a] = b->chi[a] = -INFINITY;
    }
}

static inline void bounds_add(bvh_bounds *b, const bvh_prim *p)
{
    for (int a = 0; a < 3; a++) {
        b->lo[a] = p->lo[a] < b->lo[a] ? p->lo[a] : b->lo[a];
        b->hi[a] = p->hi[a] > b->hi[a] ? p->hi[a] : b->hi[a];
        b->clo[a] = p->c[a] < b->clo[a] ? p->c[a] : b->clo[a];
        b->chi[a] = p->c[a] > b->chi[a] ? p->c[a] : b->chi[a];
    }
}

static void bounds_of(const bvh_prim *p, uint32_t begin, uint32_t end, bvh_bounds *b)
{
    bounds_empty(b);
    for (uint32_t i = begin; i < end; i++)
        bounds_add(b, &p[i]);
}

/* Half surface area in double: extents up to 2 * FLT_MAX must not overflow. Empty -> 0. */
static double half_area(const float lo[3], const float hi[3])
{
    if (!(lo[0] <= hi[0] && lo[1] <= hi[1] && lo[2] <= hi[2])) return 0.0;
    double dx = (double)hi[0] - lo[0], dy = (double)hi[1] - lo[1], dz = (double)hi[2] - lo[2];
    return dx * dy + dy * dz + dz * dx;
}

/* ---- splits ---------------------------------------------------------------------------- */

/* Bin of a centroid coordinate; binning and partitioning call the same function. */
static inline uint32_t bin_of(float c, double cmin, double scale, uint32_t bins)
{
    double f = ((double)c - cmin) * scale;
    uint32_t b = f > 0.0 ? (uint32_t)f : 0u;
    return b < bins ? b : bins - 1;
}

/* Partitions [begin, end) in place so that prims whose bin is below split come first, and
 * accumulates the bounds of both sides on the way. Returns the first index of the right side. */
static uint32_t partition_bins(bvh_prim *p, uint32_t begin, uint32_t end, int axis, double cmin,
                               double scale, uint32_t bins, uint32_t split, bvh_bounds *left,
                               bvh_bounds *right)
{
    uint32_t i = begin, j = end;
    bounds_empty(left);
    bounds_empty(right);
    while (i < j) {
        if (bin_of(p[i].c[axis], cmin, scale, bins) < split) {
            bounds_add(left, &p[i]);
            i++;
        } else {
            j--;
            bvh_prim tmp = p[i];
            p[i] = p[j];
            p[j] = tmp;
            bounds_add(right, &p[j]);
        }
    }
    return i;
}

/* nth_element on the centroid coordinate (Hoare partition, Wirth's selection): afterwards every
 * prim before k has c[axis] <= every prim from k on. Equal keys split evenly. */
static void select_nth(bvh_prim *p, uint32_t begin, uint32_t end, uint32_t k, int axis)
{
    int64_t l = begin, r = (int64_t)end - 1;
    while (l < r) {
        float x = p[k].c[axis];
        int64_t i = l, j = r;
        do {
            while (p[i].c[axis] < x)
                i++;
            while (x < p[j].c[axis])
                j--;
            if (i <= j) {
                bvh_prim tmp = p[i];
                p[i] = p[j];
                p[j] = tmp;
                i++;
                j--;
            }
        } while (i <= j);
        if (j < k) l = i;
        if (k < i) r = j;
    }
}

/* Levels of halving needed until n prims fit in leaves of max_leaf. */
static uint32_t levels_needed(uint32_t n, uint32_t max_leaf)
{
    uint32_t levels = 0;
    uint64_t m = max_leaf;
    while (m < n) {
        m *= 2;
        levels++;
    }
    return levels;
}

typedef struct sah_split {
    int axis;
    uint32_t bin; /* prims in bins < bin go left */
    double cost;  /* C_trav * A + sum(A_side * N_side) * C_isect (unnormalised) */
    uint32_t imbalance;
    uint32_t bins; /* bins used for this node */
} sah_split;

/* Bins [begin, end) along every axis with a non-zero centroid extent and returns the
 * cheapest split; axis = -1 when every centroid coincides. cmin/scale receive the binning
 * parameters for partition_bins. */
static sah_split find_sah_split(bvh_builder *b, uint32_t begin, uint32_t end, const bvh_bounds *bd,
                                double cmin[3], double scale[3])
{
    /* Small nodes use fewer bins: resetting and sweeping 3 x 16 mostly empty bins would
     * dominate the build (half the nodes hold fewer than 8 prims). */
    const uint32_t bins = end - begin < b->bins ? (end - begin < 4 ? 4 : end - begin) : b->bins;
    bool use[3];
    for (int a = 0; a < 3; a++) {
        double extent = (double)bd->chi[a] - bd->clo[a];
        use[a] = extent > 0.0;
        cmin[a] = bd->clo[a];
        /* (1 - 1e-6) keeps the largest centroid in the last bin. */
        scale[a] = use[a] ? (double)bins * (1.0 - 1e-6) / extent : 0.0;
        for (uint32_t i = 0; i < bins; i++) {
            bvh_bin *bn = &b->bin[a][i];
            bn->count = 0;
            for (int k = 0; k < 3; k++) {
                bn->lo[k] = INFINITY;
                bn->hi[k] = -INFINITY;
            }
        }
    }
    sah_split best = {
        .axis = -1, .bin = 0, .cost = INFINITY, .imbalance = UINT32_MAX, .bins = bins};
    if (!use[0] && !use[1] && !use[2]) return best;

    for (uint32_t i = begin; i < end; i++) {
        const bvh_prim *q = &b->p[i];
        for (int a = 0; a < 3; a++) {
            if (!use[a]) continue;
            bvh_bin *bn = &b->bin[a][bin_of(q->c[a], cmin[a], scale[a], bins)];
            bn->count++;
            for (int k = 0; k < 3; k++) {
                bn->lo[k] = q->lo[k] < bn->lo[k] ? q->lo[k] : bn->lo[k];
                bn->hi[k] = q->hi[k] > bn->hi[k] ? q->hi[k] : bn->hi[k];
            }
        }
    }

    const double parent_area = half_area(bd->lo, bd->hi);
    for (int a = 0; a < 3; a++) {
        if (!use[a]) continue;
        double right_cost[BVH_MAX_BINS];
        uint32_t right_count[BVH_MAX_BINS];
        float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        uint32_t n = 0;
        for (uint32_t i = bins - 1; i > 0; i--) { /* right side = bins [i, bins) */
            const bvh_bin *bn = &b->bin[a][i];
            for (int k = 0; k < 3; k++) {
                lo[k] = bn->lo[k] < lo[k] ? bn->lo[k] : lo[k];
                hi[k] = bn->hi[k] > hi[k] ? bn->hi[k] : hi[k];
            }
            n += bn->count;
            right_count[i] = n;
            right_cost[i] = half_area(lo, hi) * n;
        }
        for (int k = 0; k < 3; k++) {
            lo[k] = INFINITY;
            hi[k] = -INFINITY;
        }
        n = 0;
        for (uint32_t i = 1; i < bins; i++) { /* left side = bins [0, i) */
            const bvh_bin *bn = &b->bin[a][i - 1];
            for (int k = 0; k < 3; k++) {
                lo[k] = bn->lo[k] < lo[k] ? bn->lo[k] : lo[k];
                hi[k] = bn->hi[k] > hi[k] ? bn->hi[k] : hi[k];
            }
            n += bn->count;
            if (n == 0 || right_count[i] == 0) continue;
            double cost = SAH_TRAVERSAL * parent_area +
                          SAH_INTERSECT * (half_area(lo, hi) * n + right_cost[i]);
            uint32_t imbalance = n > right_count[i] ? n - right_count[i] : right_count[i] - n;
            /* Ties (e.g. flat parents with zero area) go to the most balanced split. */
            if (cost < best.cost || (cost == best.cost && imbalance < best.imbalance)) {
                best.axis = a;
                best.bin = i;
                best.cost = cost;
                best.imbalance = imbalance;
            }
        }
    }
    return best;
}

/* ---- recursive build -------------------------------------------------------------------- */

static void make_leaf(bvh_builder *b, uint32_t ni, const bvh_bounds *bd, uint32_t begin,
                      uint32_t end, uint32_t depth)
{
    node_set(&b->nodes[ni], bd->lo, bd->hi, begin, end - begin);
    if (depth > b->depth) b->depth = depth;
}

/* Builds node ni over [begin, end) whose bounds are bd, at the given depth; the subtree may
 * not go deeper than cap. index_median: split by index only (the non-finite prims). */
static void build_node(bvh_builder *b, uint32_t ni, uint32_t begin, uint32_t end,
                       const bvh_bounds *bd, uint32_t depth, uint32_t cap, bool index_median)
{
    const uint32_t n = end - begin;
    if (n == 1 || depth >= cap) {
        make_leaf(b, ni, bd, begin, end, depth);
        return;
    }

    bvh_bounds left, right;
    uint32_t mid = 0;
    bool median = index_median;
    bool centroids_coincide =
        bd->clo[0] == bd->chi[0] && bd->clo[1] == bd->chi[1] && bd->clo[2] == bd->chi[2];
    if (centroids_coincide) median = true;
    /* Near the cap, SAH splits (possibly 1 : n-1) could leave a child that cannot reach
     * max_leaf in the levels left: switch to median splits, which halve n every level. */
    bool near_cap = depth + 1 + levels_needed(n, b->max_leaf) > cap;

    if (median) {
        if (n <= b->max_leaf) {
            make_leaf(b, ni, bd, begin, end, depth);
            return;
        }
        mid = begin + n / 2;
        bounds_of(b->p, begin, mid, &left);
        bounds_of(b->p, mid, end, &right);
    } else if (near_cap) {
        if (n <= b->max_leaf) {
            make_leaf(b, ni, bd, begin, end, depth);
            return;
        }
        int axis = 0;
        double best = -1.0;
        for (int a = 0; a < 3; a++) {
            double extent = (double)bd->chi[a] - bd->clo[a];
            if (extent > best) {
                best = extent;
                axis = a;
            }
        }
        mid = begin + n / 2;
        select_nth(b->p, begin, end, mid, axis);
        bounds_of(b->p, begin, mid, &left);
        bounds_of(b->p, mid, end, &right);
    } else {
        double cmin[3], scale[3];
        sah_split s = find_sah_split(b, begin, end, bd, cmin, scale);
        assert(s.axis >= 0); /* centroids do not coincide, so some axis has two bins in use */
        double leaf_cost = SAH_INTERSECT * half_area(bd->lo, bd->hi) * n;
        if (n <= b->max_leaf && s.cost >= leaf_cost) {
            make_leaf(b, ni, bd, begin, end, depth);
            return;
        }
        mid = partition_bins(b->p, begin, end, s.axis, cmin[s.axis], scale[s.axis], s.bins, s.bin,
                             &left, &right);
        assert(mid > begin && mid < end);
    }

    assert(b->node_count + 2 <= b->node_cap);
    uint32_t c = b->node_count;
    b->node_count += 2;
    node_set(&b->nodes[ni], bd->lo, bd->hi, c, 0);
    build_node(b, c, begin, mid, &left, depth + 1, cap, index_median);
    build_node(b, c + 1, mid, end, &right, depth + 1, cap, index_median);
}

static bool box_valid(const float lo[3], const float hi[3])
{
    for (int a = 0; a < 3; a++) {
        if (!isfinite(lo[a]) || !isfinite(hi[a]) || !(lo[a] <= hi[a])) return false;
    }
    return true;
}

/* Widens a finite box by one ulp outwards, and to at least +-FLT_MIN around zero (so that
 * devices flushing denormals to zero keep the widening). Empty boxes stay as they are. */
static void widen_node(pc_bvh_node *n)
{
    float lo[3] = {n->bmin.x, n->bmin.y, n->bmin.z};
    float hi[3] = {n->bmax.x, n->bmax.y, n->bmax.z};
    if (!(lo[0] <= hi[0] && lo[1] <= hi[1] && lo[2] <= hi[2])) return;
    for (int a = 0; a < 3; a++) {
        float l = nextafterf(lo[a], -INFINITY), h = nextafterf(hi[a], INFINITY);
        if (fabsf(l) < FLT_MIN) l = -FLT_MIN;
        if (fabsf(h) < FLT_MIN) h = FLT_MIN;
        lo[a] = l;
        hi[a] = h;
    }
    n->bmin.x = lo[0];
    n->bmin.y = lo[1];
    n->bmin.z = lo[2];
    n->bmax.x = hi[0];
    n->bmax.y = hi[1];
    n->bmax.z = hi[2];
}

bool rd_bvh_build(rd_bvh *bvh, const float *bmin, const float *bmax, uint32_t count,
                  const rd_bvh_options *opt)
{
    memset(bvh, 0, sizeof *bvh);
    rd_bvh_options o = opt ? *opt : (rd_bvh_options){0};
    uint32_t bins = o.bins ? o.bins : 16;
    bins = bins < 2 ? 2 : bins > BVH_MAX_BINS ? BVH_MAX_BINS : bins;
    uint32_t max_leaf = o.max_leaf ? o.max_leaf : 4;
    max_leaf = max_leaf > RD_BVH_MAX_LEAF ? RD_BVH_MAX_LEAF : max_leaf;

    bvh_builder *b = calloc(1, sizeof *b);
    if (!b) return false;
    b->bins = bins;
    b->max_leaf = max_leaf;
    b->node_cap = count ? 2 * count : 1;
    b->nodes = malloc((size_t)b->node_cap * sizeof *b->nodes);
    b->p = count ? malloc((size_t)count * sizeof *b->p) : NULL;
    bvh->prim_index = malloc((size_t)(count ? count : 1) * sizeof *bvh->prim_index);
    if (!b->nodes || (count && !b->p) || !bvh->prim_index) {
        free(b->nodes);
        free(b->p);
        free(b);
        free(bvh->prim_index);
        bvh->prim_index = NULL;
        return false;
    }

    /* Valid prims fill the array from the front, non-finite ones from the back. */
    uint32_t valid = 0, invalid_at = count;
    for (uint32_t i = 0; i < count; i++) {
        const float *lo = bmin + 3 * (size_t)i, *hi = bmax + 3 * (size_t)i;
        bvh_prim *q;
        if (box_valid(lo, hi)) {
            q = &b->p[valid++];
            for (int a = 0; a < 3; a++) {
                q->lo[a] = lo[a];
                q->hi[a] = hi[a];
                q->c[a] = 0.5f * lo[a] + 0.5f * hi[a]; /* no overflow near FLT_MAX */
            }
        } else {
            q = &b->p[--invalid_at];
            for (int a = 0; a < 3; a++) {
                q->lo[a] = INFINITY;
                q->hi[a] = -INFINITY;
                q->c[a] = 0.0f;
            }
        }
        q->id = i;
    }
    /* The back was filled in reverse; restore input order among the non-finite prims. */
    for (uint32_t i = valid, j = count; i + 1 < j; i++, j--) {
        bvh_prim tmp = b->p[i];
        b->p[i] = b->p[j - 1];
        b->p[j - 1] = tmp;
    }

    b->node_count = 1;
    bvh_bounds all;
    if (count == 0) {
        bounds_empty(&all);
        node_set(&b->nodes[0], all.lo, all.hi, 0, 0);
    } else if (valid == 0 || valid == count) {
        bounds_of(b->p, 0, count, &all);
        build_node(b, 0, 0, count, &all, 0, RD_BVH_MAX_DEPTH, valid == 0);
    } else {
        /* Root: left = finite prims (SAH), right = non-finite prims (empty box, by index). */
        bvh_bounds vb, ib;
        bounds_of(b->p, 0, valid, &vb);
        bounds_of(b->p, valid, count, &ib);
        b->node_count = 3;
        node_set(&b->nodes[0], vb.lo, vb.hi, 1, 0);
        build_node(b, 1, 0, valid, &vb, 1, RD_BVH_MAX_DEPTH, false);
        build_node(b, 2, valid, count, &ib, 1, RD_BVH_MAX_DEPTH, true);
    }

    for (uint32_t i = 0; i < b->node_count; i++)
        widen_node(&b->nodes[i]);
    for (uint32_t i = 0; i < count; i++)
        bvh->prim_index[i] = b->p[i].id;

    pc_bvh_node *shrunk = realloc(b->nodes, (size_t)b->node_count * sizeof *b->nodes);
    bvh->nodes = shrunk ? shrunk : b->nodes;
    bvh->node_count = b->node_count;
    bvh->prim_count = count;
    bvh->depth = b->depth;
    free(b->p);
    free(b);
    return true;
}

bool rd_bvh_build_triangles(rd_bvh *bvh, const float *positions, uint32_t tri_count,
                            const rd_bvh_options *opt)
{
    float *lo = malloc((size_t)(tri_count ? tri_count : 1) * 6 * sizeof(float));
    if (!lo) {
        memset(bvh, 0, sizeof *bvh);
        return false;
    }
    float *hi = lo + 3 * (size_t)tri_count;
    for (uint32_t i = 0; i < tri_count; i++) {
        const float *v = positions + 9 * (size_t)i;
        bool finite = true;
        for (int k = 0; k < 9; k++)
            finite = finite && isfinite(v[k]);
        for (int a = 0; a < 3; a++) {
            float l = v[a], h = v[a];
            for (int k = 1; k < 3; k++) {
                l = v[3 * k + a] < l ? v[3 * k + a] : l;
                h = v[3 * k + a] > h ? v[3 * k + a] : h;
            }
            lo[3 * (size_t)i + a] = finite ? l : INFINITY;
            hi[3 * (size_t)i + a] = finite ? h : -INFINITY;
        }
    }
    bool ok = rd_bvh_build(bvh, lo, hi, tri_count, opt);
    free(lo);
    return ok;
}

void rd_bvh_destroy(rd_bvh *bvh)
{
    if (!bvh) return;
    free(bvh->nodes);
    free(bvh->prim_index);
    memset(bvh, 0, sizeof *bvh);
}

/* ---- ray / triangle ------------------------------------------------------------------------ */

/* Per-ray part of the watertight test: kz is the dominant direction axis; kx, ky are swapped
 * when dir[kz] < 0 to keep the winding; S shears the ray to +z (Woop et al. 2013, sec. 3). */
typedef struct ray_shear {
    int kx, ky, kz;
    float sx, sy, sz;
} ray_shear;

static void shear_init(const float dir[3], ray_shear *s)
{
    float ax = fabsf(dir[0]), ay = fabsf(dir[1]), az = fabsf(dir[2]);
    int kz = ax >= ay ? (ax >= az ? 0 : 2) : (ay >= az ? 1 : 2);
    int kx = kz == 2 ? 0 : kz + 1;
    int ky = kx == 2 ? 0 : kx + 1;
    if (dir[kz] < 0.0f) {
        int t = kx;
        kx = ky;
        ky = t;
    }
    s->kx = kx;
    s->ky = ky;
    s->kz = kz;
    s->sx = dir[kx] / dir[kz];
    s->sy = dir[ky] / dir[kz];
    s->sz = 1.0f / dir[kz];
}

/* Woop, Benthin, Wald, "Watertight Ray/Triangle Intersection", JCGT 2(1), 2013, fig. 2/3.
 * Front = counter-clockwise: det > 0 exactly when dot(dir, cross(v1-v0, v2-v0)) < 0. */
static bool tri_hit(const ray_shear *s, const float org[3], const float v0[3], const float v1[3],
                    const float v2[3], float tmin, float tmax, float *t_out, float *u_out,
                    float *v_out, bool *back_out)
{
    const int kx = s->kx, ky = s->ky, kz = s->kz;
    float A[3] = {v0[0] - org[0], v0[1] - org[1], v0[2] - org[2]};
    float B[3] = {v1[0] - org[0], v1[1] - org[1], v1[2] - org[2]};
    float C[3] = {v2[0] - org[0], v2[1] - org[1], v2[2] - org[2]};
    float Ax = A[kx] - s->sx * A[kz], Ay = A[ky] - s->sy * A[kz];
    float Bx = B[kx] - s->sx * B[kz], By = B[ky] - s->sy * B[kz];
    float Cx = C[kx] - s->sx * C[kz], Cy = C[ky] - s->sy * C[kz];
    float U = Cx * By - Cy * Bx;
    float V = Ax * Cy - Ay * Cx;
    float W = Bx * Ay - By * Ax;
    /* An edge function that is exactly 0 may be a rounding artefact: redo all three in
     * double, where the products of floats are exact (paper, sec. 3.3). */
    if (U == 0.0f || V == 0.0f || W == 0.0f) {
        U = (float)((double)Cx * By - (double)Cy * Bx);
        V = (float)((double)Ax * Cy - (double)Ay * Cx);
        W = (float)((double)Bx * Ay - (double)By * Ax);
    }
    if ((U < 0.0f || V < 0.0f || W < 0.0f) && (U > 0.0f || V > 0.0f || W > 0.0f)) return false;
    float det = U + V + W;
    if (det == 0.0f || !(fabsf(det) <= FLT_MAX)) /* also rejects NaN/Inf vertices */
        return false;
    float Az = s->sz * A[kz], Bz = s->sz * B[kz], Cz = s->sz * C[kz];
    float T = U * Az + V * Bz + W * Cz;
    float rcp = 1.0f / det;
    float t = T * rcp;
    if (!(t > tmin && t < tmax)) return false;
    *t_out = t;
    *u_out = V * rcp;
    *v_out = W * rcp;
    *back_out = det < 0.0f;
    return true;
}

bool rd_ray_triangle(const float org[3], const float dir[3], const float v0[3], const float v1[3],
                     const float v2[3], float tmin, float tmax, float *t, float *u, float *v,
                     bool *backface)
{
    ray_shear s;
    shear_init(dir, &s);
    return tri_hit(&s, org, v0, v1, v2, tmin, tmax, t, u, v, backface);
}

/* ---- offset ---------------------------------------------------------------------------------- */

void rd_offset_ray_origin(const float p[3], const float n[3], float out[3])
{
    const float origin = 1.0f / 32.0f, float_scale = 1.0f / 65536.0f, int_scale = 256.0f;
    for (int a = 0; a < 3; a++) {
        float s = int_scale * n[a];
        int32_t of = (s > -1e9f && s < 1e9f) ? (int32_t)s : 0; /* NaN normal -> no offset */
        /* Integer add on the bit pattern (in uint32 so wrap-around is defined); for a
         * negative p the offset is negated so the point still moves along n. */
        uint32_t bits = pc_f2u(p[a]) + (uint32_t)(p[a] < 0.0f ? -of : of);
        out[a] = fabsf(p[a]) < origin ? p[a] + float_scale * n[a] : pc_u2f(bits);
    }
}

/* ---- CPU traversal ----------------------------------------------------------------------------
 */

typedef struct ray_box {
    float org[3];
    float inv[3];
    int neg[3];
} ray_box;

/* NaN-ignoring max/min: x NaN -> acc (acc starts at tmin/tmax, never NaN). */
static inline float max_nn(float x, float acc)
{
    return x > acc ? x : acc;
}

static inline float min_nn(float x, float acc)
{
    return x < acc ? x : acc;
}

/* Slab test (Williams et al. 2005 with Ize 2013's conservative far scale): near/far planes
 * chosen by the direction sign, so inverted (empty) boxes are always rejected; a zero
 * direction component gives +-inf reciprocals, and the NaN of 0 * inf is ignored. */
static bool box_hit(const ray_box *r, const pc_bvh_node *n, float tmin, float tmax, float *tnear)
{
    const float lo[3] = {n->bmin.x, n->bmin.y, n->bmin.z};
    const float hi[3] = {n->bmax.x, n->bmax.y, n->bmax.z};
    float tn = tmin, tf = INFINITY;
    for (int a = 0; a < 3; a++) {
        float near_plane = r->neg[a] ? hi[a] : lo[a];
        float far_plane = r->neg[a] ? lo[a] : hi[a];
        tn = max_nn((near_plane - r->org[a]) * r->inv[a], tn);
        tf = min_nn((far_plane - r->org[a]) * r->inv[a], tf);
    }
    tf = min_nn(tf * BOX_TFAR_SCALE, tmax);
    *tnear = tn;
    return tn <= tf;
}

int64_t rd_bvh_closest_triangle(const rd_bvh *bvh, const float *positions, const float org[3],
                                const float dir[3], float tmin, float tmax, float *t_out)
{
    if (!bvh->nodes || bvh->node_count == 0) return -1;
    for (int a = 0; a < 3; a++) {
        if (!isfinite(org[a]) || !isfinite(dir[a])) return -1;
    }
    ray_box r;
    for (int a = 0; a < 3; a++) {
        r.org[a] = org[a];
        r.inv[a] = 1.0f / dir[a];
        r.neg[a] = r.inv[a] < 0.0f;
    }
    ray_shear s;
    shear_init(dir, &s);

    float best = tmax, cull = tmax, tn0, tn1;
    int64_t hit = -1;
    if (!box_hit(&r, &bvh->nodes[0], tmin, best, &tn0)) return -1;

    struct {
        uint32_t node;
        float tnear;
    } stack[PC_BVH_STACK_SIZE];
    int sp = 0;
    uint32_t node = 0;
    for (;;) {
        const pc_bvh_node *n = &bvh->nodes[node];
        uint32_t first = rd_bvh_node_first(n), count = rd_bvh_node_count(n);
        bool descend = false;
        if (count == 0) {
            assert(first + 1 < bvh->node_count);
            bool h0 = box_hit(&r, &bvh->nodes[first], tmin, cull, &tn0);
            bool h1 = box_hit(&r, &bvh->nodes[first + 1], tmin, cull, &tn1);
            if (h0 && h1) {
                bool swap = tn1 < tn0;
                assert(sp < PC_BVH_STACK_SIZE);
                stack[sp].node = swap ? first : first + 1;
                stack[sp].tnear = swap ? tn0 : tn1;
                sp++;
                node = swap ? first + 1 : first;
                descend = true;
            } else if (h0 || h1) {
                node = h0 ? first : first + 1;
                descend = true;
            }
        } else {
            for (uint32_t i = first; i < first + count; i++) {
                uint32_t tri = bvh->prim_index[i];
                const float *v = positions + 9 * (size_t)tri;
                float t, u, vv;
                bool back;
                if (tri_hit(&s, org, v, v + 3, v + 6, tmin, best, &t, &u, &vv, &back)) {
                    best = t;
                    cull = t + fabsf(t) * CULL_SLACK;
                    hit = tri;
                }
            }
        }
        if (descend) continue;
        /* Pop, skipping nodes entered farther than the closest hit so far. */
        for (;;) {
            if (sp == 0) {
                if (hit >= 0 && t_out) *t_out = best;
                return hit;
            }
            sp--;
            if (stack[sp].tnear <= cull) break;
        }
        node = stack[sp].node;
    }
}
