/* bvh_build.c: the multi-threaded binned-SAH builder (rd_bvh_build and friends).
 *
 * It takes the same split decisions as the reference builder (bvh_build_ref.c, after Wald,
 * "On fast Construction of SAH-based Bounding Volume Hierarchies", 2007: all three axes
 * binned, 16 bins, SAH leaf test at max_leaf, median splits near the depth cap), so the tree
 * quality is the reference's; what changes is how the work is done:
 *  - primitives are 32-byte {box, id} records (two per cache line); centroids are derived
 *    from the box in registers, identically everywhere they are needed;
 *  - binning alternates between two bin sets, so runs of neighbouring primitives that fall
 *    into the same bin do not serialise on one bin's min/max;
 *  - nodes of PAR_MIN_PRIMS or more are split "horizontally" (Wald 2007, sec. 4.2): their
 *    binning and a stable partition run over fixed chunks of PAR_CHUNK primitives as tasks,
 *    ping-ponging between two record arrays; smaller nodes are whole subtrees built as one
 *    task each ("vertically") into a scratch node range owned by their primitive range;
 *  - the nodes are then stitched, in parallel, into the order the recursive builder would
 *    have produced (children pairs allocated depth first, left before right).
 * Chunk boundaries depend on the node, never on the thread count, min/max merges are exact,
 * and every subtree is built by one thread: the output is bit-identical for any thread count.
 */
#include <assert.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/accel/bvh_subtree.h"
#include "renderer/accel/task_pool.h"

/* Chunk size and horizontal-split threshold (bvh.h); a subtree task below the threshold is
 * some tens of milliseconds of work. */
#define PAR_CHUNK RD_BVH_CHUNK_PRIMS
#define PAR_MIN_PRIMS RD_BVH_PAR_MIN_PRIMS

/* ---- the parallel build ----------------------------------------------------------------- */

typedef struct build_ctx build_ctx;

/* A node of the top of the tree: split horizontally (top: two children items) or the root
 * of a subtree built sequentially into scratch[2 * begin, 2 * end). */
typedef struct build_item {
    rd_task task; /* first member */
    build_ctx *ctx;
    bvh_bounds bd;
    uint32_t begin, end, depth;
    uint32_t buf; /* ctx->rec[buf] holds [begin, end) */
    bool index_median;
    bool top;
    struct build_item *child; /* two items, top only */
    uint32_t sub_nodes, sub_depth;
    uint32_t slot, base; /* final index of this node; of the subtree's second node */
} build_item;

struct build_ctx {
    bvh_rec *rec[2];
    pc_bvh_node *scratch;
    uint32_t bins, max_leaf;
    rd_task_pool *pool;
    rd_task_group group;
    atomic_bool oom;
    /* stitching */
    pc_bvh_node *nodes;
    uint32_t *prim_index;
};

typedef struct chunk_job {
    rd_task task; /* first member */
    const bvh_rec *src;
    bvh_rec *dst;
    uint32_t begin, end;
    const bvh_bin_setup *setup;
    int phase, axis;
    uint32_t split;
    bvh_bin bin[3][BVH_MAX_BINS];
    bvh_bounds left, right;
    uint32_t nleft, out_left, out_right;
} chunk_job;

enum { PHASE_BIN, PHASE_COUNT, PHASE_SCATTER };

static void chunk_run(rd_task *t)
{
    chunk_job *j = (chunk_job *)t;
    const bvh_bin_setup *s = j->setup;
    if (j->phase == PHASE_BIN) {
        bvh_bin_range(j->src, j->begin, j->end, s, j->bin);
    } else if (j->phase == PHASE_COUNT) {
        bvh_bounds_empty(&j->left);
        bvh_bounds_empty(&j->right);
        uint32_t nl = 0;
        for (uint32_t i = j->begin; i < j->end; i++) {
            bool l = bvh_goes_left(&j->src[i], j->axis, s, j->split);
            bvh_rec_bounds_add(l ? &j->left : &j->right, &j->src[i]);
            nl += l;
        }
        j->nleft = nl;
    } else { /* stable: each side keeps the source order */
        uint32_t l = j->out_left, r = j->out_right;
        for (uint32_t i = j->begin; i < j->end; i++) {
            if (bvh_goes_left(&j->src[i], j->axis, s, j->split))
                j->dst[l++] = j->src[i];
            else
                j->dst[r++] = j->src[i];
        }
    }
}

