/* bvh_build_ref.c: the single-threaded recursive binned-SAH builder that rd_bvh_build
 * replaced, kept unchanged in its decisions as the reference the tests and the benchmark
 * (probecast_bvhbench) measure the new builder against. The renderer does not call it.
 *
 * Primitives are copied once into {box, centroid, id} records that are partitioned in place
 * level by level; each interior node does one binning pass over all three axes and one
 * partition pass that also accumulates both children's bounds.
 */
#include <assert.h>
#include <stdlib.h>
#include <string.h>

#include "bvh_build_ref.h"
#include "renderer/accel/bvh_internal.h"

typedef struct ref_prim {
    float lo[3], hi[3];
    float c[3];
    uint32_t id;
} ref_prim;

typedef struct ref_builder {
    ref_prim *p;
    pc_bvh_node *nodes;
    uint32_t node_count;
    uint32_t node_cap;
    uint32_t bins;
    uint32_t max_leaf;
    uint32_t depth;
    bvh_bin bin[3][BVH_MAX_BINS];
} ref_builder;

static inline void bounds_add(bvh_bounds *b, const ref_prim *p)
{
    for (int a = 0; a < 3; a++) {
        b->lo[a] = p->lo[a] < b->lo[a] ? p->lo[a] : b->lo[a];
        b->hi[a] = p->hi[a] > b->hi[a] ? p->hi[a] : b->hi[a];
        b->clo[a] = p->c[a] < b->clo[a] ? p->c[a] : b->clo[a];
        b->chi[a] = p->c[a] > b->chi[a] ? p->c[a] : b->chi[a];
    }
}

static void bounds_of(const ref_prim *p, uint32_t begin, uint32_t end, bvh_bounds *b)
{
    bvh_bounds_empty(b);
    for (uint32_t i = begin; i < end; i++)
        bounds_add(b, &p[i]);
}

/* Partitions [begin, end) in place so that prims whose bin is below split come first, and
 * accumulates the bounds of both sides on the way. Returns the first index of the right side. */
static uint32_t partition_bins(ref_prim *p, uint32_t begin, uint32_t end, int axis, double cmin,
                               double scale, uint32_t bins, uint32_t split, bvh_bounds *left,
                               bvh_bounds *right)
{
    uint32_t i = begin, j = end;
    bvh_bounds_empty(left);
    bvh_bounds_empty(right);
    while (i < j) {
        if (bvh_bin_of(p[i].c[axis], cmin, scale, bins) < split) {
            bounds_add(left, &p[i]);
            i++;
        } else {
            j--;
            ref_prim tmp = p[i];
            p[i] = p[j];
            p[j] = tmp;
            bounds_add(right, &p[j]);
        }
    }
    return i;
}

/* nth_element on the centroid coordinate (Hoare partition, Wirth's selection). */
static void select_nth(ref_prim *p, uint32_t begin, uint32_t end, uint32_t k, int axis)
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
                ref_prim tmp = p[i];
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

static sah_split find_sah_split(ref_builder *b, uint32_t begin, uint32_t end, const bvh_bounds *bd,
                                double cmin[3], double scale[3])
{
    const uint32_t bins = bvh_node_bins(end - begin, b->bins);
    bool use[3];
    bvh_bin_params(bd, bins, use, cmin, scale);
    bvh_bins_reset(b->bin, bins);
    if (!use[0] && !use[1] && !use[2])
        return (sah_split){.axis = -1, .cost = INFINITY, .imbalance = UINT32_MAX, .bins = bins};
    for (uint32_t i = begin; i < end; i++) {
        const ref_prim *q = &b->p[i];
        for (int a = 0; a < 3; a++) {
            if (!use[a]) continue;
            bvh_bin *bn = &b->bin[a][bvh_bin_of(q->c[a], cmin[a], scale[a], bins)];
            bn->count++;
            for (int k = 0; k < 3; k++) {
                bn->lo[k] = q->lo[k] < bn->lo[k] ? q->lo[k] : bn->lo[k];
                bn->hi[k] = q->hi[k] > bn->hi[k] ? q->hi[k] : bn->hi[k];
            }
        }
    }
    return bvh_sweep_bins((const bvh_bin(*)[BVH_MAX_BINS])b->bin, use, bins, bd);
}

