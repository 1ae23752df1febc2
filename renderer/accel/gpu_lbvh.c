/* gpu_lbvh.c: a linear BVH built on the GPU (see gpu_lbvh.h). */
#include "renderer/accel/gpu_lbvh.h"
#include "renderer/accel/gpu_ploc.h"

#include <assert.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "shaders/gpu_types.h"
#include "shaders/lbvh_bounds.spv.h"
#include "shaders/lbvh_boxes.spv.h"
#include "shaders/lbvh_hierarchy.spv.h"
#include "shaders/lbvh_morton.spv.h"
#include "shaders/lbvh_remap.spv.h"
#include "shaders/lbvh_scan.spv.h"
#include "shaders/lbvh_sort.spv.h"
#include "shaders/ploc_emit.spv.h"
#include "shaders/ploc_init.spv.h"
#include "shaders/ploc_round.spv.h"

#define PUSH_SIZE ((uint32_t)sizeof(pc_push))
static const rd_pipeline_desc kPipelines[] = {
    RD_PIPELINE_DESC(rd_gpu_lbvh_builder, bounds, "lbvh_bounds", pc_spv_lbvh_bounds, PUSH_SIZE),
    RD_PIPELINE_DESC(rd_gpu_lbvh_builder, morton, "lbvh_morton", pc_spv_lbvh_morton, PUSH_SIZE),
    RD_PIPELINE_DESC(rd_gpu_lbvh_builder, sort, "lbvh_sort", pc_spv_lbvh_sort, PUSH_SIZE),
    RD_PIPELINE_DESC(rd_gpu_lbvh_builder, hierarchy, "lbvh_hierarchy", pc_spv_lbvh_hierarchy,
                     PUSH_SIZE),
    RD_PIPELINE_DESC(rd_gpu_lbvh_builder, boxes, "lbvh_boxes", pc_spv_lbvh_boxes, PUSH_SIZE),
    RD_PIPELINE_DESC(rd_gpu_lbvh_builder, scan, "lbvh_scan", pc_spv_lbvh_scan, PUSH_SIZE),
    RD_PIPELINE_DESC(rd_gpu_lbvh_builder, remap, "lbvh_remap", pc_spv_lbvh_remap, PUSH_SIZE),
    RD_PIPELINE_DESC(rd_gpu_lbvh_builder, ploc_init, "ploc_init", pc_spv_ploc_init, PUSH_SIZE),
    RD_PIPELINE_DESC(rd_gpu_lbvh_builder, ploc_round, "ploc_round", pc_spv_ploc_round, PUSH_SIZE),
    RD_PIPELINE_DESC(rd_gpu_lbvh_builder, ploc_emit, "ploc_emit", pc_spv_ploc_emit, PUSH_SIZE),
};
#define PIPELINE_COUNT (sizeof kPipelines / sizeof kPipelines[0])

/* Groups in one dimension of a dispatch: the least maxComputeWorkGroupCount Vulkan allows. */
#define MAX_GROUPS_PER_DIM 65535u
/* The scratch layout of shaders/lbvh.glsl, in uints: 8 of bounds (word 6: the output's node
 * count, word 7 its depth), 2N of keys, then leaf_slot, node_slot, done (n each), range and alive (2n each), cost
 * (n), 4 of indirect dispatch; then, 16-byte aligned, the working tree of 2n - 1 nodes. */
#define KEYS_AT 8u
#define TAIL_WORDS 8u
#define ARGS_WORDS 4u
/* Passes of lbvh_boxes after the leaves: the tree's internal levels, at most 64. */
#define BOX_PASSES 64u

rd_vk_result rd_gpu_lbvh_builder_create(rd_vk *vk, rd_gpu_lbvh_builder *b, char *err, size_t errlen)
{
    memset(b, 0, sizeof *b); /* row_groups 0: the per-dimension limit */
    return rd_pipelines_create(vk, b, kPipelines, PIPELINE_COUNT, err, errlen);
}

void rd_gpu_lbvh_builder_destroy(rd_vk *vk, rd_gpu_lbvh_builder *b)
{
    rd_pipelines_destroy(vk, b, kPipelines, PIPELINE_COUNT);
}

/* Keys lbvh_morton writes (the layout of shaders/lbvh.glsl): a power of two, at least 128 (the
 * padding keys past n, all ones, are not sorted). */