static void run_phase(build_ctx *ctx, chunk_job *jobs, uint32_t n, int phase)
{
    rd_task_group g = {0};
    for (uint32_t k = 0; k < n; k++) {
        jobs[k].phase = phase;
        rd_task_submit(ctx->pool, &g, &jobs[k].task, chunk_run);
    }
    rd_task_wait(ctx->pool, &g);
}

static bool item_is_top(const build_item *it)
{
    uint32_t n = it->end - it->begin;
    return n >= PAR_MIN_PRIMS && !it->index_median && !bvh_centroids_coincide(&it->bd) &&
           !bvh_near_cap(n, it->depth, it->ctx->max_leaf);
}

static void item_run(rd_task *t);

static void item_init(build_item *it, build_ctx *ctx, uint32_t begin, uint32_t end,
                      const bvh_bounds *bd, uint32_t depth, uint32_t buf, bool index_median)
{
    memset(it, 0, sizeof *it);
    it->ctx = ctx;
    it->bd = *bd;
    it->begin = begin;
    it->end = end;
    it->depth = depth;
    it->buf = buf;
    it->index_median = index_median;
}

/* Splits a top item over chunks: bin, sweep, count, scatter into the other record array. */
static bool split_horizontal(build_item *it)
{
    build_ctx *ctx = it->ctx;
    const uint32_t n = it->end - it->begin, chunks = (n + PAR_CHUNK - 1) / PAR_CHUNK;
    chunk_job *jobs = malloc((size_t)chunks * sizeof *jobs);
    build_item *child = malloc(2 * sizeof *child);
    if (!jobs || !child) {
        free(jobs);
        free(child);
        return false;
    }
    bvh_bin_setup s = {.bins = bvh_node_bins(n, ctx->bins)};
    bvh_bin_params(&it->bd, s.bins, s.use, s.cmin, s.scale);
    for (uint32_t k = 0; k < chunks; k++) {
        chunk_job *j = &jobs[k];
        j->src = ctx->rec[it->buf];
        j->dst = ctx->rec[it->buf ^ 1];
        j->begin = it->begin + k * PAR_CHUNK;
        j->end = k + 1 < chunks ? j->begin + PAR_CHUNK : it->end;
        j->setup = &s;
    }
    run_phase(ctx, jobs, chunks, PHASE_BIN);
    for (uint32_t k = 1; k < chunks; k++)
        bvh_bins_merge(jobs[0].bin, (const bvh_bin(*)[BVH_MAX_BINS])jobs[k].bin, s.bins);
    sah_split sp =
        bvh_sweep_bins((const bvh_bin(*)[BVH_MAX_BINS])jobs[0].bin, s.use, s.bins, &it->bd);
    assert(sp.axis >= 0); /* n > max_leaf, so never a leaf either */
    for (uint32_t k = 0; k < chunks; k++) {
        jobs[k].axis = sp.axis;
        jobs[k].split = sp.bin;
    }
    run_phase(ctx, jobs, chunks, PHASE_COUNT);
    bvh_bounds left, right;
    bvh_bounds_empty(&left);
    bvh_bounds_empty(&right);
    uint32_t nleft = 0;
    for (uint32_t k = 0; k < chunks; k++) {
        jobs[k].out_left = it->begin + nleft;
        nleft += jobs[k].nleft;
        bvh_bounds_merge(&left, &jobs[k].left);
        bvh_bounds_merge(&right, &jobs[k].right);
    }
    uint32_t mid = it->begin + nleft, right_at = mid;
    for (uint32_t k = 0; k < chunks; k++) {
        jobs[k].out_right = right_at;
        right_at += (jobs[k].end - jobs[k].begin) - jobs[k].nleft;
    }
    assert(mid > it->begin && mid < it->end);
    run_phase(ctx, jobs, chunks, PHASE_SCATTER);
    free(jobs);
    item_init(&child[0], ctx, it->begin, mid, &left, it->depth + 1, it->buf ^ 1, false);
    item_init(&child[1], ctx, mid, it->end, &right, it->depth + 1, it->buf ^ 1, false);
    it->child = child;
    return true;
}

static void item_run(rd_task *t)
{
    build_item *it = (build_item *)t;
    build_ctx *ctx = it->ctx;
    if (atomic_load(&ctx->oom)) return;
    if (item_is_top(it)) {
        it->top = true;
        if (!split_horizontal(it)) {
            atomic_store(&ctx->oom, true);
            return;
        }
        rd_task_submit(ctx->pool, &ctx->group, &it->child[1].task, item_run);
        rd_task_submit(ctx->pool, &ctx->group, &it->child[0].task, item_run);
        return;
    }
    bvh_seq_builder b = {.r = ctx->rec[it->buf],
                         .nodes = ctx->scratch + 2 * (size_t)it->begin,
                         .count = 1,
                         .bins = ctx->bins,
                         .max_leaf = ctx->max_leaf,
                         .depth = it->depth};
    bvh_seq_build_node(&b, 0, it->begin, it->end, &it->bd, it->depth, it->index_median);
    it->sub_nodes = b.count;
    it->sub_depth = b.depth;
}

