/* view.h: one camera's images of a world: primary pass -> shade (direct) -> [near field -> GI
 * sampling -> reflections -> reflection filter] -> tone map, or progressive path tracing, with
 * GPU timings and ray counts.
 *
 * A view owns its per-resolution buffers and its own globals buffer; the pipelines
 * (rd_view_passes) are created once per device and shared by every view. Rendering reads the
 * world (scene, sky, probe field as it is) and writes only the view. Render thread only.
 */
#ifndef RD_VIEW_H
#define RD_VIEW_H

#include "renderer/scene/camera.h"
#include "renderer/vk/frame_stats.h"
#include "renderer/vk/vk_buffer.h"
#include "renderer/vk/vk_compute.h"
#include "renderer/world.h"

/* A view's size when its settings give none (the server's settings table takes its width and
 * height defaults from here). */
#define RD_VIEW_DEFAULT_WIDTH 960u
#define RD_VIEW_DEFAULT_HEIGHT 540u

typedef struct rd_view_settings { /* per frame */
    unsigned width, height;       /* 0 = RD_VIEW_DEFAULT_WIDTH x RD_VIEW_DEFAULT_HEIGHT */
    float exposure_ev;            /* exposure in stops: radiance * 2^ev before tone mapping */
    unsigned tonemap;             /* PC_TONEMAP_* (0 = ACES fit) */
    unsigned seed;                /* random streams of stochastic passes */
    unsigned view;                /* PC_VIEW_* debug view */
    unsigned pathtrace_spp;       /* > 0: reference path tracing with this many samples per
                                     pixel instead of direct light + probes */
    unsigned max_bounces;         /* path tracing (0 = 64) */
    unsigned pathtrace_first;     /* path tracing: samples already accumulated from an identical
                                     earlier frame of this view (0 = start over) */
    unsigned reflections;         /* PC_REFLECT_* (0 = auto): indirect specular with GI on */
    unsigned near_field;          /* PC_NEAR_* (0 = auto): near-field rays with GI on */
    unsigned shadow_cull;         /* PC_SHADOW_CULL_* (0 = maps, where the world has them) */
} rd_view_settings;

/* The pipelines of a view's frame; created once per device, shared by all views. */
typedef struct rd_view_passes {
    rd_pipeline primary, shade, tonemap, gi_sample, pathtrace, reflect, reflect_filter, near_field;
} rd_view_passes;

rd_vk_result rd_view_passes_create(rd_vk *vk, rd_view_passes *p, char *err, size_t errlen);
void rd_view_passes_destroy(rd_vk *vk, rd_view_passes *p); /* idempotent */

/* What a view's accumulated histories (reflections, near field) depend on; a frame whose key
 * differs from the last one starts a new history epoch. Compared bytewise (no padding). */
typedef struct rd_view_history_key {
    pc_view view;           /* camera, size and seed; frame index and tone mapping zeroed */
    pc_scene_refs scene;    /* a new scene has new buffers */
    pc_environment env;     /* sky, image and its irradiance */
    uint64_t world_changes; /* rd_world.changes: nodes, lights, GI settings */
    uint64_t gi;            /* rd_world.gi */
    uint64_t converged;     /* rd_world_converged: a field that falls asleep starts a new epoch
                               (what was averaged while it converged measured another field) */
    uint64_t mapped;        /* lights whose maps the frame reads (pc_ddgi_volume.control.w):
                               reflection hits take visibility from them */
} rd_view_history_key;

/* A per-pixel history (uvec4 per pixel: a mean and epoch << 8 | samples), created when a frame
 * first needs it and zeroed then. It is valid for one epoch, which restarts when what the view
 * sees may have changed (camera, size, seed, scene, environment, world changes: the key). */
typedef struct rd_view_history {
    rd_buffer buffer;
    uint32_t epoch; /* 24 bits */
    bool keyed;
    rd_view_history_key key; /* of the last frame that used it */
    unsigned frames;         /* frames of this epoch so far, this one included */
} rd_view_history;