static uint64_t padded_keys(uint32_t n)
{
    uint64_t p = 2u * PC_WG_1D;
    while (p < n)
        p <<= 1;
    return p;
}

/* The radix sort (shaders/lbvh_sort.comp; its constants in gpu_types.h). */
#define SORT_PASSES PC_LBVH_SORT_PASSES
#define SORT_DIGITS PC_LBVH_SORT_DIGITS
#define SORT_TILE PC_LBVH_SORT_TILE
#define SORT_SCAN_BLOCK PC_LBVH_SORT_SCAN_BLOCK

static uint32_t sort_tiles(uint32_t n)
{
    return (n + SORT_TILE - 1) / SORT_TILE;
}

static uint32_t sort_hist_words(uint32_t n)
{
    return SORT_DIGITS * sort_tiles(n);
}

static uint32_t sort_scan_blocks(uint32_t n)
{
    return (sort_hist_words(n) + SORT_SCAN_BLOCK - 1) / SORT_SCAN_BLOCK;
}

/* The sort's scratch, in uints: the other key buffer (2n), hist, then the block sums. */
uint64_t rd_gpu_lbvh_sort_scratch_bytes(uint32_t n)
{
    return 4 * (2 * (uint64_t)n + sort_hist_words(n) + sort_scan_blocks(n));
}

uint32_t rd_gpu_lbvh_node_count(uint32_t tri_count)
{
    return tri_count ? 2 * tri_count - 1 : 1;
}

/* Byte offset of the working tree in the scratch. */
#define SCAN_BLOCK PC_LBVH_SCAN_BLOCK
_Static_assert(SCAN_BLOCK % PC_WG_1D == 0, "whole chunks a thread");

static uint32_t scan_blocks(uint32_t n)
{
    return n ? (2 * n - 1 + SCAN_BLOCK - 1) / SCAN_BLOCK : 0;
}

static uint64_t work_nodes_at(uint32_t n)
{
    uint64_t words =
        KEYS_AT + 2 * padded_keys(n) + TAIL_WORDS * (uint64_t)n + ARGS_WORDS + scan_blocks(n);
    return (4 * words + 15) & ~(uint64_t)15;
}

/* Word offset of the PLOC area (shaders/ploc.glsl), after the keys: a multiple of 4. */
static uint32_t ploc_at(uint32_t n)
{
    return (uint32_t)((KEYS_AT + 2 * padded_keys(n) + 3) & ~(uint64_t)3);
}

/* Byte offset of the sort's scratch (rd_gpu_lbvh_sort_scratch_bytes), after the working tree
 * (LBVH) or the PLOC area. */
static uint64_t sort_at(const rd_gpu_lbvh_builder *b, uint32_t n)
{
    if (b->method == RD_GPU_BVH_PLOC)
        return (4 * (ploc_at(n) + rd_gpu_ploc_words(n)) + 15) & ~(uint64_t)15;
    return work_nodes_at(n) + sizeof(pc_bvh_node) * (uint64_t)rd_gpu_lbvh_node_count(n);
}

uint64_t rd_gpu_lbvh_scratch_bytes(const rd_gpu_lbvh_builder *b, uint32_t tri_count)
{
    return sort_at(b, tri_count) + rd_gpu_lbvh_sort_scratch_bytes(tri_count);
}

static uint32_t max_leaf_def(uint32_t max_leaf)
{
    return max_leaf == 0 ? 4 : max_leaf > RD_BVH_MAX_LEAF ? RD_BVH_MAX_LEAF : max_leaf;
}

static uint64_t groups(uint64_t threads)
{
    return (threads + PC_WG_1D - 1) / PC_WG_1D;
}

/* Groups a row of a dispatch: the builder's test hook, else the per-dimension limit. */
uint32_t rd_gpu_lbvh_row_groups(const rd_gpu_lbvh_builder *b)
{
    return b->row_groups && b->row_groups < MAX_GROUPS_PER_DIM ? b->row_groups : MAX_GROUPS_PER_DIM;
}

/* Dispatches count groups of 1D work as rows of rd_gpu_lbvh_row_groups(b) groups (x) in y, the
 * shaders' lbvh_group() (shaders/lbvh.glsl) numbering them; the last row's extra groups return. */
