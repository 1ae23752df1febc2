/* bvh_cwide.c: binary to compressed 8-wide BVH collapse (see bvh_cwide.h). */
#include "bvh_cwide.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bvh_wide.h"
#include "renderer/accel/bvh.h"

/* Makes room for need elements of size bytes in *p. Aborts when out of memory. */
static void grow(void **p, uint32_t *capacity, uint64_t need, size_t size)
{
    if (need <= *capacity) return;
    uint64_t c = *capacity ? *capacity : 64;
    while (c < need)
        c *= 2;
    void *q = c <= UINT32_MAX ? realloc(*p, (size_t)c * size) : NULL;
    if (!q) {
        fprintf(stderr, "probecast_rtbench: out of memory compressing a BVH\n");
        abort();
    }
    *p = q;
    *capacity = (uint32_t)c;
}

static uint32_t get_byte(const pc_uvec4 *v, int word, int byte)
{
    return ((&v->x)[word] >> (8 * byte)) & 0xffu;
}

static void set_byte(pc_uvec4 *v, int word, int byte, uint32_t value)
{
    uint32_t *u = &(&v->x)[word];
    *u = (*u & ~(0xffu << (8 * byte))) | (value << (8 * byte));
}

/* The plane p + q * 2^(e - 127) of biased exponent e, in double: exact unless p and the step
 * lie more than 53 bits apart, and then within half a double ulp, so that a plane at or below
 * (above) a float bound also rounds to a float at or below (above) it. */
static double plane(float p, uint32_t q, uint32_t e)
{
    return (double)p + q * ldexp(1.0, (int)e - 127);
}

/* Smallest biased exponent whose 255 steps from p reach hi (1 for a flat axis). */
static uint32_t axis_exponent(float p, float hi)
{
    double ext = (double)hi - p;
    if (!(ext > 0)) return 1;
    int x;
    frexp(ext / 255.0, &x); /* ext / 255 <= 2^x < 2 ext / 255 */
    int e = x + 127 - 1;
    if (e < 1) e = 1;
    while (e < 254 && plane(p, 255, (uint32_t)e) < hi)
        e++;
    return (uint32_t)e;
}

static uint32_t clamp_q(double q)
{
    return q <= 0 ? 0 : q >= 255 ? 255 : (uint32_t)q;
}

/* Quantised lo rounded down and hi rounded up until the planes contain [lo, hi]. */
static uint32_t quant_lo(float p, uint32_t e, float lo)
{
    uint32_t q = clamp_q(floor(((double)lo - p) / ldexp(1.0, (int)e - 127)));
    while (q > 0 && plane(p, q, e) > lo)
        q--;
    return q;
}

static uint32_t quant_hi(float p, uint32_t e, float hi)
{
    uint32_t q = clamp_q(ceil(((double)hi - p) / ldexp(1.0, (int)e - 127)));
    while (q < 255 && plane(p, q, e) < hi)
        q++;
    return q;
}

static const float *lo3(const pc_bvh_node *n)
{
    return &n->bmin.x;
}

static const float *hi3(const pc_bvh_node *n)
{
    return &n->bmax.x;
}

double rtb_cwide_slot_cost(const float lo[3], const float hi[3], const pc_bvh_node *c, int slot)
{
    double cost = 0;
    for (int a = 0; a < 3; a++) {
        double d = ((double)lo3(c)[a] + hi3(c)[a]) - ((double)lo[a] + hi[a]);
        cost += (slot >> a) & 1 ? -d : d;
    }
    return cost;
}

int rtb_cwide_slots(const pc_bvh_node *bin, uint32_t b, uint32_t slots[RTB_CWIDE], float lo[3],
                    float hi[3])
{
    uint32_t kids[RTB_CWIDE];
    int n = rtb_bvh_open(bin, b, RTB_CWIDE, kids), used = 0;
    for (int a = 0; a < 3; a++)
        lo[a] = INFINITY, hi[a] = -INFINITY;
    for (int k = 0; k < n; k++) {
        const pc_bvh_node *c = &bin[kids[k]];
        if (rtb_bvh_box_empty(c)) continue; /* never hit: left out */
        kids[used++] = kids[k];
        for (int a = 0; a < 3; a++) {
            lo[a] = fminf(lo[a], lo3(c)[a]);
            hi[a] = fmaxf(hi[a], hi3(c)[a]);
        }
    }
    for (int s = 0; s < RTB_CWIDE; s++)
        slots[s] = RTB_CWIDE_NONE;
    /* greedy: the cheapest (child, slot) pair of free ones first, ties to the lower child and
     * slot; this leaves no child and slot that both have a cheaper partner in each other */
    double cost[RTB_CWIDE][RTB_CWIDE];
    for (int i = 0; i < used; i++)
        for (int s = 0; s < RTB_CWIDE; s++)
            cost[i][s] = rtb_cwide_slot_cost(lo, hi, &bin[kids[i]], s);
    bool placed[RTB_CWIDE] = {false};
    for (int round = 0; round < used; round++) {
        int bi = -1, bs = -1;
        for (int i = 0; i < used; i++) {
            if (placed[i]) continue;
            for (int s = 0; s < RTB_CWIDE; s++)
                if (slots[s] == RTB_CWIDE_NONE && (bi < 0 || cost[i][s] < cost[bi][bs]))
                    bi = i, bs = s;
        }
        placed[bi] = true;
        slots[bs] = kids[bi];
    }
    return used;
}