static void make_leaf(ref_builder *b, uint32_t ni, const bvh_bounds *bd, uint32_t begin,
                      uint32_t end, uint32_t depth)
{
    bvh_node_set(&b->nodes[ni], bd->lo, bd->hi, begin, end - begin);
    if (depth > b->depth) b->depth = depth;
}

/* Builds node ni over [begin, end) whose bounds are bd, at the given depth; the subtree may
 * not go deeper than cap. index_median: split by index only (the non-finite prims). */
static void build_node(ref_builder *b, uint32_t ni, uint32_t begin, uint32_t end,
                       const bvh_bounds *bd, uint32_t depth, uint32_t cap, bool index_median)
{
    const uint32_t n = end - begin;
    if (n == 1 || depth >= cap) {
        make_leaf(b, ni, bd, begin, end, depth);
        return;
    }
    bvh_bounds left, right;
    uint32_t mid = 0;
    bool median = index_median || (bd->clo[0] == bd->chi[0] && bd->clo[1] == bd->chi[1] &&
                                   bd->clo[2] == bd->chi[2]);
    bool near_cap = depth + 1 + bvh_levels_needed(n, b->max_leaf) > cap;
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
        assert(s.axis >= 0);
        double leaf_cost = SAH_INTERSECT * bvh_half_area(bd->lo, bd->hi) * n;
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
    bvh_node_set(&b->nodes[ni], bd->lo, bd->hi, c, 0);
    build_node(b, c, begin, mid, &left, depth + 1, cap, index_median);
    build_node(b, c + 1, mid, end, &right, depth + 1, cap, index_median);
}

bool rd_bvh_build_reference(rd_bvh *bvh, const float *bmin, const float *bmax, uint32_t count,
                            const rd_bvh_options *opt)
{
    memset(bvh, 0, sizeof *bvh);
    ref_builder *b = calloc(1, sizeof *b);
    if (!b) return false;
    bvh_resolve_options(opt, &b->bins, &b->max_leaf);
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
        ref_prim *q;
        if (bvh_box_valid(lo, hi)) {
            q = &b->p[valid++];
            for (int a = 0; a < 3; a++) {
                q->lo[a] = lo[a];
                q->hi[a] = hi[a];
                q->c[a] = bvh_centroid(lo[a], hi[a]);
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
        ref_prim tmp = b->p[i];
        b->p[i] = b->p[j - 1];
        b->p[j - 1] = tmp;
    }
    b->node_count = 1;
    bvh_bounds all;
    if (count == 0) {
        bvh_bounds_empty(&all);
        bvh_node_set(&b->nodes[0], all.lo, all.hi, 0, 0);
    } else if (valid == 0 || valid == count) {
        bounds_of(b->p, 0, count, &all);
        build_node(b, 0, 0, count, &all, 0, RD_BVH_MAX_DEPTH, valid == 0);
    } else {
        /* Root: left = finite prims (SAH), right = non-finite prims (empty box, by index). */
        bvh_bounds vb, ib;
        bounds_of(b->p, 0, valid, &vb);
        bounds_of(b->p, valid, count, &ib);
        b->node_count = 3;
        bvh_node_set(&b->nodes[0], vb.lo, vb.hi, 1, 0);
        build_node(b, 1, 0, valid, &vb, 1, RD_BVH_MAX_DEPTH, false);
        build_node(b, 2, valid, count, &ib, 1, RD_BVH_MAX_DEPTH, true);
    }
    for (uint32_t i = 0; i < b->node_count; i++)
        bvh_widen_node(&b->nodes[i]);
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
