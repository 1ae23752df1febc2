/* bvh_wide.h: collapses the renderer's binary BVHs (pc_bvh_node arrays with absolute indices,
 * as rd_gpu_scene uploads them) into 4-wide nodes (rtb_wide_types.h) for the benchmark's wide
 * tracer. Leaves keep their (first, count), so the wide tree indexes the same triangle and
 * instance-index arrays; only node data differs.
 *
 * Collapse (Wald, Benthin, Boulos, "Getting Rid of Packets", 2008, sec. 3; the greedy child
 * choice of Ylitie, Karras, Laine, HPG 2017, sec. 4.1 without its cost model): a wide node
 * starts from a binary interior node's two children and repeatedly opens the interior child of
 * largest surface area until it has RTB_WIDE children or only leaves are left. Children with
 * an empty box (the builder's subtree of non-finite primitives, an empty mesh's root) are never
 * hit by a binary traversal either; they become unused slots.
 */
#ifndef RTB_BVH_WIDE_H
#define RTB_BVH_WIDE_H

#include <stdbool.h>
#include <stdint.h>

#include "shaders/gpu_types.h"
#include "tests/bench/rtb_wide_types.h"

typedef struct rtb_wide {
    rtb_wide_node *nodes;
    uint32_t node_count, capacity;
    uint32_t depth; /* deepest wide level below any root collapsed so far */
} rtb_wide;

/* Appends the collapse of the binary tree rooted at bin[root] (indices absolute into bin) to
 * w and returns its wide root index. Aborts when out of memory. */
uint32_t rtb_wide_collapse(rtb_wide *w, const pc_bvh_node *bin, uint32_t root);
void rtb_wide_destroy(rtb_wide *w); /* idempotent */

/* Stack entries a wide tracer of nodes with up to width children (rtb_trace_wide.comp: 4,
 * rtb_trace_cwide.comp: 8) can need when no tree is deeper than depth wide levels: a node pops
 * itself and pushes at most width children, one of which is popped next, so each level of the
 * TLAS and of one BLAS leaves at most width - 1 siblings pending below the deepest node's width
 * children, plus a TLAS leaf's waiting instances. */
uint32_t rtb_wide_stack_need(uint32_t width, uint32_t depth);

/* The greedy choice both collapses share (rtb_wide_collapse, rtb_cwide_collapse): the binary
 * nodes that become the children of the wide node of binary node bin[b], at most width (>= 2)
 * of them, written to slots; returns their count. 0 for a node with an empty box, 1 (b itself)
 * for a leaf, else b's children with the interior child of largest surface area opened until
 * there are width or only leaves are left. Slots may include children with empty boxes, which
 * the caller leaves unused (rtb_bvh_box_empty). */
int rtb_bvh_open(const pc_bvh_node *bin, uint32_t b, int width, uint32_t *slots);
bool rtb_bvh_box_empty(const pc_bvh_node *n);

#endif
