/* video_i420.h: a view's frame as I420 on the GPU (shaders/video_i420.comp), for the video
 * encoders (server/encode/video_encoder.h): BT.601 limited range, 2x2 chroma means, bit exact
 * with srv_video_rgba_to_i420 on the CPU. The readback then carries 1.5 bytes a pixel instead of
 * 4, and the encoders skip the colour conversion.
 *
 * Layout (the buffer and its host copy): the Y plane, y_stride bytes a row (the width rounded up
 * to 8; bytes past the width repeat the last column), height rows; then Cb, then Cr, each
 * c_stride = y_stride / 2 bytes a row and (height + 1) / 2 rows. Render thread only. */
#ifndef RD_VIDEO_I420_H
#define RD_VIDEO_I420_H

#include <stdbool.h>
#include <stdint.h>

#include "renderer/view.h"
#include "renderer/vk/vk_buffer.h"
#include "renderer/vk/vk_compute.h"

typedef struct rd_video_i420 {
    rd_pipeline pipeline;
} rd_video_i420;

rd_vk_result rd_video_i420_create(rd_vk *vk, rd_video_i420 *p, char *err, size_t errlen);
void rd_video_i420_destroy(rd_vk *vk, rd_video_i420 *p); /* idempotent */

typedef struct rd_i420_layout {
    unsigned y_stride, c_stride, c_rows;
    uint64_t cb_at, cr_at, bytes;
} rd_i420_layout;

rd_i420_layout rd_i420_layout_of(unsigned width, unsigned height);

/* Records the pass into c: rgba (width x height RGBA8, one uint a pixel, R in the low byte) to
 * planes (at least rd_i420_layout_of(width, height).bytes). A barrier before it orders it after
 * the commands that wrote rgba; the caller orders what reads planes after it. */
void rd_video_i420_record(const rd_video_i420 *p, rd_cmd *c, const rd_buffer *rgba, unsigned width,
                          unsigned height, const rd_buffer *planes);

/* The pass over view v's RGBA8 image (its last frame, or the frame recorded before into c) into
 * v->i420, created or grown first (waiting for the device when an older one may still be read).
 * timed: c holds the view's frame, whose timer then gets an "i420" section. */
rd_vk_result rd_video_i420_record_view(const rd_video_i420 *p, rd_view *v, rd_cmd *c, bool timed,
                                       char *err, size_t errlen);

#endif