/* Fills the already allocated node `at` from binary node b at compressed depth level: its
 * interior children are allocated next to each other in slot order, then filled depth first. */
static void fill(rtb_cwide *w, const pc_bvh_node *bin, uint32_t at, uint32_t b, uint32_t level)
{
    if (level > w->depth) w->depth = level;
    uint32_t slots[RTB_CWIDE], meta[RTB_CWIDE] = {0};
    float lo[3], hi[3];
    rtb_cwide_slots(bin, b, slots, lo, hi);
    uint32_t interior = 0, leaves = 0;
    for (int k = 0; k < RTB_CWIDE; k++) { /* ranks in slot order, as the group traversal needs */
        if (slots[k] == RTB_CWIDE_NONE) continue;
        uint32_t count = rd_bvh_node_count(&bin[slots[k]]);
        meta[k] = count == 0 ? RTB_CWIDE_INTERIOR | interior++ : count << 3 | leaves++;
    }
    uint32_t child_base = w->node_count, leaf_base = w->leaf_count;
    grow((void **)&w->nodes, &w->node_capacity, (uint64_t)w->node_count + interior,
         sizeof *w->nodes);
    grow((void **)&w->leaf_first, &w->leaf_capacity, (uint64_t)w->leaf_count + leaves,
         sizeof *w->leaf_first);
    w->node_count += interior;
    w->leaf_count += leaves;

    rtb_cwide_node d = {0};
    uint32_t e[3] = {127, 127, 127};
    if (interior + leaves > 0) {
        d.origin = (pc_vec4){lo[0], lo[1], lo[2], 0};
        for (int a = 0; a < 3; a++)
            e[a] = axis_exponent(lo[a], hi[a]);
    }
    uint32_t ebits = e[0] | e[1] << 8 | e[2] << 16;
    memcpy(&d.origin.w, &ebits, sizeof ebits);
    d.refs = (pc_uvec4){child_base, leaf_base, 0, 0};
    pc_uvec4 *q[3] = {&d.q_x, &d.q_y, &d.q_z};
    for (int k = 0; k < RTB_CWIDE; k++) {
        int word = k >> 2, byte = k & 3;
        if (meta[k] == 0) {
            for (int a = 0; a < 3; a++) {
                set_byte(q[a], word, byte, 255);
                set_byte(q[a], 2 + word, byte, 0);
            }
            continue;
        }
        const pc_bvh_node *c = &bin[slots[k]];
        set_byte(&d.refs, 2 + word, byte, meta[k]);
        if (!(meta[k] & RTB_CWIDE_INTERIOR))
            w->leaf_first[leaf_base + (meta[k] & 7)] = rd_bvh_node_first(c);
        for (int a = 0; a < 3; a++) {
            set_byte(q[a], word, byte, quant_lo(lo[a], e[a], lo3(c)[a]));
            set_byte(q[a], 2 + word, byte, quant_hi(lo[a], e[a], hi3(c)[a]));
        }
    }
    w->nodes[at] = d;
    for (int k = 0; k < RTB_CWIDE; k++)
        if (meta[k] & RTB_CWIDE_INTERIOR)
            fill(w, bin, child_base + (meta[k] & 7), slots[k], level + 1);
}

uint32_t rtb_cwide_collapse(rtb_cwide *w, const pc_bvh_node *bin, uint32_t root)
{
    uint32_t at = w->node_count;
    grow((void **)&w->nodes, &w->node_capacity, (uint64_t)at + 1, sizeof *w->nodes);
    w->node_count++;
    fill(w, bin, at, root, 0);
    return at;
}

void rtb_cwide_destroy(rtb_cwide *w)
{
    free(w->nodes);
    free(w->leaf_first);
    *w = (rtb_cwide){0};
}

bool rtb_cwide_child(const rtb_cwide *w, const rtb_cwide_node *n, int k, float lo[3], float hi[3],
                     uint32_t *child, uint32_t *count)
{
    int word = k >> 2, byte = k & 3;
    uint32_t meta = get_byte(&n->refs, 2 + word, byte);
    if (meta == 0) return false;
    uint32_t ebits;
    memcpy(&ebits, &n->origin.w, sizeof ebits);
    const float *p = &n->origin.x;
    const pc_uvec4 *q[3] = {&n->q_x, &n->q_y, &n->q_z};
    for (int a = 0; a < 3; a++) {
        float s = ldexpf(1.0f, (int)((ebits >> (8 * a)) & 0xffu) - 127);
        lo[a] = p[a] + (float)get_byte(q[a], word, byte) * s; /* q * s is exact */
        hi[a] = p[a] + (float)get_byte(q[a], 2 + word, byte) * s;
    }
    uint32_t r = meta & 7;
    if (meta & RTB_CWIDE_INTERIOR) {
        *child = n->refs.x + r;
        *count = 0;
    } else {
        *child = w->leaf_first[n->refs.y + r];
        *count = meta >> 3;
    }
    return true;
}

uint64_t rtb_cwide_bytes(const rtb_cwide *w)
{
    return (uint64_t)w->node_count * sizeof(rtb_cwide_node) +
           (uint64_t)w->leaf_count * sizeof(uint32_t);
}
