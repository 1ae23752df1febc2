/* jpeg_gpu.c: GPU DCT and quantisation, CPU entropy coding with libjpeg's transcoding API. */
#include "jpeg_gpu.h"

#include <stdio.h> /* jpeglib.h needs FILE and size_t first */
#include <stdlib.h>
#include <string.h>

#include <jerror.h>
#include <jpeglib.h>

#include "bench/jpeg_dct_comp.spv.h"
#include "server/clock.h"
#include "shaders/gpu_types.h"

_Static_assert(sizeof(JCOEF) == 2 && sizeof(JBLOCK) == 128, "libjpeg blocks of 64 int16");

/* ---- quantisation tables ------------------------------------------------------------------- */

void jpeg_gpu_quant_tables(unsigned quality, unsigned tables[2][64])
{
    struct jpeg_compress_struct c;
    struct jpeg_error_mgr e;
    c.err = jpeg_std_error(&e);
    jpeg_create_compress(&c);
    c.in_color_space = JCS_RGB;
    c.input_components = 3;
    jpeg_set_defaults(&c);
    jpeg_set_quality(&c, (int)quality, TRUE); /* what tjCompress2 and srv_jpeg_encode do */
    for (int t = 0; t < 2; t++)
        for (int k = 0; k < 64; k++)
            tables[t][k] = c.quant_tbl_ptrs[t]->quantval[k]; /* natural order */
    jpeg_destroy_compress(&c);
}

/* Entropy-codes image rows [y0, y0 + rows) (y0 a multiple of 16) of g's coefficients with the
 * given restart interval. libjpeg's coefficient arrays for the rows are requested and realised
 * as jpegtran's are, then their block-row pointers are pointed into the host copy of the GPU's
 * planes (whose layout is the arrays'): access_virt_barray of an array held in memory returns
 * the array's own row-pointer table, so jpeg_write_coefficients reads the GPU's blocks where
 * they lie. libjpeg writes dummy blocks past the image's last block column and row itself. */
typedef struct rows_job {
    const jpeg_gpu *g;
    unsigned y0, rows, restart;
} rows_job;

static void feed_rows(struct jpeg_compress_struct *ci, void *user)
{
    const rows_job *job = user;
    const jpeg_gpu *g = job->g;
    ci->image_width = g->width;
    ci->image_height = job->rows;
    ci->input_components = 3;
    ci->in_color_space = JCS_RGB;
    jpeg_set_defaults(ci); /* YCbCr 4:2:0, JFIF, standard Huffman tables, no optimize_coding */
    jpeg_set_quality(ci, (int)g->quality, TRUE);
    ci->restart_interval = job->restart;

    const JBLOCK *all = g->coefs_host.mapped;
    size_t plane = (size_t)g->mcu_cols * g->mcu_rows; /* blocks in a chroma plane */
    unsigned mcu_y0 = job->y0 / SRV_JPEG_MCU, mcu_n = (job->rows + SRV_JPEG_MCU - 1) / SRV_JPEG_MCU;
    jvirt_barray_ptr arrays[3];
    for (int k = 0; k < 3; k++) {
        unsigned s = k == 0 ? 2 : 1; /* blocks an MCU across and down */
        arrays[k] = ci->mem->request_virt_barray((j_common_ptr)ci, JPOOL_IMAGE, FALSE,
                                                 g->mcu_cols * s, mcu_n * s, mcu_n * s);
    }
    ci->mem->realize_virt_arrays((j_common_ptr)ci);
    for (int k = 0; k < 3; k++) {
        unsigned s = k == 0 ? 2 : 1, across = g->mcu_cols * s;
        JBLOCKARRAY r =
            ci->mem->access_virt_barray((j_common_ptr)ci, arrays[k], 0, mcu_n * s, TRUE);
        const JBLOCK *base = all + (k == 0 ? 0 : (size_t)(3 + k) * plane);
        for (unsigned i = 0; i < mcu_n * s; i++)
            r[i] = (JBLOCKROW)(base + (size_t)(mcu_y0 * s + i) * across);
    }
    jpeg_write_coefficients(ci, arrays);
    jpeg_finish_compress(ci);
}

