/* video_i420.c: a view's frame as I420 on the GPU (see video_i420.h). */
#include "renderer/encode/video_i420.h"

#include <stdio.h>
#include <string.h>

#include "shaders/gpu_types.h"
#include "shaders/video_i420.spv.h"

rd_vk_result rd_video_i420_create(rd_vk *vk, rd_video_i420 *p, char *err, size_t errlen)
{
    memset(p, 0, sizeof *p);
    return rd_pipeline_create(vk, &p->pipeline, "video_i420", pc_spv_video_i420,
                              sizeof pc_spv_video_i420, sizeof(pc_push), err, errlen);
}

void rd_video_i420_destroy(rd_vk *vk, rd_video_i420 *p)
{
    rd_pipeline_destroy(vk, &p->pipeline);
}

rd_i420_layout rd_i420_layout_of(unsigned width, unsigned height)
{
    rd_i420_layout l;
    l.y_stride = (width + 7u) & ~7u;
    l.c_stride = l.y_stride / 2;
    l.c_rows = (height + 1) / 2;
    l.cb_at = (uint64_t)l.y_stride * height;
    l.cr_at = l.cb_at + (uint64_t)l.c_stride * l.c_rows;
    l.bytes = l.cr_at + (uint64_t)l.c_stride * l.c_rows;
    return l;
}

void rd_video_i420_record(const rd_video_i420 *p, rd_cmd *c, const rd_buffer *rgba, unsigned width,
                          unsigned height, const rd_buffer *planes)
{
    rd_i420_layout l = rd_i420_layout_of(width, height);
    unsigned groups_x = l.y_stride / 8, rows = l.c_rows;
    pc_push push = {.buf0 = rgba->address,
                    .buf1 = planes->address,
                    .params = {width, height, l.y_stride / 4, 0}};
    rd_cmd_barrier(c);
    rd_cmd_dispatch(c, &p->pipeline, &push, (groups_x + 7) / 8, (rows + 7) / 8, 1);
}

rd_vk_result rd_video_i420_record_view(const rd_video_i420 *p, rd_view *v, rd_cmd *c, bool timed,
                                       char *err, size_t errlen)
{
    if (!v->width || !v->height) {
        snprintf(err, errlen, "I420 pass over a %ux%u image", v->width, v->height);
        return RD_VK_ERR_UNSUPPORTED;
    }
    uint64_t bytes = rd_i420_layout_of(v->width, v->height).bytes;
    if (!v->i420.buffer || v->i420.size < bytes) {
        if (v->i420.buffer) vkDeviceWaitIdle(v->vk->device); /* a readback may copy it */
        rd_buffer_destroy(v->vk, &v->i420);
        rd_vk_result r = rd_buffer_create(v->vk, &v->i420, bytes, RD_MEMORY_DEVICE, err, errlen);
        if (r != RD_VK_OK) return r;
    }
    rd_video_i420_record(p, c, &v->rgba8, v->width, v->height, &v->i420);
    if (timed) rd_timer_mark(c, &v->timer, "i420");
    return RD_VK_OK;
}
