/* ploc_ref.h: a CPU PLOC builder (Meister and Bittner, "Parallel Locally-Ordered Clustering for
 * Bounding Volume Hierarchy Construction", 2018), kept beside the tests as the reference for a
 * GPU builder by clustering (issue 24: the LBVH's trees trace slower than the CPU builder's on
 * real meshes, whose triangles vary in size; clustering merges by the merged boxes' areas). The
 * renderer does not use it.
 *
 * Triangles in the order of the LBVH's 30-bit Morton codes of their centroids (the same codes as
 * shaders/lbvh_morton.comp, ties by index); then, until one cluster is left, each cluster finds
 * its nearest neighbour within radius places on either side (the least area of the two boxes'
 * union; ties go to the nearer place, and between the two next places to the partner in its
 * aligned pair, i ^ 1, so that equal boxes pair up instead of chaining), mutual nearest
 * neighbours merge (the new cluster at the lower place), and the rest keep their order. Leaves:
 * the subtrees of at most max_leaf triangles collapsed where one leaf's SAH times leaf_weight
 * costs no more (as the LBVH's lbvh_boxes.comp; never a subtree mixing finite triangles with
 * ones of a non-finite vertex, whose boxes are empty). The tree comes out in rd_bvh's layout
 * (children adjacent, leaves' triangles contiguous in prim_index, depth set). */
#ifndef PC_PLOC_REF_H
#define PC_PLOC_REF_H

#include <stdbool.h>
#include <stdint.h>

#include "renderer/accel/bvh.h"

/* pos: 9 floats a triangle; radius at least 1; max_leaf 1 to RD_BVH_MAX_LEAF. Free with
 * rd_bvh_destroy. False only for bad arguments; out of memory aborts. iterations (may be NULL):
 * the clustering's rounds. */
bool pc_ploc_build(rd_bvh *out, const float *pos, uint32_t n, uint32_t radius, uint32_t max_leaf,
                   float leaf_weight, uint32_t *iterations);

#endif