static bool encode_rows(srv_jpeg_encoder *c, const jpeg_gpu *g, unsigned y0, unsigned rows,
                        unsigned restart, srv_jpeg_buf *out)
{
    rows_job job = {.g = g, .y0 = y0, .rows = rows, .restart = restart};
    return srv_jpeg_encoder_run(c, out, (size_t)g->width * rows / 2 + 2048, feed_rows, &job) ==
           SRV_JPEG_OK;
}

/* ---- entropy tasks ------------------------------------------------------------------------- */

typedef struct stripe_task {
    rd_task task; /* first: the pool hands this back */
    jpeg_gpu *g;
    const srv_jpeg_plan *plan;
    unsigned index;
    srv_jpeg_buf *out;
    bool ok;
} stripe_task;

/* Stripe t->index with that stripe's own compressor (no two tasks share one). */
static void stripe_run(rd_task *task)
{
    stripe_task *t = (stripe_task *)task;
    t->ok = encode_rows(t->g->coders[t->index], t->g, srv_jpeg_stripe_y(t->plan, t->index),
                        srv_jpeg_stripe_rows(t->plan, t->index), t->plan->restart_interval, t->out);
}

/* ---- Vulkan -------------------------------------------------------------------------------- */

rd_vk_result jpeg_gpu_create(jpeg_gpu *g, rd_vk *vk, char *err, size_t errlen)
{
    memset(g, 0, sizeof *g);
    g->vk = vk;
    g->coders[0] = srv_jpeg_encoder_create();
    g->coder_count = 1;
    g->pool_threads = 1;
    rd_vk_result r = rd_pipeline_create(vk, &g->pipeline, "jpeg_dct", pc_spv_jpeg_dct_comp,
                                        sizeof pc_spv_jpeg_dct_comp, sizeof(pc_push), err, errlen);
    if (r == RD_VK_OK)
        r = rd_buffer_create(vk, &g->quant, 2 * 64 * sizeof(uint32_t), RD_MEMORY_UPLOAD, err,
                             errlen);
    if (r == RD_VK_OK) r = rd_timer_create(vk, &g->timer, err, errlen);
    if (r != RD_VK_OK) jpeg_gpu_destroy(g);
    return r;
}

void jpeg_gpu_destroy(jpeg_gpu *g)
{
    if (!g->vk) return;
    rd_task_pool_destroy(g->pool);
    for (unsigned i = 0; i < g->coder_count; i++)
        srv_jpeg_encoder_destroy(g->coders[i]);
    rd_vk_wait_idle(g->vk);
    rd_timer_destroy(g->vk, &g->timer);
    rd_buffer_destroy(g->vk, &g->frame_host);
    rd_buffer_destroy(g->vk, &g->quant);
    rd_buffer_destroy(g->vk, &g->coefs_host);
    rd_buffer_destroy(g->vk, &g->coefs);
    rd_buffer_destroy(g->vk, &g->frame);
    rd_pipeline_destroy(g->vk, &g->pipeline);
    memset(g, 0, sizeof *g);
}

/* Makes b at least size bytes (its contents are lost when it grows). */
static rd_vk_result ensure(rd_vk *vk, rd_buffer *b, VkDeviceSize size, rd_memory where, char *err,
                           size_t errlen)
{
    if (b->buffer && b->size >= size) return RD_VK_OK;
    rd_buffer_destroy(vk, b);
    return rd_buffer_create(vk, b, size, where, err, errlen);
}