typedef struct rd_view {
    rd_vk *vk;
    const rd_view_passes *passes; /* not owned; must outlive the view */
    rd_buffer globals, counters, gbuffer, radiance, rgba8;
    /* reflections (shaders/reflect.comp): this frame's pc_reflect_control (host visible) */
    rd_buffer reflect_ctrl;
    rd_view_history reflect; /* reflections' demodulated specular (reflect.comp) */
    rd_view_history near;    /* near-field ratios (near_field.comp) */
    bool near_on;            /* the last frame traced near-field rays */
    /* the frame's JPEG coefficients, one set per quality, when the GPU encodes
     * (renderer/encode/jpeg_dct.h: rd_jpeg_dct_record_view creates and grows it) */
    rd_buffer jpeg_coefs;
    /* the frame as I420 for video viewers (renderer/encode/video_i420.h: rd_video_i420_record_view
     * creates and grows it) */
    rd_buffer i420;
    rd_timer timer;
    unsigned width, height; /* of the buffers (the last frame); 0 before the first */
    unsigned frame_index;
    unsigned pathtrace_samples; /* accumulated in the radiance buffer by the last frame */
    rd_frame_stats stats;       /* of the last frame */
} rd_view;

rd_vk_result rd_view_create(rd_vk *vk, const rd_view_passes *passes, rd_view *v, char *err,
                            size_t errlen);
/* Idempotent; waits for the device if buffers may be in use (a readback copying rgba8). */
void rd_view_destroy(rd_view *v);
/* Renders one frame of w from camera into v's buffers (blocking). Reads the world only: uses
 * the probe field as it is (no update). Path tracing when s->pathtrace_spp > 0. A size change
 * waits for the device and reallocates the buffers. With GI on, glossy pixels trace one
 * reflection ray per frame, averaged over the frames for which camera and world stay the same
 * (the history key); a scene without glossy materials (rd_gpu_scene.glossy) records no
 * reflection pass, and a frame without glossy pixels in sight dispatches none. With GI on,
 * near-field rays (gpu_types.h, PC_NEAR_*) correct the probe field at camera pixels, one pixel
 * in four per frame, averaged the same way. */
rd_vk_result rd_view_render(rd_view *v, const rd_world *w, const rd_view_camera *camera,
                            const rd_view_settings *s, char *err, size_t errlen);
/* The same frame without waiting: records it into cmd (begun by the caller, who submits it, e.g.
 * with a readback copy of rgba8 behind it: renderer/vk/readback.h). The view must have no frame in
 * flight, since its globals, counters and timer are rewritten; path tracing is refused (it
 * submits batches of its own). After the submission has completed, rd_view_collect reads the
 * frame's GPU times and ray counts into v->stats. */
rd_vk_result rd_view_record(rd_view *v, const rd_world *w, const rd_view_camera *camera,
                            const rd_view_settings *s, rd_cmd *cmd, char *err, size_t errlen);
rd_vk_result rd_view_collect(rd_view *v, char *err, size_t errlen);
/* Whether the view's last frame still accumulates: its near-field history has had fewer than
 * PC_NEAR_SETTLE_FRAMES frames of this epoch. A still image (render, eval) renders frames until
 * this is false; the server keeps a resting view rendering until then. */
bool rd_view_settling(const rd_view *v);
/* rd_view_render, then again while the view settles (at most PC_NEAR_SETTLE_FRAMES more
 * frames): a still image. v->stats are the last frame's. */
rd_vk_result rd_view_render_still(rd_view *v, const rd_world *w, const rd_view_camera *camera,
                                  const rd_view_settings *s, char *err, size_t errlen);
/* Reads back the last frame: tone-mapped RGBA8 (width*height*4 bytes) or linear radiance
 * (width*height*3 floats). */
rd_vk_result rd_view_read_rgba8(rd_view *v, uint8_t *out, char *err, size_t errlen);
rd_vk_result rd_view_read_hdr(rd_view *v, float *rgb, char *err, size_t errlen);

#endif
