/* render.h: one frame = primary pass -> shade pass -> tone-map pass, with GPU timings and ray
 * counts. The renderer owns the per-resolution buffers and the pipelines; the scene is
 * passed in (rd_gpu_scene) so one renderer can draw any uploaded scene.
 */
#ifndef RD_RENDER_H
#define RD_RENDER_H

#include "camera.h"
#include "gpu_scene.h"
#include "vk_compute.h"

typedef struct rd_frame_settings {
    unsigned width, height; /* 0 = 960 x 540 */
    float sky[3];           /* radiance of rays that escape (default black) */
    float exposure_ev;      /* exposure in stops: radiance * 2^ev before tone mapping */
    unsigned tonemap;       /* PC_TONEMAP_* (0 = ACES fit) */
    unsigned seed;
} rd_frame_settings;

typedef struct rd_frame_stats {
    unsigned pass_count;
    const char *pass_name[RD_TIMER_MAX];
    double pass_ms[RD_TIMER_MAX]; /* GPU time per pass (0 when timestamps are unavailable) */
    bool timed;
    pc_counters rays;             /* rays traced per kind in this frame */
} rd_frame_stats;

typedef struct rd_renderer {
    rd_vk *vk;
    rd_pipeline primary, shade, tonemap;
    rd_buffer globals, counters, gbuffer, radiance, rgba8;
    rd_timer timer;
    unsigned width, height;
    unsigned frame_index;
    rd_frame_stats stats;
} rd_renderer;

rd_vk_result rd_renderer_create(rd_vk *vk, rd_renderer *r, char *err, size_t errlen);
void rd_renderer_destroy(rd_renderer *r); /* idempotent */
/* Renders one frame of scene from camera into the renderer's buffers (blocking). */
rd_vk_result rd_renderer_render(rd_renderer *r, const rd_gpu_scene *scene,
                                const rd_view_camera *camera, const rd_frame_settings *settings,
                                char *err, size_t errlen);
/* Reads back the last frame: tone-mapped RGBA8 (width*height*4 bytes) or linear radiance
 * (width*height*3 floats). */
rd_vk_result rd_renderer_read_rgba8(rd_renderer *r, uint8_t *out, char *err, size_t errlen);
rd_vk_result rd_renderer_read_hdr(rd_renderer *r, float *rgb, char *err, size_t errlen);

#endif
