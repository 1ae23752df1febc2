/* jpeg_dct.c: the GPU half of a JPEG encode (see jpeg_dct.h). */
#include "renderer/encode/jpeg_dct.h"

#include <stdio.h>
#include <string.h>

#include "shaders/gpu_types.h"
#include "shaders/jpeg_dct.spv.h"

rd_vk_result rd_jpeg_dct_create(rd_vk *vk, rd_jpeg_dct *d, const rd_jpeg_tables *tables, char *err,
                                size_t errlen)
{
    memset(d, 0, sizeof *d);
    rd_vk_result r = rd_pipeline_create(vk, &d->pipeline, "jpeg_dct", pc_spv_jpeg_dct,
                                        sizeof pc_spv_jpeg_dct, sizeof(pc_push), err, errlen);
    uint32_t words[RD_JPEG_QUALITIES * 128];
    for (unsigned q = 0; q < RD_JPEG_QUALITIES; q++)
        for (unsigned k = 0; k < 128; k++)
            words[q * 128 + k] = (*tables)[q][k / 64][k % 64];
    if (r == RD_VK_OK)
        r = rd_buffer_create(vk, &d->tables, sizeof words, RD_MEMORY_DEVICE, err, errlen);
    if (r == RD_VK_OK) r = rd_buffer_upload(vk, &d->tables, 0, words, sizeof words, err, errlen);
    if (r != RD_VK_OK) rd_jpeg_dct_destroy(vk, d);
    return r;
}

void rd_jpeg_dct_destroy(rd_vk *vk, rd_jpeg_dct *d)
{
    rd_buffer_destroy(vk, &d->tables);
    rd_pipeline_destroy(vk, &d->pipeline);
}

unsigned rd_jpeg_mcu_cols(unsigned width)
{
    return (width + RD_JPEG_MCU - 1) / RD_JPEG_MCU;
}

unsigned rd_jpeg_mcu_rows(unsigned height)
{
    return (height + RD_JPEG_MCU - 1) / RD_JPEG_MCU;
}

uint64_t rd_jpeg_coef_bytes(unsigned width, unsigned height)
{
    return (uint64_t)rd_jpeg_mcu_cols(width) * rd_jpeg_mcu_rows(height) * 6 * RD_JPEG_BLOCK_BYTES;
}

void rd_jpeg_dct_record(const rd_jpeg_dct *d, rd_cmd *c, const rd_buffer *rgba, unsigned width,
                        unsigned height, const unsigned *qualities, unsigned n,
                        const rd_buffer *coefs)
{
    uint64_t packed = 0; /* one quality a byte from the lowest; 0 ends the list */
    for (unsigned i = 0; i < n && i < RD_JPEG_MAX_SETS; i++) {
        unsigned q = qualities[i] < 1                   ? 1
                     : qualities[i] > RD_JPEG_QUALITIES ? RD_JPEG_QUALITIES
                                                        : qualities[i];
        packed |= (uint64_t)q << (8 * i);
    }
    unsigned cols = rd_jpeg_mcu_cols(width), rows = rd_jpeg_mcu_rows(height);
    pc_push push = {.globals = packed,
                    .buf0 = rgba->address,
                    .buf1 = coefs->address,
                    .buf2 = d->tables.address,
                    .params = {width, height, cols, rows}};
    rd_cmd_barrier(c);
    rd_cmd_dispatch(c, &d->pipeline, &push, cols, rows, 1);
}

rd_vk_result rd_jpeg_dct_record_view(const rd_jpeg_dct *d, rd_view *v, rd_cmd *c,
                                     const unsigned *qualities, unsigned n, bool timed, char *err,
                                     size_t errlen)
{
    if (n < 1 || n > RD_JPEG_MAX_SETS || !v->width || !v->height) {
        snprintf(err, errlen, "JPEG pass: %u qualities over a %ux%u image", n, v->width, v->height);
        return RD_VK_ERR_UNSUPPORTED;
    }
    uint64_t set = rd_jpeg_coef_bytes(v->width, v->height);
    if (!v->jpeg_coefs.buffer || v->jpeg_coefs.size < n * set) {
        if (v->jpeg_coefs.buffer) vkDeviceWaitIdle(v->vk->device); /* a readback may copy it */
        rd_buffer_destroy(v->vk, &v->jpeg_coefs);
        rd_vk_result r =
            rd_buffer_create(v->vk, &v->jpeg_coefs, n * set, RD_MEMORY_DEVICE, err, errlen);
        if (r != RD_VK_OK) return r;
    }
    rd_jpeg_dct_record(d, c, &v->rgba8, v->width, v->height, qualities, n, &v->jpeg_coefs);
    if (timed) rd_timer_mark(c, &v->timer, "jpeg");
    return RD_VK_OK;
}
