/* jpeg_gpu.c: the product's GPU DCT pass and coefficient entropy coder, driven for measurement. */
#include "jpeg_gpu.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "server/base/clock.h"

srv_jpeg_coefs jpeg_gpu_coefs(const jpeg_gpu *g)
{
    return (srv_jpeg_coefs){.blocks = g->coefs_host.mapped,
                            .width = g->width,
                            .height = g->height,
                            .quality = g->quality};
}

static bool encode_stripe(jpeg_gpu *g, unsigned coder, const srv_jpeg_plan *plan, unsigned index,
                          srv_jpeg_buf *out)
{
    srv_jpeg_coefs c = jpeg_gpu_coefs(g);
    return srv_jpeg_encode_coefs(g->coders[coder], plan, &c, index, out) == SRV_JPEG_OK;
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
    t->ok = encode_stripe(t->g, t->index, t->plan, t->index, t->out);
}

/* ---- Vulkan -------------------------------------------------------------------------------- */

rd_vk_result jpeg_gpu_create(jpeg_gpu *g, rd_vk *vk, char *err, size_t errlen)
{
    memset(g, 0, sizeof *g);
    g->vk = vk;
    g->coders[0] = srv_jpeg_encoder_create();
    g->coder_count = 1;
    g->pool_threads = 1;
    rd_vk_result r = srv_jpeg_dct_create(vk, &g->dct, err, errlen);
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
    rd_buffer_destroy(g->vk, &g->sets);
    rd_buffer_destroy(g->vk, &g->coefs_host);
    rd_buffer_destroy(g->vk, &g->coefs);
    rd_buffer_destroy(g->vk, &g->frame);
    rd_jpeg_dct_destroy(g->vk, &g->dct);
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
    VkDeviceSize pixels = (VkDeviceSize)width * height * 4;
    VkDeviceSize coefs = rd_jpeg_coef_bytes(width, height);
    rd_vk_result r = ensure(g->vk, &g->frame, pixels, RD_MEMORY_DEVICE, err, errlen);
    if (r == RD_VK_OK) r = ensure(g->vk, &g->coefs, coefs, RD_MEMORY_DEVICE, err, errlen);
    if (r == RD_VK_OK) r = ensure(g->vk, &g->coefs_host, coefs, RD_MEMORY_READBACK, err, errlen);
    if (r == RD_VK_OK) r = rd_buffer_upload(g->vk, &g->frame, 0, rgba, pixels, err, errlen);
    return r;
}

rd_vk_result jpeg_gpu_transform(jpeg_gpu *g, jpeg_gpu_times *times, char *err, size_t errlen)
{
    double t0 = srv_mono_ms();
    rd_cmd cmd;
    rd_vk_result r = rd_cmd_begin(g->vk, &cmd, err, errlen);
    if (r != RD_VK_OK) return r;
    rd_timer_begin(&cmd, &g->timer);
    rd_jpeg_dct_record(&g->dct, &cmd, &g->frame, g->width, g->height, &g->quality, 1,
                       g->direct ? &g->coefs_host : &g->coefs);
    rd_timer_mark(&cmd, &g->timer, "dct"); /* its barrier: the pass's writes, host-visible */
    if (!g->direct) {
        rd_cmd_barrier(&cmd);
        VkBufferCopy region = {.size = rd_jpeg_coef_bytes(g->width, g->height)};
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

rd_vk_result jpeg_gpu_time_sets(jpeg_gpu *g, const unsigned *qualities, unsigned n, bool fused,
                                double *ms, char *err, size_t errlen)
{
    VkDeviceSize set = rd_jpeg_coef_bytes(g->width, g->height);
    rd_vk_result r = ensure(g->vk, &g->sets, n * set, RD_MEMORY_DEVICE, err, errlen);
    rd_cmd cmd;
    if (r == RD_VK_OK) r = rd_cmd_begin(g->vk, &cmd, err, errlen);
    if (r != RD_VK_OK) return r;
    rd_timer_begin(&cmd, &g->timer);
    if (fused) {
        rd_jpeg_dct_record(&g->dct, &cmd, &g->frame, g->width, g->height, qualities, n, &g->sets);
    } else {
        for (unsigned i = 0; i < n; i++) {
            rd_buffer part = g->sets; /* set i's range: the pass addresses it */
            part.address += i * set;
            rd_jpeg_dct_record(&g->dct, &cmd, &g->frame, g->width, g->height, &qualities[i], 1,
                               &part);
        }
    }
    rd_timer_mark(&cmd, &g->timer, "sets");
    r = rd_cmd_submit_wait(g->vk, &cmd, err, errlen);
    if (r == RD_VK_OK) r = rd_timer_resolve(g->vk, &g->timer, err, errlen);
    *ms = g->timer.valid ? g->timer.ms[1] : 0;
    return r;
}

/* ---- entropy coding ------------------------------------------------------------------------ */

bool jpeg_gpu_entropy(jpeg_gpu *g, srv_jpeg_buf *out, char *err, size_t errlen)
{
    srv_jpeg_plan whole;
    bool ok = srv_jpeg_plan_make(&whole, g->width, g->height, 1, 1) == SRV_JPEG_OK &&
              encode_stripe(g, 0, &whole, 0, out);
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