rd_vk_result jpeg_gpu_set_frame(jpeg_gpu *g, const uint8_t *rgba, unsigned width, unsigned height,
                                unsigned quality, char *err, size_t errlen)
{
    if (!width || !height || width > SRV_JPEG_MAX_SIDE || height > SRV_JPEG_MAX_SIDE ||
        quality < 1 || quality > 100) {
        rd_vk_errorf(err, errlen, "bad frame %ux%u or quality %u", width, height, quality);
        return RD_VK_ERR_UNSUPPORTED;
    }
    g->width = width;
    g->height = height;
    g->quality = quality;
    g->mcu_cols = (width + SRV_JPEG_MCU - 1) / SRV_JPEG_MCU;
    g->mcu_rows = (height + SRV_JPEG_MCU - 1) / SRV_JPEG_MCU;
    VkDeviceSize pixels = (VkDeviceSize)width * height * 4;
    VkDeviceSize coefs = (VkDeviceSize)g->mcu_cols * g->mcu_rows * 6 * sizeof(JBLOCK);
    rd_vk_result r = ensure(g->vk, &g->frame, pixels, RD_MEMORY_DEVICE, err, errlen);
    if (r == RD_VK_OK) r = ensure(g->vk, &g->coefs, coefs, RD_MEMORY_DEVICE, err, errlen);
    if (r == RD_VK_OK) r = ensure(g->vk, &g->coefs_host, coefs, RD_MEMORY_READBACK, err, errlen);
    if (r == RD_VK_OK) r = rd_buffer_upload(g->vk, &g->frame, 0, rgba, pixels, err, errlen);
    if (r != RD_VK_OK) return r;
    unsigned tables[2][64];
    jpeg_gpu_quant_tables(quality, tables);
    uint32_t *q = g->quant.mapped;
    for (int k = 0; k < 128; k++)
        q[k] = tables[k / 64][k % 64];
    return RD_VK_OK;
}

rd_vk_result jpeg_gpu_transform(jpeg_gpu *g, jpeg_gpu_times *times, char *err, size_t errlen)
{
    double t0 = srv_mono_ms();
    rd_cmd cmd;
    rd_vk_result r = rd_cmd_begin(g->vk, &cmd, err, errlen);
    if (r != RD_VK_OK) return r;
    rd_timer_begin(&cmd, &g->timer);
    pc_push push = {.buf0 = g->frame.address,
                    .buf1 = g->direct ? g->coefs_host.address : g->coefs.address,
                    .buf2 = g->quant.address,
                    .params = {g->width, g->height, g->mcu_cols, g->mcu_rows}};
    rd_cmd_dispatch(&cmd, &g->pipeline, &push, g->mcu_cols, g->mcu_rows, 1);
    rd_timer_mark(&cmd, &g->timer, "dct"); /* its barrier: the pass's writes, host-visible */
    if (!g->direct) {
        rd_cmd_barrier(&cmd);
        VkBufferCopy region = {.size =
                                   (VkDeviceSize)g->mcu_cols * g->mcu_rows * 6 * sizeof(JBLOCK)};
        vkCmdCopyBuffer(cmd.cb, g->coefs.buffer, g->coefs_host.buffer, 1, &region);
        rd_cmd_barrier(&cmd); /* the copy's writes become visible to the host */
        rd_timer_mark(&cmd, &g->timer, "copy");
    } else {
        rd_cmd_barrier(&cmd); /* also without timestamps */
    }
    r = rd_cmd_submit_wait(g->vk, &cmd, err, errlen);
    if (r == RD_VK_OK) r = rd_timer_resolve(g->vk, &g->timer, err, errlen);
    if (r == RD_VK_OK && !(g->coefs_host.memory_flags & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT)) {
        VkMappedMemoryRange range = {.sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE,
                                     .memory = g->coefs_host.memory,
                                     .size = VK_WHOLE_SIZE};
        VkResult vr = vkInvalidateMappedMemoryRanges(g->vk->device, 1, &range);
        if (vr != VK_SUCCESS)
            r = rd_vk_fail(g->vk, vr, "vkInvalidateMappedMemoryRanges", err, errlen);
    }
    if (times) {
        times->dct_ms = g->timer.valid ? g->timer.ms[1] : 0;
        times->copy_ms = g->timer.valid && !g->direct ? g->timer.ms[2] : 0;
        times->wall_ms = srv_mono_ms() - t0;
    }
    return r;
}

