/* bvh.h: binned-SAH bounding volume hierarchies, built on the CPU.
 *
 * One builder serves both levels: a bottom-level BVH over a mesh's triangles and a top-level
 * BVH over instance boxes. Nodes use the GPU layout (pc_bvh_node) with indices relative to
 * the start of this BVH's node and primitive arrays; the uploader adds base offsets.
 * Depth never exceeds RD_BVH_MAX_DEPTH (< PC_BVH_STACK_SIZE), so GPU stacks cannot overflow.
 *
 * The builder (bvh_build.c) bins all three axes (16 bins) and takes the cheapest SAH split,
 * as the single-threaded reference (rd_bvh_build_reference) does, with the same decisions;
 * it runs on a pool of threads: the top levels bin and partition over fixed chunks of
 * primitives in parallel, the subtrees below 64 K primitives are built one per task, and
 * rd_bvh_build_many builds several meshes at once. The output (nodes and prim_index) is
 * bit-identical whatever the thread count. Memory while building: about 160 bytes per
 * primitive. The caller's thread takes part; builds under 64 K primitives (one mesh) or
 * 16 K (all meshes together) start no threads.
 */
#ifndef RD_BVH_H
#define RD_BVH_H

#include <stdbool.h>
#include <stdint.h>

#include "shaders/gpu_types.h"

#define RD_BVH_MAX_DEPTH 48
#define RD_BVH_MAX_LEAF 8
/* Primitives per chunk of the parallel top levels; nodes of RD_BVH_PAR_MIN_PRIMS or more are
 * binned and partitioned over such chunks, smaller ones are built whole by one thread. */
#define RD_BVH_CHUNK_PRIMS 16384u
#define RD_BVH_PAR_MIN_PRIMS (4u * RD_BVH_CHUNK_PRIMS)

typedef struct rd_bvh {
    pc_bvh_node *nodes; /* nodes[0] is the root */
    uint32_t node_count;
    uint32_t *prim_index; /* leaf order -> original primitive index */
    uint32_t prim_count;
    uint32_t depth; /* levels below the root */
} rd_bvh;

typedef struct rd_bvh_options {
    uint32_t bins;     /* 0 = 16, clamped to [2, 64] */
    uint32_t max_leaf; /* 0 = 4, at most RD_BVH_MAX_LEAF */
    uint32_t threads;  /* threads of execution, the caller's included; 0 = online cores */
} rd_bvh_options;

/* A mesh for rd_bvh_build_many: tri_count triangles of 9 floats each. */
typedef struct rd_bvh_mesh {
    const float *positions;
    uint32_t tri_count;
} rd_bvh_mesh;

/* Builds over count primitive boxes (bmin/bmax: 3 floats each). Boxes with non-finite
 * coordinates (or bmin > bmax) are kept as empty leaves' members but never hit: their box is
 * made empty, [+inf, -inf], and they sit in a subtree of their own whose box is empty too.
 * count == 0 yields a single root node with an empty box (stored as an interior node with
 * first = 0); traversals test the root box before reading children, so it is never entered.
 * Empty boxes are inverted, so slab tests must pick the near/far plane by the sign of the
 * direction (a min/max slab test would accept them). Finite node boxes are widened by one ulp
 * outwards (and to at least +-FLT_MIN around 0), so a ray with a zero direction component whose
 * origin lies exactly on a box plane cannot hit anything inside: a NaN from 0 * inf in the
 * slab test may then be dropped or propagated, either way the answer is right.
 * Returns false only when out of memory (bvh is then zeroed). */
bool rd_bvh_build(rd_bvh *bvh, const float *bmin, const float *bmax, uint32_t count,
                  const rd_bvh_options *opt);
/* Over triangles given as 9 floats each (their boxes, see rd_bvh_triangle_boxes). */
bool rd_bvh_build_triangles(rd_bvh *bvh, const float *positions, uint32_t tri_count,
                            const rd_bvh_options *opt);
/* One BVH per mesh into out[0 .. mesh_count), the meshes built in parallel on one pool
 * (opt->threads). Each result equals rd_bvh_build_triangles of that mesh. Returns false when
 * out of memory, with every out[] zeroed. */
bool rd_bvh_build_many(rd_bvh *out, const rd_bvh_mesh *meshes, uint32_t mesh_count,
                       const rd_bvh_options *opt);
void rd_bvh_destroy(rd_bvh *bvh); /* idempotent */

/* Boxes of triangles (9 floats each) as the builders see them: a triangle with a non-finite
 * vertex gets the empty box [+inf, -inf]. */
void rd_bvh_triangle_boxes(const float *positions, uint32_t tri_count, float *bmin, float *bmax);

/* Surface area heuristic cost of a built tree, normalised by the root's area: the sum over
 * interior nodes of SAH_TRAVERSAL * A(node) plus over leaves of SAH_INTERSECT * A * count,
 * divided by A(root); 0 when the root box is empty or flat. Lower is better. */
double rd_bvh_sah_cost(const rd_bvh *bvh);

/* Node field accessors (the uint bits stored in the w components). */
uint32_t rd_bvh_node_first(const pc_bvh_node *n); /* left child or first primitive */
uint32_t rd_bvh_node_count(const pc_bvh_node *n); /* 0 for interior nodes */

/* Watertight ray/triangle intersection (Woop, Benthin, Wald, JCGT 2013), the same arithmetic
 * as shaders/trace.glsl. Returns true for a hit with tmin < t < tmax; u, v are the
 * barycentrics of v1 and v2; *backface is true when the ray meets the triangle's back
 * (counter-clockwise front). */
bool rd_ray_triangle(const float org[3], const float dir[3], const float v0[3], const float v1[3],
                     const float v2[3], float tmin, float tmax, float *t, float *u, float *v,
                     bool *backface);

/* Ray origins off surfaces, the CPU twins of shaders/trace.glsl's (the same arithmetic).
 * rd_ray_offset_distance: how far a ray leaving a surface point moves along its normal, given
 * the sum of the magnitudes its computation met (shaders/common.glsl, ray_offset_scale: for an
 * untransformed triangle, its largest vertex coordinate plus the point's): PC_RAY_OFFSET_REL of
 * it, Wächter and Binder's 256 ulps (Ray Tracing Gems, ch. 6) of those magnitudes; 0 for a
 * non-finite scale. rd_offset_ray_origin: p moved by offset along n (unit, toward the side the
 * new ray leaves from). */
float rd_ray_offset_distance(float scale);
void rd_offset_ray_origin(const float p[3], const float n[3], float offset, float out[3]);

/* Closest hit over a triangle BLAS on the CPU (for tests and picking). positions are the
 * mesh's triangles in their original order. Returns the original triangle index or -1. */
int64_t rd_bvh_closest_triangle(const rd_bvh *bvh, const float *positions, const float org[3],
                                const float dir[3], float tmin, float tmax, float *t_out);

#endif