void rd_gpu_lbvh_dispatch_rows(rd_cmd *c, const rd_gpu_lbvh_builder *b, const rd_pipeline *p,
                               const pc_push *push, uint64_t count)
{
    uint64_t row = rd_gpu_lbvh_row_groups(b);
    if (count < row) row = count;
    if (row == 0) return;
    uint64_t rows = (count + row - 1) / row;
    assert(rows <= MAX_GROUPS_PER_DIM);
    rd_cmd_dispatch(c, p, push, (uint32_t)row, (uint32_t)rows, 1);
}

void rd_gpu_lbvh_record_sort(rd_cmd *c, const rd_gpu_lbvh_builder *b, VkDeviceAddress keys,
                             uint32_t n, VkDeviceAddress sort_scratch)
{
    assert(n <= RD_GPU_LBVH_MAX_TRIANGLES);
    if (n == 0) return;
    uint32_t tiles = sort_tiles(n), words = sort_hist_words(n);
    VkDeviceAddress other = sort_scratch, hist = other + 8 * (uint64_t)n;
    VkDeviceAddress sums = hist + 4 * (uint64_t)words;
    _Static_assert(SORT_PASSES % 2 == 0, "the sorted keys end in keys");
    for (uint32_t pass = 0; pass < SORT_PASSES; pass++) {
        VkDeviceAddress from = pass % 2 ? other : keys, to = pass % 2 ? keys : other;
        uint32_t shift = 8 * pass;
        pc_push p = {.buf0 = from, .buf2 = hist, .params = {n, shift, tiles, 0}};
        rd_gpu_lbvh_dispatch_rows(c, b, &b->sort, &p, tiles);
        rd_cmd_barrier(c);
        p = (pc_push){.buf1 = sums, .buf2 = hist, .params = {words, shift, tiles, 1}};
        rd_gpu_lbvh_dispatch_rows(c, b, &b->sort, &p, sort_scan_blocks(n));
        rd_cmd_barrier(c);
        p.params.w = 2;
        rd_cmd_dispatch(c, &b->sort, &p, 1, 1, 1);
        rd_cmd_barrier(c);
        p.params.w = 3;
        rd_gpu_lbvh_dispatch_rows(c, b, &b->sort, &p, sort_scan_blocks(n));
        rd_cmd_barrier(c);
        p = (pc_push){.buf0 = from, .buf1 = to, .buf2 = hist, .params = {n, shift, tiles, 4}};
        rd_gpu_lbvh_dispatch_rows(c, b, &b->sort, &p, tiles);
        rd_cmd_barrier(c);
    }
}