/* ---- stitching -------------------------------------------------------------------------- */

/* Gives every item its final node index, as the recursive builder would: a node's children
 * pair is allocated when the node is built, then the left subtree, then the right. */
static void assign_slots(build_item *it, uint32_t slot, uint32_t *next, uint32_t *depth)
{
    it->slot = slot;
    if (it->top) {
        it->base = *next;
        *next += 2;
        assign_slots(&it->child[0], it->base, next, depth);
        assign_slots(&it->child[1], it->base + 1, next, depth);
    } else {
        it->base = *next;
        *next += it->sub_nodes - 1;
        if (it->sub_depth > *depth) *depth = it->sub_depth;
    }
}

static void copy_subtree(rd_task *t)
{
    build_item *it = (build_item *)t;
    build_ctx *ctx = it->ctx;
    const pc_bvh_node *src = ctx->scratch + 2 * (size_t)it->begin;
    for (uint32_t i = 0; i < it->sub_nodes; i++) {
        pc_bvh_node n = src[i];
        if (rd_bvh_node_count(&n) == 0) n.bmin.w = pc_u2f(it->base + rd_bvh_node_first(&n) - 1);
        bvh_widen_node(&n);
        ctx->nodes[i == 0 ? it->slot : it->base + i - 1] = n;
    }
    const bvh_rec *r = ctx->rec[it->buf];
    for (uint32_t i = it->begin; i < it->end; i++)
        ctx->prim_index[i] = bvh_rec_id(&r[i]);
}

/* Writes top nodes and submits a copy task per subtree. */
static void stitch(build_item *it)
{
    build_ctx *ctx = it->ctx;
    if (it->top) {
        pc_bvh_node *n = &ctx->nodes[it->slot];
        bvh_node_set(n, it->bd.lo, it->bd.hi, it->base, 0);
        bvh_widen_node(n);
        stitch(&it->child[0]);
        stitch(&it->child[1]);
    } else {
        rd_task_submit(ctx->pool, &ctx->group, &it->task, copy_subtree);
    }
}

static void free_items(build_item *it)
{
    if (!it->child) return;
    free_items(&it->child[0]);
    free_items(&it->child[1]);
    free(it->child);
}

/* ---- records from the input ------------------------------------------------------------- */

typedef struct prim_source {
    const float *bmin, *bmax; /* boxes, or */
    const float *tris;        /* triangles, 9 floats each */
    uint32_t count;
} prim_source;

typedef struct fill_job {
    rd_task task; /* first member */
    const prim_source *src;
    bvh_rec *dst;
    uint32_t begin, end;
    int phase;
    uint32_t valid;              /* phase 0 */
    uint32_t out_valid, out_bad; /* phase 1 */
    bvh_bounds vb;               /* phase 1: bounds of the valid prims */
} fill_job;

static inline bool source_box(const prim_source *s, uint32_t i, float lo[3], float hi[3])
{
    if (s->tris) {
        bvh_triangle_box(s->tris + 9 * (size_t)i, lo, hi);
    } else {
        memcpy(lo, s->bmin + 3 * (size_t)i, 3 * sizeof(float));
        memcpy(hi, s->bmax + 3 * (size_t)i, 3 * sizeof(float));
    }
    return bvh_box_valid(lo, hi);
}

/* Phase 0 counts valid prims; phase 1 writes valid ones to the front and non-finite ones
 * (empty box) to the back, both in input order. */
static void fill_run(rd_task *t)
{
    fill_job *j = (fill_job *)t;
    float lo[3], hi[3];
    if (j->phase == 0) {
        uint32_t v = 0;
        for (uint32_t i = j->begin; i < j->end; i++)
            v += source_box(j->src, i, lo, hi);
        j->valid = v;
        return;
    }
    bvh_bounds_empty(&j->vb);
    uint32_t v = j->out_valid, b = j->out_bad;
    for (uint32_t i = j->begin; i < j->end; i++) {
        if (source_box(j->src, i, lo, hi)) {
            bvh_rec q = bvh_rec_make(lo, hi, i);
            j->dst[v++] = q;
            bvh_rec_bounds_add(&j->vb, &q);
        } else {
            const float e_lo[3] = {INFINITY, INFINITY, INFINITY};
            const float e_hi[3] = {-INFINITY, -INFINITY, -INFINITY};
            bvh_rec q = bvh_rec_make(e_lo, e_hi, i);
            j->dst[b++] = q;
        }
    }
}

