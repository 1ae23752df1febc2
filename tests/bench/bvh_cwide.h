/* bvh_cwide.h: collapses the renderer's binary BVHs (pc_bvh_node arrays with absolute indices,
 * as rd_gpu_scene uploads them) into compressed 8-wide nodes (rtb_cwide_types.h) for the
 * benchmark's cwide tracer. The same greedy collapse as the 4-wide tracer's (rtb_bvh_open in
 * bvh_wide.h) with up to RTB_CWIDE children; leaves keep their (first, count), so the tree
 * indexes the same triangle and instance-index arrays. Child boxes are quantised to 8 bits per
 * plane relative to the node's own box, rounded outwards (Ylitie, Karras, Laine, HPG 2017,
 * sec. 3.1). Children with an empty box become unused slots, as in the 4-wide collapse.
 */
#ifndef RTB_BVH_CWIDE_H
#define RTB_BVH_CWIDE_H

#include <stdbool.h>
#include <stdint.h>

#include "shaders/gpu_types.h"
#include "tests/bench/rtb_cwide_types.h"

typedef struct rtb_cwide {
    rtb_cwide_node *nodes;
    uint32_t node_count, node_capacity;
    uint32_t *leaf_first; /* first primitive per leaf child (rtb_cwide_types.h) */
    uint32_t leaf_count, leaf_capacity;
    uint32_t depth; /* deepest compressed level below any root collapsed so far */
} rtb_cwide;

/* Appends the collapse of the binary tree rooted at bin[root] (indices absolute into bin) to
 * w and returns its compressed root index. Aborts when out of memory. */
uint32_t rtb_cwide_collapse(rtb_cwide *w, const pc_bvh_node *bin, uint32_t root);
void rtb_cwide_destroy(rtb_cwide *w); /* idempotent */

/* Child k of node n as the tracer decodes it. Returns 0 for an unused slot, else fills the
 * float box [lo, hi] that the traversal tests and *child: the wide node index of an interior
 * child (*count = 0) or the first primitive of a leaf (*count = its primitive count). */
bool rtb_cwide_child(const rtb_cwide *w, const rtb_cwide_node *n, int k, float lo[3], float hi[3],
                     uint32_t *child, uint32_t *count);

/* Bytes of node memory the tracer reads: nodes plus leaf_first. */
uint64_t rtb_cwide_bytes(const rtb_cwide *w);

#endif
