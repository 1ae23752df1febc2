/* bvh_internal.h: what the BVH builders (bvh_build.c, bvh_build_ref.c) and bvh.c share: the
 * SAH constants, option defaults, the split rules and the node box rules. Both builders call
 * these, so they take the same split decisions; they differ in memory layout and threading.
 * Not part of the renderer's API. */
#ifndef RD_BVH_INTERNAL_H
#define RD_BVH_INTERNAL_H

#include <float.h>
#include <math.h>
#include <stdbool.h>
#include <stdint.h>

#include "renderer/accel/bvh.h"

#define BVH_MAX_BINS 64
#define BVH_DEFAULT_BINS 16
#define BVH_DEFAULT_MAX_LEAF 4
/* SAH constants: one traversal step (two box tests) costs about as much as one watertight
 * triangle test on the GPU. */
#define SAH_TRAVERSAL 1.0
#define SAH_INTERSECT 1.0

/* Lane 3 of each array is padding for 4-wide updates (its value means nothing). */
typedef struct bvh_bounds {
    float lo[4], hi[4];   /* box */
    float clo[4], chi[4]; /* centroid bounds */
} bvh_bounds;

/* A bin's box and count; lane 3 of lo/hi is padding that lets the multi-threaded builder
 * update a box with 4-wide min/max (its value means nothing). */
typedef struct bvh_bin {
    float lo[4], hi[4];
    uint32_t count;
} bvh_bin;

typedef struct sah_split {
    int axis;
    uint32_t bin; /* prims in bins < bin go left */
    double cost;  /* C_trav * A + sum(A_side * N_side) * C_isect (unnormalised) */
    uint32_t imbalance;
    uint32_t bins; /* bins used for this node */
} sah_split;

/* Options with defaults filled in and clamped. */
static inline void bvh_resolve_options(const rd_bvh_options *opt, uint32_t *bins,
                                       uint32_t *max_leaf)
{
    rd_bvh_options o = opt ? *opt : (rd_bvh_options){0};
    uint32_t b = o.bins ? o.bins : BVH_DEFAULT_BINS;
    *bins = b < 2 ? 2 : b > BVH_MAX_BINS ? BVH_MAX_BINS : b;
    uint32_t l = o.max_leaf ? o.max_leaf : BVH_DEFAULT_MAX_LEAF;
    *max_leaf = l > RD_BVH_MAX_LEAF ? RD_BVH_MAX_LEAF : l;
}

static inline void bvh_node_set(pc_bvh_node *n, const float lo[3], const float hi[3],
                                uint32_t first, uint32_t count)
{
    n->bmin = (pc_vec4){lo[0], lo[1], lo[2], pc_u2f(first)};
    n->bmax = (pc_vec4){hi[0], hi[1], hi[2], pc_u2f(count)};
}

static inline void bvh_bounds_empty(bvh_bounds *b)
{
    for (int a = 0; a < 4; a++) {
        b->lo[a] = b->clo[a] = INFINITY;
        b->hi[a] = b->chi[a] = -INFINITY;
    }
}

/* Union of two bounds (min/max are exact, so any merge order gives the same bits). */
static inline void bvh_bounds_merge(bvh_bounds *b, const bvh_bounds *o)
{
    for (int a = 0; a < 3; a++) {
        b->lo[a] = o->lo[a] < b->lo[a] ? o->lo[a] : b->lo[a];
        b->hi[a] = o->hi[a] > b->hi[a] ? o->hi[a] : b->hi[a];
        b->clo[a] = o->clo[a] < b->clo[a] ? o->clo[a] : b->clo[a];
        b->chi[a] = o->chi[a] > b->chi[a] ? o->chi[a] : b->chi[a];
    }
}

/* Half surface area in double: extents up to 2 * FLT_MAX must not overflow. Empty -> 0. */
static inline double bvh_half_area(const float lo[3], const float hi[3])
{
    if (!(lo[0] <= hi[0] && lo[1] <= hi[1] && lo[2] <= hi[2])) return 0.0;
    double dx = (double)hi[0] - lo[0], dy = (double)hi[1] - lo[1], dz = (double)hi[2] - lo[2];
    return dx * dy + dy * dz + dz * dx;
}

/* Centroid of a primitive box (no overflow near FLT_MAX). */
static inline float bvh_centroid(float lo, float hi)
{
    return 0.5f * lo + 0.5f * hi;
}