rd_vk_result jpeg_gpu_time_frame_copy(jpeg_gpu *g, jpeg_gpu_times *times, char *err, size_t errlen)
{
    double t0 = srv_mono_ms();
    VkDeviceSize bytes = (VkDeviceSize)g->width * g->height * 4;
    rd_vk_result r = ensure(g->vk, &g->frame_host, bytes, RD_MEMORY_READBACK, err, errlen);
    rd_cmd cmd;
    if (r == RD_VK_OK) r = rd_cmd_begin(g->vk, &cmd, err, errlen);
    if (r != RD_VK_OK) return r;
    rd_timer_begin(&cmd, &g->timer);
    VkBufferCopy region = {.size = bytes};
    vkCmdCopyBuffer(cmd.cb, g->frame.buffer, g->frame_host.buffer, 1, &region);
    rd_cmd_barrier(&cmd);
    rd_timer_mark(&cmd, &g->timer, "copy");
    r = rd_cmd_submit_wait(g->vk, &cmd, err, errlen);
    if (r == RD_VK_OK) r = rd_timer_resolve(g->vk, &g->timer, err, errlen);
    times->dct_ms = 0;
    times->copy_ms = g->timer.valid ? g->timer.ms[1] : 0;
    times->wall_ms = srv_mono_ms() - t0;
    return r;
}

/* ---- entropy coding ------------------------------------------------------------------------ */

bool jpeg_gpu_entropy(jpeg_gpu *g, srv_jpeg_buf *out, char *err, size_t errlen)
{
    bool ok = encode_rows(g->coders[0], g, 0, g->height, 0, out);
    if (!ok) snprintf(err, errlen, "libjpeg: %s", srv_jpeg_encoder_error(g->coders[0]));
    return ok;
}

bool jpeg_gpu_entropy_striped(jpeg_gpu *g, unsigned threads, const srv_jpeg_plan *plan,
                              srv_jpeg_buf *stripes, srv_jpeg_buf *out, char *err, size_t errlen)
{
    if (threads < 1) threads = 1;
    if (threads > JPEG_GPU_MAX_THREADS) threads = JPEG_GPU_MAX_THREADS;
    if (plan->width != g->width || plan->height != g->height) {
        snprintf(err, errlen, "the plan is for another frame size");
        return false;
    }
    if (plan->stripe_count > JPEG_GPU_MAX_THREADS) {
        snprintf(err, errlen, "more than %d stripes", JPEG_GPU_MAX_THREADS);
        return false;
    }
    if (g->pool_threads != threads) {
        rd_task_pool_destroy(g->pool);
        g->pool = threads > 1 ? rd_task_pool_create(threads) : NULL;
        if (threads > 1 && !g->pool) abort(); /* out of memory or threads */
        g->pool_threads = threads;
    }
    while (g->coder_count < plan->stripe_count)
        g->coders[g->coder_count++] = srv_jpeg_encoder_create();
    stripe_task tasks[JPEG_GPU_MAX_THREADS];
    rd_task_group group = {0};
    for (unsigned i = 0; i < plan->stripe_count; i++) {
        tasks[i] = (stripe_task){.g = g, .plan = plan, .index = i, .out = &stripes[i]};
        rd_task_submit(g->pool, &group, &tasks[i].task, stripe_run);
    }
    rd_task_wait(g->pool, &group);
    bool ok = true;
    for (unsigned i = 0; i < plan->stripe_count; i++)
        ok &= tasks[i].ok;
    if (!ok) {
        snprintf(err, errlen, "libjpeg failed on a stripe");
        return false;
    }
    size_t cap = srv_jpeg_join_bound(plan, stripes);
    srv_jpeg_buf_reserve(out, cap);
    srv_jpeg_result jr = srv_jpeg_join(plan, stripes, out->data, out->cap, &out->size);
    if (jr != SRV_JPEG_OK) snprintf(err, errlen, "join: %s", srv_jpeg_strerror(jr));
    return jr == SRV_JPEG_OK;
}
