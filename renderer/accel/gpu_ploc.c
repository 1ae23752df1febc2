/* gpu_ploc.c: the GPU PLOC hierarchy (see gpu_ploc.h). */
#include "renderer/accel/gpu_ploc.h"

#include <assert.h>

/* shaders/ploc.glsl's layout, in words from the area's start (its constants in
 * shaders/bvh_build_types.h): control, a record a round, cur0, cur1 and nn (n each), the block sums
 * (2 a block), then (4-word aligned) 2n - 1 clusters. */

static uint64_t blocks(uint32_t n)
{
    return (n + PC_PLOC_BLOCK - 1) / PC_PLOC_BLOCK;
}

uint64_t rd_gpu_ploc_words(uint32_t n)
{
    uint64_t sums_end = PC_PLOC_CTRL_WORDS + (uint64_t)PC_PLOC_ROUNDS_ALL * PC_PLOC_LOG_WORDS +
                        3 * (uint64_t)n + 2 * blocks(n);
    uint64_t clusters = n ? 2 * (uint64_t)n - 1 : 0;
    return ((sums_end + 3) & ~(uint64_t)3) + PC_PLOC_CLUSTER_WORDS * clusters;
}

/* Rounds to record: clustering rounds (each merges at least one pair: the pair of least union
 * area among the neighbours is mutual; n - 1 merges at most), then forced pairing rounds, each
 * halving what is left (ceil(log2 n) of them end any build). */
static void rounds(uint32_t n, uint32_t *cluster, uint32_t *forced)
{
    uint32_t f = 0;
    while (f < 32 && (1ull << f) < n)
        f++;
    *cluster = n - 1 < PC_PLOC_ROUNDS ? n - 1 : PC_PLOC_ROUNDS;
    *forced = f;
    assert(f <= PC_PLOC_FORCED_ROUNDS);
}

void rd_gpu_ploc_record(rd_cmd *c, const rd_gpu_lbvh_builder *b, VkDeviceAddress positions,
                        uint32_t n, uint32_t max_leaf, VkDeviceAddress nodes,
                        VkDeviceAddress prim_index, const rd_buffer *scratch, uint32_t area_at,
                        rd_timer *timer)
{
    assert(area_at % 4 == 0 && max_leaf >= 1 && max_leaf <= 15);
    uint32_t row = rd_gpu_lbvh_row_groups(b);
    pc_push init = {.globals = prim_index,
                    .buf0 = positions,
                    .buf1 = nodes,
                    .buf2 = scratch->address,
                    .params = {n, area_at, 0, row}};
    rd_gpu_lbvh_dispatch_rows(c, b, &b->ploc_init, &init, (n + PC_WG_1D - 1) / PC_WG_1D + !n);
    rd_cmd_barrier(c);
    if (n < 2) {
        if (timer) rd_timer_mark(c, timer, "ploc_rounds");
        return;
    }
    uint32_t clustering, forced;
    rounds(n, &clustering, &forced);
    uint32_t total = clustering + forced;
    VkDeviceSize log0 = 4 * ((VkDeviceSize)area_at + PC_PLOC_CTRL_WORDS);
    for (uint32_t r = 0; r < total; r++) {
        VkDeviceSize log = log0 + 4 * (VkDeviceSize)r * PC_PLOC_LOG_WORDS;
        uint32_t w = max_leaf << 4 | (r >= clustering ? 1u << 8 : 0) | row << 16;
        pc_push p = {.buf2 = scratch->address, .params = {n, area_at, r, w}};
        rd_cmd_dispatch_indirect(c, &b->ploc_round, &p, scratch, log + 4 * PC_PLOC_LOG_NN_ARGS);
        rd_cmd_barrier(c);
        p.params.w = w | 1;
        rd_cmd_dispatch_indirect(c, &b->ploc_round, &p, scratch, log + 4 * PC_PLOC_LOG_BLOCK_ARGS);
        rd_cmd_barrier(c);
        p.params.w = w | 2;
        rd_cmd_dispatch(c, &b->ploc_round, &p, 1, 1, 1);
        rd_cmd_barrier(c);
        p.params.w = w | 3;
        rd_cmd_dispatch_indirect(c, &b->ploc_round, &p, scratch, log + 4 * PC_PLOC_LOG_BLOCK_ARGS);
        rd_cmd_barrier(c);
    }
    if (timer) rd_timer_mark(c, timer, "ploc_rounds");
    for (uint32_t r = total; r-- > 0;) {
        pc_push p = {.globals = prim_index,
                     .buf1 = nodes,
                     .buf2 = scratch->address,
                     .params = {n, area_at, r, 0}};
        VkDeviceSize log = log0 + 4 * (VkDeviceSize)r * PC_PLOC_LOG_WORDS;
        rd_cmd_dispatch_indirect(c, &b->ploc_emit, &p, scratch, log + 4 * PC_PLOC_LOG_EMIT_ARGS);
        rd_cmd_barrier(c);
    }
    if (timer) rd_timer_mark(c, timer, "ploc_emit");
}

/* every word index of the scratch (keys, then the PLOC area) fits in 32 bits */
_Static_assert(8 + 4ull * RD_GPU_LBVH_MAX_TRIANGLES + PC_PLOC_CTRL_WORDS +
                       PC_PLOC_ROUNDS_ALL * PC_PLOC_LOG_WORDS + 3ull * RD_GPU_LBVH_MAX_TRIANGLES +
                       RD_GPU_LBVH_MAX_TRIANGLES / 64 +
                       PC_PLOC_CLUSTER_WORDS * 2ull * RD_GPU_LBVH_MAX_TRIANGLES <
                   (1ull << 32),
               "32-bit indices");