/* The whole build over src with an optional pool. Returns false when out of memory. */
static bool build_core(rd_bvh *bvh, const prim_source *src, const rd_bvh_options *opt,
                       rd_task_pool *pool)
{
    memset(bvh, 0, sizeof *bvh);
    const uint32_t count = src->count;
    build_ctx ctx = {.pool = pool};
    atomic_init(&ctx.oom, false);
    bvh_resolve_options(opt, &ctx.bins, &ctx.max_leaf);
    bvh->prim_index = malloc((size_t)(count ? count : 1) * sizeof *bvh->prim_index);
    if (!bvh->prim_index) return false;
    if (count == 0) {
        bvh->nodes = malloc(sizeof *bvh->nodes);
        if (!bvh->nodes) {
            rd_bvh_destroy(bvh);
            return false;
        }
        bvh_bounds e;
        bvh_bounds_empty(&e);
        bvh_node_set(&bvh->nodes[0], e.lo, e.hi, 0, 0);
        bvh->node_count = 1;
        return true;
    }
    const uint32_t chunks = (count + PAR_CHUNK - 1) / PAR_CHUNK;
    ctx.rec[0] = malloc((size_t)count * sizeof(bvh_rec));
    ctx.rec[1] = count >= PAR_MIN_PRIMS ? malloc((size_t)count * sizeof(bvh_rec)) : NULL;
    ctx.scratch = malloc(2 * (size_t)count * sizeof(pc_bvh_node));
    fill_job *fill = malloc((size_t)chunks * sizeof *fill);
    build_item *root = calloc(1, sizeof *root);
    bool ok = ctx.rec[0] && (ctx.rec[1] || count < PAR_MIN_PRIMS) && ctx.scratch && fill && root;
    if (ok) {
        for (uint32_t k = 0; k < chunks; k++) {
            fill[k] = (fill_job){.src = src, .dst = ctx.rec[0], .begin = k * PAR_CHUNK};
            fill[k].end = k + 1 < chunks ? fill[k].begin + PAR_CHUNK : count;
        }
        rd_task_group g = {0};
        for (uint32_t k = 0; k < chunks; k++)
            rd_task_submit(pool, &g, &fill[k].task, fill_run);
        rd_task_wait(pool, &g);
        uint32_t valid = 0;
        for (uint32_t k = 0; k < chunks; k++)
            valid += fill[k].valid;
        uint32_t v = 0, b = valid;
        for (uint32_t k = 0; k < chunks; k++) {
            fill[k].phase = 1;
            fill[k].out_valid = v;
            fill[k].out_bad = b;
            v += fill[k].valid;
            b += (fill[k].end - fill[k].begin) - fill[k].valid;
            rd_task_submit(pool, &g, &fill[k].task, fill_run);
        }
        rd_task_wait(pool, &g);
        bvh_bounds vb, ib;
        bvh_bounds_empty(&vb);
        for (uint32_t k = 0; k < chunks; k++)
            bvh_bounds_merge(&vb, &fill[k].vb);
        bvh_rec_bounds_of(ctx.rec[0], valid, count, &ib);

        if (valid == 0 || valid == count) {
            item_init(root, &ctx, 0, count, valid ? &vb : &ib, 0, 0, valid == 0);
            rd_task_submit(pool, &ctx.group, &root->task, item_run);
        } else {
            /* Root: left = finite prims (SAH), right = non-finite prims (empty box, by index). */
            item_init(root, &ctx, 0, count, &vb, 0, 0, false);
            root->top = true;
            root->child = malloc(2 * sizeof *root->child);
            if (root->child) {
                item_init(&root->child[0], &ctx, 0, valid, &vb, 1, 0, false);
                item_init(&root->child[1], &ctx, valid, count, &ib, 1, 0, true);
                rd_task_submit(pool, &ctx.group, &root->child[1].task, item_run);
                rd_task_submit(pool, &ctx.group, &root->child[0].task, item_run);
            } else {
                atomic_store(&ctx.oom, true);
            }
        }
        rd_task_wait(pool, &ctx.group);
        ok = !atomic_load(&ctx.oom);
    }
    uint32_t node_count = 1, depth = 0;
    if (ok) {
        assign_slots(root, 0, &node_count, &depth);
        ctx.nodes = malloc((size_t)node_count * sizeof *ctx.nodes);
        ok = ctx.nodes != NULL;
    }
    if (ok) {
        ctx.prim_index = bvh->prim_index;
        stitch(root);
        rd_task_wait(pool, &ctx.group);
        bvh->nodes = ctx.nodes;
        bvh->node_count = node_count;
        bvh->prim_count = count;
        bvh->depth = depth;
    }
    if (root) free_items(root);
    free(root);
    free(fill);
    free(ctx.scratch);
    free(ctx.rec[0]);
    free(ctx.rec[1]);
    if (!ok) rd_bvh_destroy(bvh);
    return ok;
}