void rd_gpu_lbvh_record(rd_cmd *c, const rd_gpu_lbvh_builder *b, VkDeviceAddress positions,
                        uint32_t tri_count, uint32_t max_leaf, VkDeviceAddress nodes,
                        VkDeviceAddress prim_index, const rd_buffer *scratch_buf, rd_timer *timer)
{
    VkDeviceAddress scratch = scratch_buf->address;
    uint32_t n = tri_count, ml = max_leaf_def(max_leaf);
    VkDeviceAddress work = scratch + work_nodes_at(n);
    uint64_t nkeys = padded_keys(n);
    assert(n <= RD_GPU_LBVH_MAX_TRIANGLES);
    /* the most threads of a pass (N padded keys, 2n - 1 nodes), and every uint word index of
     * the scratch, fit in 32 bits */
    _Static_assert(2ull * RD_GPU_LBVH_MAX_TRIANGLES * (2 + TAIL_WORDS) + KEYS_AT + ARGS_WORDS +
                           2ull * RD_GPU_LBVH_MAX_TRIANGLES / SCAN_BLOCK <
                       (1ull << 32),
                   "32-bit indices");
    uint32_t leaf_at = (uint32_t)(KEYS_AT + 2 * nkeys);
    pc_push push = {.buf0 = positions, .buf2 = scratch, .params = {n, 0, 0, 0}};
    if (n > 0) {
        rd_cmd_dispatch(c, &b->bounds, &push, 1, 1, 1); /* reset */
        rd_cmd_barrier(c);
        push.params.z = 1;
        rd_gpu_lbvh_dispatch_rows(c, b, &b->bounds, &push, groups(n));
        rd_cmd_barrier(c);
        push.params = (pc_uvec4){n, (uint32_t)nkeys, 0, 0};
        rd_gpu_lbvh_dispatch_rows(c, b, &b->morton, &push, groups(nkeys));
        rd_cmd_barrier(c);
        if (timer) rd_timer_mark(c, timer, "lbvh_keys");
        rd_gpu_lbvh_record_sort(c, b, scratch + 4 * KEYS_AT, n, scratch + sort_at(b, n));
        if (timer) rd_timer_mark(c, timer, "lbvh_sort");
    }
    if (b->method == RD_GPU_BVH_PLOC) {
        rd_gpu_ploc_record(c, b, positions, n, ml, nodes, prim_index, scratch_buf, ploc_at(n),
                           timer);
        return;
    }
    pc_push h = {.buf0 = scratch,
                 .buf1 = n ? work : nodes,
                 .buf2 = prim_index,
                 .params = {n, leaf_at, 0, rd_gpu_lbvh_row_groups(b)}};
    rd_gpu_lbvh_dispatch_rows(c, b, &b->hierarchy, &h, groups(n > 1 ? n - 1 : 1));
    rd_cmd_barrier(c);
    if (timer) rd_timer_mark(c, timer, "lbvh_hierarchy");
    if (n > 0) {
        pc_push x = {
            .buf0 = positions, .buf1 = work, .buf2 = scratch, .params = {n, leaf_at, 0, ml}};
        rd_gpu_lbvh_dispatch_rows(c, b, &b->boxes, &x, groups(n)); /* the leaves */
        rd_cmd_barrier(c);
        VkDeviceSize args = 4 * ((VkDeviceSize)leaf_at + TAIL_WORDS * (VkDeviceSize)n);
        for (uint32_t k = 1; n > 1 && k <= BOX_PASSES; k++) {
            x.params.z = k;
            rd_cmd_dispatch_indirect(c, &b->boxes, &x, scratch_buf, args);
            rd_cmd_barrier(c);
        }
        if (timer) rd_timer_mark(c, timer, "lbvh_boxes");
        /* block sums, their scan, then each block's words */
        pc_push sc = {.buf2 = scratch, .params = {n, leaf_at, 0, 0}};
        rd_gpu_lbvh_dispatch_rows(c, b, &b->scan, &sc, scan_blocks(n));
        rd_cmd_barrier(c);
        sc.params.z = 1;
        rd_cmd_dispatch(c, &b->scan, &sc, 1, 1, 1);
        rd_cmd_barrier(c);
        sc.params.z = 2;
        rd_gpu_lbvh_dispatch_rows(c, b, &b->scan, &sc, scan_blocks(n));
        rd_cmd_barrier(c);
        pc_push rm = {.buf0 = work, .buf1 = nodes, .buf2 = scratch, .params = {n, leaf_at, 0, 0}};
        rd_gpu_lbvh_dispatch_rows(c, b, &b->remap, &rm, groups(2 * (uint64_t)n - 1));
        rd_cmd_barrier(c);
        if (timer) rd_timer_mark(c, timer, "lbvh_collapse");
    }
}

/* Levels below the root of a downloaded tree (a broken tree's walk stops at bad child indices
 * or after node_count visits: the tests catch such trees). */
static uint32_t tree_depth(const rd_bvh *bvh)
{
    uint32_t *stack = malloc(2 * (size_t)bvh->node_count * sizeof *stack), sp = 0, depth = 0;
    uint32_t visits = 0;
    if (!stack) {
        fprintf(stderr, "probecast: out of memory (GPU LBVH depth)\n");
        abort();
    }
    stack[sp++] = 0, stack[sp++] = 0;
    while (sp > 0 && visits++ < bvh->node_count) {
        uint32_t d = stack[--sp], ni = stack[--sp];
        const pc_bvh_node *nd = &bvh->nodes[ni];
        depth = d > depth ? d : depth;
        uint32_t first = rd_bvh_node_first(nd);
        if (rd_bvh_node_count(nd) != 0 || bvh->prim_count == 0) continue;
        if (first + 1 >= bvh->node_count || sp + 4 > 2 * bvh->node_count) continue;
        stack[sp++] = first, stack[sp++] = d + 1;
        stack[sp++] = first + 1, stack[sp++] = d + 1;
    }
    free(stack);
    return depth;
}

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