/* Bin of a centroid coordinate; binning and partitioning call the same function. */
static inline uint32_t bvh_bin_of(float c, double cmin, double scale, uint32_t bins)
{
    double f = ((double)c - cmin) * scale;
    uint32_t b = f > 0.0 ? (uint32_t)f : 0u;
    return b < bins ? b : bins - 1;
}

/* Bins used for a node of n prims: small nodes use fewer, since resetting and sweeping
 * 3 x 16 mostly empty bins would dominate the build (half the nodes hold fewer than 8). */
static inline uint32_t bvh_node_bins(uint32_t n, uint32_t bins)
{
    return n < bins ? (n < 4 ? 4 : n) : bins;
}

/* Binning parameters of a node: use[a] when the centroid extent along a is non-zero;
 * bvh_bin_of(c, cmin[a], scale[a], bins) is the bin. Returns whether any axis is usable. */
static inline bool bvh_bin_params(const bvh_bounds *bd, uint32_t bins, bool use[3], double cmin[3],
                                  double scale[3])
{
    for (int a = 0; a < 3; a++) {
        double extent = (double)bd->chi[a] - bd->clo[a];
        use[a] = extent > 0.0;
        cmin[a] = bd->clo[a];
        /* (1 - 1e-6) keeps the largest centroid in the last bin. */
        scale[a] = use[a] ? (double)bins * (1.0 - 1e-6) / extent : 0.0;
    }
    return use[0] || use[1] || use[2];
}

static inline void bvh_bins_reset(bvh_bin bin[3][BVH_MAX_BINS], uint32_t bins)
{
    for (int a = 0; a < 3; a++)
        for (uint32_t i = 0; i < bins; i++)
            bin[a][i] = (bvh_bin){{INFINITY, INFINITY, INFINITY, INFINITY},
                                  {-INFINITY, -INFINITY, -INFINITY, -INFINITY},
                                  0};
}

/* Adds bin set o into b. */
static inline void bvh_bins_merge(bvh_bin b[3][BVH_MAX_BINS], const bvh_bin o[3][BVH_MAX_BINS],
                                  uint32_t bins)
{
    for (int a = 0; a < 3; a++)
        for (uint32_t i = 0; i < bins; i++) {
            bvh_bin *x = &b[a][i];
            const bvh_bin *y = &o[a][i];
            x->count += y->count;
            for (int k = 0; k < 3; k++) {
                x->lo[k] = y->lo[k] < x->lo[k] ? y->lo[k] : x->lo[k];
                x->hi[k] = y->hi[k] > x->hi[k] ? y->hi[k] : x->hi[k];
            }
        }
}

/* Cheapest split over filled bins (Wald 2007); axis = -1 when no axis separates. */
sah_split bvh_sweep_bins(const bvh_bin bin[3][BVH_MAX_BINS], const bool use[3], uint32_t bins,
                         const bvh_bounds *bd);

/* Levels of halving needed until n prims fit in leaves of max_leaf. */
static inline uint32_t bvh_levels_needed(uint32_t n, uint32_t max_leaf)
{
    uint32_t levels = 0;
    uint64_t m = max_leaf;
    while (m < n) {
        m *= 2;
        levels++;
    }
    return levels;
}

static inline bool bvh_box_valid(const float lo[3], const float hi[3])
{
    for (int a = 0; a < 3; a++) {
        if (!isfinite(lo[a]) || !isfinite(hi[a]) || !(lo[a] <= hi[a])) return false;
    }
    return true;
}

/* Box of triangle v (9 floats); any non-finite vertex gives the empty box [+inf, -inf]. */
static inline void bvh_triangle_box(const float *v, float lo[3], float hi[3])
{
    bool finite = true;
    for (int k = 0; k < 9; k++)
        finite = finite && isfinite(v[k]);
    for (int a = 0; a < 3; a++) {
        float l = v[a], h = v[a];
        for (int k = 1; k < 3; k++) {
            l = v[3 * k + a] < l ? v[3 * k + a] : l;
            h = v[3 * k + a] > h ? v[3 * k + a] : h;
        }
        lo[a] = finite ? l : INFINITY;
        hi[a] = finite ? h : -INFINITY;
    }
}

/* Widens a finite node box by one ulp outwards, and to at least +-FLT_MIN around zero (so
 * that devices flushing denormals to zero keep the widening). Empty boxes stay as they are. */
void bvh_widen_node(pc_bvh_node *n);

#endif
