/* bvh_split.c: what both builders share (declared in bvh_internal.h): the SAH sweep over
 * filled bins, the widening of node boxes, and triangle boxes. */
#include "renderer/accel/bvh_internal.h"

sah_split bvh_sweep_bins(const bvh_bin bin[3][BVH_MAX_BINS], const bool use[3], uint32_t bins,
                         const bvh_bounds *bd)
{
    sah_split best = {
        .axis = -1, .bin = 0, .cost = INFINITY, .imbalance = UINT32_MAX, .bins = bins};
    const double parent_area = bvh_half_area(bd->lo, bd->hi);
    for (int a = 0; a < 3; a++) {
        if (!use[a]) continue;
        double right_cost[BVH_MAX_BINS];
        uint32_t right_count[BVH_MAX_BINS];
        /* lane 3 is padding: 4-wide min/max (see bvh_bin) */
        float lo[4] = {INFINITY, INFINITY, INFINITY, INFINITY};
        float hi[4] = {-INFINITY, -INFINITY, -INFINITY, -INFINITY};
        uint32_t n = 0;
        for (uint32_t i = bins - 1; i > 0; i--) { /* right side = bins [i, bins) */
            const bvh_bin *bn = &bin[a][i];
            for (int k = 0; k < 4; k++) {
                lo[k] = bn->lo[k] < lo[k] ? bn->lo[k] : lo[k];
                hi[k] = bn->hi[k] > hi[k] ? bn->hi[k] : hi[k];
            }
            n += bn->count;
            right_count[i] = n;
            right_cost[i] = n ? bvh_half_area(lo, hi) * n : 0.0;
        }
        for (int k = 0; k < 4; k++) {
            lo[k] = INFINITY;
            hi[k] = -INFINITY;
        }
        n = 0;
        for (uint32_t i = 1; i < bins; i++) { /* left side = bins [0, i) */
            const bvh_bin *bn = &bin[a][i - 1];
            for (int k = 0; k < 4; k++) {
                lo[k] = bn->lo[k] < lo[k] ? bn->lo[k] : lo[k];
                hi[k] = bn->hi[k] > hi[k] ? bn->hi[k] : hi[k];
            }
            n += bn->count;
            if (n == 0 || right_count[i] == 0) continue;
            double cost = SAH_TRAVERSAL * parent_area +
                          SAH_INTERSECT * (bvh_half_area(lo, hi) * n + right_cost[i]);
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

void bvh_widen_node(pc_bvh_node *n)
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

void rd_bvh_triangle_boxes(const float *positions, uint32_t tri_count, float *bmin, float *bmax)
{
    for (uint32_t i = 0; i < tri_count; i++)
        bvh_triangle_box(positions + 9 * (size_t)i, bmin + 3 * (size_t)i, bmax + 3 * (size_t)i);
}