rd_vk_result rd_gpu_lbvh_build_download(rd_vk *vk, const rd_gpu_lbvh_builder *b,
                                        const float *positions, uint32_t tri_count,
                                        uint32_t max_leaf, rd_timer *timer, rd_bvh *out,
                                        double *gpu_ms, char *err, size_t errlen)
{
    memset(out, 0, sizeof *out);
    if (tri_count > RD_GPU_LBVH_MAX_TRIANGLES) {
        snprintf(err, errlen, "GPU LBVH: %u triangles, at most %u", tri_count,
                 RD_GPU_LBVH_MAX_TRIANGLES);
        return RD_VK_ERR_UNSUPPORTED;
    }
    uint32_t nn = rd_gpu_lbvh_node_count(tri_count);
    size_t pos_bytes = (size_t)tri_count * 9 * sizeof(float);
    size_t node_bytes = (size_t)nn * sizeof(pc_bvh_node), prim_bytes = (size_t)tri_count * 4;
    rd_buffer pos = {0}, nodes = {0}, prim = {0}, scratch = {0};
    rd_vk_result r = rd_buffer_create(vk, &pos, pos_bytes, RD_MEMORY_DEVICE, err, errlen);
    if (r == RD_VK_OK && pos_bytes)
        r = rd_buffer_upload(vk, &pos, 0, positions, pos_bytes, err, errlen);
    if (r == RD_VK_OK) r = rd_buffer_create(vk, &nodes, node_bytes, RD_MEMORY_DEVICE, err, errlen);
    if (r == RD_VK_OK) r = rd_buffer_create(vk, &prim, prim_bytes, RD_MEMORY_DEVICE, err, errlen);
    if (r == RD_VK_OK)
        r = rd_buffer_create(vk, &scratch, rd_gpu_lbvh_scratch_bytes(b, tri_count),
                             RD_MEMORY_DEVICE, err, errlen);
    rd_cmd c;
    if (r == RD_VK_OK) r = rd_cmd_begin(vk, &c, err, errlen);
    if (r == RD_VK_OK) {
        if (timer) rd_timer_begin(&c, timer);
        rd_gpu_lbvh_record(&c, b, pos.address, tri_count, max_leaf, nodes.address, prim.address,
                           &scratch, timer);
        double t0 = now_ms();
        r = rd_cmd_submit_wait(vk, &c, err, errlen);
        if (gpu_ms) *gpu_ms = now_ms() - t0;
        if (r == RD_VK_OK && timer) r = rd_timer_resolve(vk, timer, err, errlen);
    }
    if (r == RD_VK_OK) {
        out->nodes = malloc(node_bytes);
        out->prim_index = malloc(prim_bytes ? prim_bytes : 4);
        if (!out->nodes || !out->prim_index) {
            fprintf(stderr, "probecast: out of memory (GPU LBVH read-back)\n");
            abort();
        }
        out->prim_count = tri_count;
        uint32_t words[2] = {0, 0}; /* the node count and the depth the build wrote */
        r = rd_buffer_download(vk, &scratch, RD_GPU_LBVH_COUNT_OFFSET, words, sizeof words, err,
                               errlen);
        out->node_count = words[0];
        if (r == RD_VK_OK && !(out->node_count >= 1 && out->node_count <= nn)) {
            snprintf(err, errlen, "GPU LBVH: %u nodes out of %u", out->node_count, nn);
            r = RD_VK_ERR_VULKAN;
        }
        if (r == RD_VK_OK)
            r = rd_buffer_download(vk, &nodes, 0, out->nodes,
                                   (size_t)out->node_count * sizeof(pc_bvh_node), err, errlen);
        if (r == RD_VK_OK && prim_bytes)
            r = rd_buffer_download(vk, &prim, 0, out->prim_index, prim_bytes, err, errlen);
        if (r == RD_VK_OK) out->depth = tree_depth(out);
        if (r == RD_VK_OK && words[1] != out->depth) { /* the tests build many trees */
            snprintf(err, errlen, "GPU LBVH: depth %u written, %u walked", words[1], out->depth);
            r = RD_VK_ERR_VULKAN;
        }
    }
    rd_buffer_destroy(vk, &scratch);
    rd_buffer_destroy(vk, &prim);
    rd_buffer_destroy(vk, &nodes);
    rd_buffer_destroy(vk, &pos);
    if (r != RD_VK_OK) rd_bvh_destroy(out);
    return r;
}
