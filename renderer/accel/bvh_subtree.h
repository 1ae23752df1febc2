/* bvh_subtree.h: the record layout of the multi-threaded builder and its single-threaded
 * part (bvh_subtree.c): binning, partitioning and whole subtrees built by one thread.
 * Internal to bvh_build.c and bvh_subtree.c. */
#ifndef RD_BVH_SUBTREE_H
#define RD_BVH_SUBTREE_H

#include "renderer/accel/bvh_internal.h"

/* A primitive: its box and original index; the centroid is derived from the box
 * (bvh_centroid) wherever it is needed, always with the same arithmetic. */
typedef struct bvh_rec {
    float lo[4]; /* lo[3]: the original index (bvh_rec_id) */
    float hi[4]; /* hi[3]: 0 */
} bvh_rec;
_Static_assert(sizeof(bvh_rec) == 32, "two records per cache line");

typedef struct bvh_bin_setup {
    bool use[3];
    double cmin[3], scale[3];
    uint32_t bins;
} bvh_bin_setup;

/* The index rides in lane 3 so that boxes load and update as 4-wide vectors; its bits are
 * flipped at bit 30 so the lane never holds a denormal (whose arithmetic would trap into
 * microcode in the 4-wide centroid): it is a float >= 2, inf or NaN, all harmless there. */
#define BVH_REC_ID_FLIP 0x40000000u

static inline uint32_t bvh_rec_id(const bvh_rec *r)
{
    return pc_f2u(r->lo[3]) ^ BVH_REC_ID_FLIP;
}

static inline bvh_rec bvh_rec_make(const float lo[3], const float hi[3], uint32_t id)
{
    return (bvh_rec){{lo[0], lo[1], lo[2], pc_u2f(id ^ BVH_REC_ID_FLIP)}, {hi[0], hi[1], hi[2], 0}};
}

/* All four lanes, so that the compiler can use 4-wide arithmetic, min and max. */
static inline void bvh_rec_bounds_add(bvh_bounds *b, const bvh_rec *p)
{
    for (int a = 0; a < 4; a++) {
        float c = bvh_centroid(p->lo[a], p->hi[a]);
        b->lo[a] = p->lo[a] < b->lo[a] ? p->lo[a] : b->lo[a];
        b->hi[a] = p->hi[a] > b->hi[a] ? p->hi[a] : b->hi[a];
        b->clo[a] = c < b->clo[a] ? c : b->clo[a];
        b->chi[a] = c > b->chi[a] ? c : b->chi[a];
    }
}

static inline bool bvh_goes_left(const bvh_rec *q, int axis, const bvh_bin_setup *s, uint32_t split)
{
    float c = bvh_centroid(q->lo[axis], q->hi[axis]);
    return bvh_bin_of(c, s->cmin[axis], s->scale[axis], s->bins) < split;
}

typedef struct bvh_seq_builder {
    bvh_rec *r;         /* the record array holding the subtree's range */
    pc_bvh_node *nodes; /* local: root at 0; interior children local, leaf first global */
    uint32_t count;     /* nodes used */
    uint32_t bins, max_leaf;
    uint32_t depth; /* deepest leaf, absolute */
    bvh_bin bin[3][BVH_MAX_BINS];
} bvh_seq_builder;

/* Bounds of records [begin, end). */
void bvh_rec_bounds_of(const bvh_rec *r, uint32_t begin, uint32_t end, bvh_bounds *b);
/* Bins records [begin, end) into out (reset first). */
void bvh_bin_range(const bvh_rec *r, uint32_t begin, uint32_t end, const bvh_bin_setup *s,
                   bvh_bin out[3][BVH_MAX_BINS]);
bool bvh_centroids_coincide(const bvh_bounds *bd);
/* Whether a node of n prims at depth must switch to median splits to respect the cap. */
bool bvh_near_cap(uint32_t n, uint32_t depth, uint32_t max_leaf);
/* Builds node ni of b over records [begin, end) with bounds bd, recursively: the reference's
 * build_node (bvh_build_ref.c) on records, with the same decisions and node order. */
void bvh_seq_build_node(bvh_seq_builder *b, uint32_t ni, uint32_t begin, uint32_t end,
                        const bvh_bounds *bd, uint32_t depth, bool index_median);

#endif
