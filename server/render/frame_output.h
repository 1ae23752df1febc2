/* frame_output.h: from a view's rendered image to the encoders (render thread only).
 *
 * A frame's command buffer (srv_frame_output_begin) holds the view's passes, then what the
 * encoders need of the image, copied to host memory by the readback ring without waiting
 * (renderer/vk/readback.h); srv_frame_output_poll hands finished copies to the encoder pool as
 * images (encoder_pool.h), read where the GPU put them (a lease on the readback slot) while
 * enough slots stay free for frames in flight.
 *
 * What is copied depends on the JPEG path:
 *  - CPU (libjpeg-turbo encodes the pixels): the RGBA8 image, 4 bytes a pixel;
 *  - GPU: the JPEG pass (renderer/encode/jpeg_dct.h) runs in the frame's command buffer, transforming
 *    once and quantising at every quality the frame is sent at (the encoders' lag-driven
 *    variants, srv_encoder_qualities), and its coefficients are copied, 3 bytes a pixel a
 *    quality; the encoders only entropy-code them (server/encode/jpeg_coefs.h), about 40% of the
 * CPU time of encoding the pixels. When some watcher of the view takes video, an I420 pass
 *    (renderer/encode/video_i420.h) runs too and its planes follow the coefficients, 1.5 bytes a
 *    pixel, for the video encoders; a moving frame that every watcher takes as video
 *    (srv_frame_info.video_only) gets only the planes.
 * On the CPU path video encoders read the RGBA8 pixels.
 * A still (the last frame at still quality once input stops) re-encodes the view's last image:
 * the RGBA8 image kept on the CPU, or on the GPU path the JPEG pass over the view's image,
 * which still holds that frame (nothing rendered the view since).
 */
#ifndef SRV_FRAME_OUTPUT_H
#define SRV_FRAME_OUTPUT_H

#include <stdbool.h>

#include "server/encode/encoder_pool.h"
#include "server/render/render_stats.h"
#include "renderer/encode/jpeg_dct.h"
#include "renderer/encode/video_i420.h"
#include "renderer/vk/readback.h"
#include "server/render/views.h"

/* Where JPEGs are transformed and quantised (probecast serve --jpeg). */
typedef enum srv_jpeg_path {
    SRV_JPEG_AUTO = 0, /* GPU on a real GPU, CPU on a CPU device (lavapipe) */
    SRV_JPEG_CPU,
    SRV_JPEG_GPU,
} srv_jpeg_path;

/* "auto", "cpu", "gpu" (false for anything else). */
bool srv_jpeg_path_parse(const char *s, srv_jpeg_path *out);

typedef struct srv_frame_output {
    rd_vk *vk;
    rd_readback rb;
    bool gpu; /* the GPU JPEG path is on */
    rd_jpeg_dct dct;
    rd_video_i420 i420; /* GPU path: frames as I420 for video viewers */
    bool i420_ok;
    srv_encoder_pool *encoders;
    srv_stats_board *stats;
    srv_views *views;
} srv_frame_output;

/* Sets up the ring and, for the GPU path (path, or AUTO on a device that is not the CPU), the
 * JPEG pass; when AUTO chose the GPU path and the pass cannot be made, the CPU path is used
 * instead (with a warning); an explicit SRV_JPEG_GPU fails. */
rd_vk_result srv_frame_output_init(srv_frame_output *o, rd_vk *vk, srv_jpeg_path path,
                                   srv_encoder_pool *encoders, srv_stats_board *stats,
                                   srv_views *views, char *err, size_t errlen);
/* Waits for copies in flight, frees everything (idempotent). Views must be disposed first (their
 * last images hold readback leases). */
void srv_frame_output_dispose(srv_frame_output *o);

bool srv_frame_output_ready(const srv_frame_output *o); /* a frame can begin now */
bool srv_frame_output_busy(const srv_frame_output *o);  /* copies in flight */

/* Begins a frame: a command buffer for the view's passes (recorded by the caller). */
rd_vk_result srv_frame_output_begin(srv_frame_output *o, rd_cmd **cmd, char *err, size_t errlen);
/* Appends what the encoders need of v's image (the JPEG pass or nothing, then the copy) to the
 * begun frame and submits it, without waiting. info: the frame (ready_us is set on delivery);
 * quality: its JPEG quality before the lag-driven caps; timed: the view's passes are in it
 * (its GPU times are collected on delivery). */
rd_vk_result srv_frame_output_finish(srv_frame_output *o, srv_view *v, const srv_frame_info *info,
                                     unsigned quality, bool timed, char *err, size_t errlen);
void srv_frame_output_abort(srv_frame_output *o); /* drops a begun frame */
/* A frame of v's last image (already rendered, nothing in flight) at quality: begin + finish on
 * the GPU path, the kept RGBA8 image handed to the encoders again on the CPU path. false when it
 * cannot now (no last image, or no free readback slot: try again later). */
bool srv_frame_output_again(srv_frame_output *o, srv_view *v, const srv_frame_info *info,
                            unsigned quality);
/* Hands every finished copy to the encoders (with timeout_ns > 0 first waiting up to that long
 * for the oldest). */
void srv_frame_output_poll(srv_frame_output *o, uint64_t timeout_ns);

#endif
