/* bvh_wide.c: binary to 4-wide BVH collapse (see bvh_wide.h). */
#include "bvh_wide.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "renderer/accel/bvh.h"

bool rtb_bvh_box_empty(const pc_bvh_node *n)
{
    return !(n->bmin.x <= n->bmax.x && n->bmin.y <= n->bmax.y && n->bmin.z <= n->bmax.z);
}

static double area(const pc_bvh_node *n)
{
    double x = (double)n->bmax.x - n->bmin.x, y = (double)n->bmax.y - n->bmin.y,
           z = (double)n->bmax.z - n->bmin.z;
    return x * y + y * z + z * x;
}

static uint32_t alloc_node(rtb_wide *w)
{
    if (w->node_count == w->capacity) {
        w->capacity = w->capacity ? 2 * w->capacity : 64;
        w->nodes = realloc(w->nodes, (size_t)w->capacity * sizeof *w->nodes);
        if (!w->nodes) {
            fprintf(stderr, "probecast_rtbench: out of memory collapsing a BVH\n");
            abort();
        }
    }
    rtb_wide_node *n = &w->nodes[w->node_count];
    float inf = INFINITY;
    n->lo_x = n->lo_y = n->lo_z = (pc_vec4){inf, inf, inf, inf};
    n->hi_x = n->hi_y = n->hi_z = (pc_vec4){-inf, -inf, -inf, -inf};
    n->child = (pc_uvec4){0, 0, 0, 0};
    n->count = (pc_uvec4){RTB_WIDE_EMPTY, RTB_WIDE_EMPTY, RTB_WIDE_EMPTY, RTB_WIDE_EMPTY};
    return w->node_count++;
}

static void set4(pc_vec4 *v, int k, float f)
{
    float *p = &v->x;
    p[k] = f;
}

static void set4u(pc_uvec4 *v, int k, uint32_t u)
{
    uint32_t *p = &v->x;
    p[k] = u;
}

static uint32_t collapse_at(rtb_wide *w, const pc_bvh_node *bin, uint32_t b, uint32_t level);

/* Fills wide node `at` from the binary nodes in slots[0 .. n) and recurses below. */
static void emit(rtb_wide *w, const pc_bvh_node *bin, uint32_t at, const uint32_t *slots, int n,
                 uint32_t level)
{
    if (level > w->depth) w->depth = level;
    for (int k = 0; k < n; k++) {
        const pc_bvh_node *c = &bin[slots[k]];
        if (rtb_bvh_box_empty(c)) continue; /* never hit: an unused slot */
        uint32_t first = rd_bvh_node_first(c), count = rd_bvh_node_count(c);
        uint32_t child = first;
        if (count == 0) child = collapse_at(w, bin, slots[k], level + 1);
        rtb_wide_node *d = &w->nodes[at]; /* after the recursion: nodes may have moved */
        set4(&d->lo_x, k, c->bmin.x), set4(&d->hi_x, k, c->bmax.x);
        set4(&d->lo_y, k, c->bmin.y), set4(&d->hi_y, k, c->bmax.y);
        set4(&d->lo_z, k, c->bmin.z), set4(&d->hi_z, k, c->bmax.z);
        set4u(&d->child, k, child);
        set4u(&d->count, k, count);
    }
}

int rtb_bvh_open(const pc_bvh_node *bin, uint32_t b, int width, uint32_t *slots)
{
    int n = 0;
    if (rtb_bvh_box_empty(&bin[b])) return 0; /* an empty mesh: every slot unused */
    if (rd_bvh_node_count(&bin[b]) != 0) {
        slots[n++] = b; /* a leaf root: one leaf slot */
        return n;
    }
    uint32_t first = rd_bvh_node_first(&bin[b]);
    slots[n++] = first;
    slots[n++] = first + 1;
    while (n < width) { /* open the interior child of largest area */
        int best = -1;
        double best_area = -1;
        for (int k = 0; k < n; k++) {
            const pc_bvh_node *c = &bin[slots[k]];
            if (rd_bvh_node_count(c) != 0 || rtb_bvh_box_empty(c)) continue;
            double a = area(c);
            if (a > best_area) best = k, best_area = a;
        }
        if (best < 0) break;
        uint32_t c = rd_bvh_node_first(&bin[slots[best]]);
        slots[best] = c;
        slots[n++] = c + 1;
    }
    return n;
}

/* The wide node of binary node b (interior, a leaf or empty) at wide depth level. */
static uint32_t collapse_at(rtb_wide *w, const pc_bvh_node *bin, uint32_t b, uint32_t level)
{
    uint32_t at = alloc_node(w);
    uint32_t slots[RTB_WIDE];
    int n = rtb_bvh_open(bin, b, RTB_WIDE, slots);
    emit(w, bin, at, slots, n, level);
    return at;
}

uint32_t rtb_wide_collapse(rtb_wide *w, const pc_bvh_node *bin, uint32_t root)
{
    return collapse_at(w, bin, root, 0);
}

void rtb_wide_destroy(rtb_wide *w)
{
    free(w->nodes);
    *w = (rtb_wide){0};
}

uint32_t rtb_wide_stack_need(uint32_t width, uint32_t depth)
{
    return 2 * ((width - 1) * (depth + 1) + width) + RD_BVH_MAX_LEAF;
}
