/* bvh_cwide.h: collapses the renderer's binary BVHs (pc_bvh_node arrays with absolute indices,
 * as rd_gpu_scene uploads them) into compressed 8-wide nodes (rtb_cwide_types.h) for the
 * benchmark's cwide tracer. The same greedy collapse as the 4-wide tracer's (rtb_bvh_open in
 * bvh_wide.h) with up to RTB_CWIDE children; leaves keep their (first, count), so the tree
 * indexes the same triangle and instance-index arrays. Child boxes are quantised to 8 bits per
 * plane relative to the node's own box, rounded outwards (Ylitie, Karras, Laine, HPG 2017,
 * sec. 3.1). Children with an empty box become unused slots, as in the 4-wide collapse.
 *
 * Slots follow the ray octants (their sec. 3.2 and 4.3; rtb_cwide_slots): slot s, its bits the
 * signs of a direction (bit a set: negative on axis a), should hold the child met first by rays
 * of that octant, i.e. the child whose centroid lies farthest back along the diagonal d_s =
 * (+-1, +-1, +-1) of the octant, seen from the node's centre. A ray of octant o then visits
 * slots in increasing s ^ o: rtb_trace_cwide.comp's group traversal takes the highest set bit
 * of a hit mask whose slot s sits at bit s ^ (7 - o), with no sort.
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
#define RTB_CWIDE_NONE 0xffffffffu /* an unused slot in rtb_cwide_slots */

/* The cost of child c in slot s of a node whose children span [lo, hi]: dot(centroid(c) -
 * centre, d_s), doubled, in double. Smaller is earlier for rays of octant s. */
double rtb_cwide_slot_cost(const float lo[3], const float hi[3], const pc_bvh_node *c, int slot);

/* The children of the compressed node made from bin[b] by slot: the binary node index, or
 * RTB_CWIDE_NONE. The children are rtb_bvh_open's with non-empty boxes (their count is returned;
 * [lo, hi] gets the union of their boxes), placed greedily, cheapest (child, slot) pair of the
 * rtb_cwide_slot_cost table first, so that no child and slot would both be cheaper together
 * than with what they got (a stable assignment). */
int rtb_cwide_slots(const pc_bvh_node *bin, uint32_t b, uint32_t slots[RTB_CWIDE], float lo[3],
                    float hi[3]);

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