/* ---- entry points ----------------------------------------------------------------------- */

static uint32_t resolve_threads(const rd_bvh_options *opt)
{
    return opt && opt->threads ? opt->threads : rd_online_cores();
}

/* A pool when the work is worth one; NULL (build on this thread) otherwise or when threads
 * cannot start, which changes nothing in the output. */
static rd_task_pool *pool_for(const rd_bvh_options *opt, uint64_t prims)
{
    uint32_t threads = resolve_threads(opt);
    return threads > 1 && prims >= PAR_CHUNK ? rd_task_pool_create(threads) : NULL;
}

bool rd_bvh_build(rd_bvh *bvh, const float *bmin, const float *bmax, uint32_t count,
                  const rd_bvh_options *opt)
{
    prim_source src = {.bmin = bmin, .bmax = bmax, .count = count};
    rd_task_pool *pool = pool_for(opt, count >= PAR_MIN_PRIMS ? count : 0);
    bool ok = build_core(bvh, &src, opt, pool);
    rd_task_pool_destroy(pool);
    return ok;
}

bool rd_bvh_build_triangles(rd_bvh *bvh, const float *positions, uint32_t tri_count,
                            const rd_bvh_options *opt)
{
    rd_bvh_mesh m = {.positions = positions, .tri_count = tri_count};
    return rd_bvh_build_many(bvh, &m, 1, opt);
}

typedef struct mesh_job {
    rd_task task; /* first member */
    rd_bvh *out;
    prim_source src;
    const rd_bvh_options *opt;
    rd_task_pool *pool;
    bool ok;
} mesh_job;

static void mesh_run(rd_task *t)
{
    mesh_job *j = (mesh_job *)t;
    j->ok = build_core(j->out, &j->src, j->opt, j->pool);
}

static int by_key(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

bool rd_bvh_build_many(rd_bvh *out, const rd_bvh_mesh *meshes, uint32_t mesh_count,
                       const rd_bvh_options *opt)
{
    uint64_t total = 0;
    for (uint32_t m = 0; m < mesh_count; m++)
        total += meshes[m].tri_count;
    /* One mesh below PAR_MIN_PRIMS is a single task: no pool for it. */
    rd_task_pool *pool = pool_for(opt, mesh_count > 1 || total >= PAR_MIN_PRIMS ? total : 0);
    for (uint32_t m = 0; m < mesh_count; m++)
        memset(&out[m], 0, sizeof out[m]);
    mesh_job *jobs = calloc(mesh_count ? mesh_count : 1, sizeof *jobs);
    uint64_t *order = malloc((mesh_count ? mesh_count : 1) * sizeof *order);
    bool ok = jobs && order;
    if (ok) {
        /* Largest last: the pool runs the newest task first, so big meshes start early
         * (key: size, then index). */
        for (uint32_t m = 0; m < mesh_count; m++)
            order[m] = (uint64_t)meshes[m].tri_count << 32 | m;
        qsort(order, mesh_count, sizeof *order, by_key);
        rd_task_group g = {0};
        for (uint32_t k = 0; k < mesh_count; k++) {
            uint32_t m = (uint32_t)order[k];
            jobs[m] = (mesh_job){.out = &out[m], .opt = opt, .pool = pool};
            jobs[m].src = (prim_source){.tris = meshes[m].positions, .count = meshes[m].tri_count};
            rd_task_submit(pool, &g, &jobs[m].task, mesh_run);
        }
        rd_task_wait(pool, &g);
        for (uint32_t m = 0; m < mesh_count; m++)
            ok = ok && jobs[m].ok;
        if (!ok)
            for (uint32_t m = 0; m < mesh_count; m++)
                rd_bvh_destroy(&out[m]);
    }
    free(order);
    free(jobs);
    rd_task_pool_destroy(pool);
    return ok;
}
