/* bvh_subtree.c: the single-threaded part of the multi-threaded builder: binning into two
 * alternating bin sets, in-place partitioning and whole subtrees built recursively by one
 * thread, with the reference builder's decisions (bvh_build_ref.c). */
#include "renderer/accel/bvh_subtree.h"

#include <assert.h>
#include <string.h>

/* ---- records ---------------------------------------------------------------------------- */

void bvh_rec_bounds_of(const bvh_rec *r, uint32_t begin, uint32_t end, bvh_bounds *b)
{
    bvh_bounds_empty(b);
    for (uint32_t i = begin; i < end; i++)
        bvh_rec_bounds_add(b, &r[i]);
}

static inline void bin_add(bvh_bin *row, const bvh_rec *restrict q, int a, const bvh_bin_setup *s)
{
    bvh_bin *restrict bn =
        &row[bvh_bin_of(bvh_centroid(q->lo[a], q->hi[a]), s->cmin[a], s->scale[a], s->bins)];
    bn->count++;
    /* all four lanes, so that the compiler can use one 4-wide min and max */
    for (int k = 0; k < 4; k++) {
        bn->lo[k] = q->lo[k] < bn->lo[k] ? q->lo[k] : bn->lo[k];
        bn->hi[k] = q->hi[k] > bn->hi[k] ? q->hi[k] : bn->hi[k];
    }
}

/* Ranges this long bin into two alternating bin sets (see bvh_bin_range). */
#define BIN_TWO_SETS_FROM 256u

/* Bins [begin, end) along the usable axes into out (reset here). Long ranges send even and
 * odd records to two bin sets merged at the end: neighbouring primitives often share a bin,
 * and with one set each update would wait for the previous one's store. */
void bvh_bin_range(const bvh_rec *r, uint32_t begin, uint32_t end, const bvh_bin_setup *s,
                   bvh_bin out[3][BVH_MAX_BINS])
{
    int axes[3], na = 0;
    for (int a = 0; a < 3; a++)
        if (s->use[a]) axes[na++] = a;
    bvh_bins_reset(out, s->bins);
    uint32_t i = begin;
    if (end - begin >= BIN_TWO_SETS_FROM) {
        bvh_bin odd[3][BVH_MAX_BINS];
        bvh_bins_reset(odd, s->bins);
        for (; i + 1 < end; i += 2) {
            for (int k = 0; k < na; k++) {
                bin_add(out[axes[k]], &r[i], axes[k], s);
                bin_add(odd[axes[k]], &r[i + 1], axes[k], s);
            }
        }
        bvh_bins_merge(out, (const bvh_bin(*)[BVH_MAX_BINS])odd, s->bins);
    }
    for (; i < end; i++)
        for (int k = 0; k < na; k++)
            bin_add(out[axes[k]], &r[i], axes[k], s);
}

/* ---- one subtree on one thread ---------------------------------------------------------- */

/* In-place partition; accumulates both sides' bounds. Returns the first right index. */
static uint32_t partition_in_place(bvh_rec *r, uint32_t begin, uint32_t end, int axis,
                                   const bvh_bin_setup *s, uint32_t split, bvh_bounds *left,
                                   bvh_bounds *right)
{
    uint32_t i = begin, j = end;
    bvh_bounds_empty(left);
    bvh_bounds_empty(right);
    while (i < j) {
        if (bvh_goes_left(&r[i], axis, s, split)) {
            bvh_rec_bounds_add(left, &r[i]);
            i++;
        } else {
            j--;
            bvh_rec tmp = r[i];
            r[i] = r[j];
            r[j] = tmp;
            bvh_rec_bounds_add(right, &r[j]);
        }
    }
    return i;
}

/* nth_element on the centroid coordinate (Hoare partition, Wirth's selection). */
static void select_nth(bvh_rec *r, uint32_t begin, uint32_t end, uint32_t k, int axis)
{
    int64_t l = begin, h = (int64_t)end - 1;
    while (l < h) {
        float x = bvh_centroid(r[k].lo[axis], r[k].hi[axis]);
        int64_t i = l, j = h;
        do {
            while (bvh_centroid(r[i].lo[axis], r[i].hi[axis]) < x)
                i++;
            while (x < bvh_centroid(r[j].lo[axis], r[j].hi[axis]))
                j--;
            if (i <= j) {
                bvh_rec tmp = r[i];
                r[i] = r[j];
                r[j] = tmp;
                i++;
                j--;
            }
        } while (i <= j);
        if (j < k) l = i;
        if (k < i) h = j;
    }
}

bool bvh_centroids_coincide(const bvh_bounds *bd)
{
    return bd->clo[0] == bd->chi[0] && bd->clo[1] == bd->chi[1] && bd->clo[2] == bd->chi[2];
}

bool bvh_near_cap(uint32_t n, uint32_t depth, uint32_t max_leaf)
{
    return depth + 1 + bvh_levels_needed(n, max_leaf) > RD_BVH_MAX_DEPTH;
}

static void make_leaf(bvh_seq_builder *b, uint32_t ni, const bvh_bounds *bd, uint32_t begin,
                      uint32_t end, uint32_t depth)
{
    bvh_node_set(&b->nodes[ni], bd->lo, bd->hi, begin, end - begin);
    if (depth > b->depth) b->depth = depth;
}

/* The reference's build_node (bvh_build_ref.c) on records: same decisions, same order of
 * node allocation. */
void bvh_seq_build_node(bvh_seq_builder *b, uint32_t ni, uint32_t begin, uint32_t end,
                        const bvh_bounds *bd, uint32_t depth, bool index_median)
{
    const uint32_t n = end - begin;
    if (n == 1 || depth >= RD_BVH_MAX_DEPTH) {
        make_leaf(b, ni, bd, begin, end, depth);
        return;
    }
    bvh_bounds left, right;
    uint32_t mid;
    bool median = index_median || bvh_centroids_coincide(bd);
    if (median || bvh_near_cap(n, depth, b->max_leaf)) {
        if (n <= b->max_leaf) {
            make_leaf(b, ni, bd, begin, end, depth);
            return;
        }
        mid = begin + n / 2;
        if (!median) { /* near the cap: halve along the widest centroid axis */
            int axis = 0;
            double best = -1.0;
            for (int a = 0; a < 3; a++) {
                double extent = (double)bd->chi[a] - bd->clo[a];
                if (extent > best) {
                    best = extent;
                    axis = a;
                }
            }
            select_nth(b->r, begin, end, mid, axis);
        }
        bvh_rec_bounds_of(b->r, begin, mid, &left);
        bvh_rec_bounds_of(b->r, mid, end, &right);
    } else {
        bvh_bin_setup s = {.bins = bvh_node_bins(n, b->bins)};
        bvh_bin_params(bd, s.bins, s.use, s.cmin, s.scale);
        bvh_bin_range(b->r, begin, end, &s, b->bin);
        sah_split sp = bvh_sweep_bins((const bvh_bin(*)[BVH_MAX_BINS])b->bin, s.use, s.bins, bd);
        assert(sp.axis >= 0); /* centroids do not coincide, so some axis has two bins in use */
        double leaf_cost = SAH_INTERSECT * bvh_half_area(bd->lo, bd->hi) * n;
        if (n <= b->max_leaf && sp.cost >= leaf_cost) {
            make_leaf(b, ni, bd, begin, end, depth);
            return;
        }
        mid = partition_in_place(b->r, begin, end, sp.axis, &s, sp.bin, &left, &right);
        assert(mid > begin && mid < end);
    }
    uint32_t c = b->count;
    b->count += 2;
    bvh_node_set(&b->nodes[ni], bd->lo, bd->hi, c, 0);
    bvh_seq_build_node(b, c, begin, mid, &left, depth + 1, index_median);
    bvh_seq_build_node(b, c + 1, mid, end, &right, depth + 1, index_median);
}
