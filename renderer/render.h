/* render.h: the one-view convenience for offline tools (probecast render, eval, tests): a
 * world (world.h) and one view (view.h) of it, where each frame first advances the probe
 * field and then renders: [probe updates] -> primary -> shade (direct) -> [near field, GI
 * sampling, reflections] -> tone map, with GPU timings and ray counts of all of it. The scene is
 * passed in (rd_gpu_scene) so one renderer can draw any uploaded scene. The daemon uses world and
 * views directly.
 */
#ifndef RD_RENDER_H
#define RD_RENDER_H

#include "renderer/scene/camera.h"
#include "renderer/gi/ddgi.h"
#include "renderer/vk/frame_stats.h"
#include "renderer/accel/gpu_scene.h"
#include "renderer/view.h"
#include "renderer/vk/vk_compute.h"
#include "renderer/world.h"

typedef struct rd_frame_settings {
    unsigned width, height;   /* 0 = RD_VIEW_DEFAULT_WIDTH x _HEIGHT (view.h) */
    float sky[3];             /* radiance of rays that escape (default black) */
    float exposure_ev;        /* exposure in stops: radiance * 2^ev before tone mapping */
    unsigned tonemap;         /* PC_TONEMAP_* (0 = ACES fit) */
    unsigned seed;            /* random streams of stochastic passes */
    unsigned view;            /* PC_VIEW_* */
    unsigned gi_updates;      /* probe updates before this frame is shaded (0 = 1) */
    unsigned pathtrace_spp;   /* > 0: reference path tracing with this many samples per pixel
                                 instead of direct light + probes (no probe updates) */
    unsigned max_bounces;     /* path tracing (0 = 64) */
    unsigned pathtrace_first; /* path tracing: samples already accumulated from an identical
                                 earlier frame (0 = start over); progressive rendering */
    unsigned reflections;     /* PC_REFLECT_* (0 = auto; rd_view_settings) */
    unsigned near_field;      /* PC_NEAR_* (0 = auto; rd_view_settings) */
    unsigned shadow_cull;     /* PC_SHADOW_CULL_* (0 = maps; rd_view_settings) */
    /* instead of sky when set: the environment (an image, if any, is the world's own:
     * rd_world_set_environment_image) */
    const rd_environment *env;
} rd_frame_settings;

typedef struct rd_renderer {
    rd_vk *vk;
    rd_view_passes passes;
    rd_world world;       /* world.gi, world.ddgi: the probe field */
    rd_view view;         /* view.width, view.height, view.rgba8, view.pathtrace_samples ... */
    rd_frame_stats stats; /* of the last frame: the world's updates, then the view's passes */
} rd_renderer;

rd_vk_result rd_renderer_create(rd_vk *vk, rd_renderer *r, char *err, size_t errlen);
void rd_renderer_destroy(rd_renderer *r); /* idempotent */
/* Configures global illumination for a scene with the given bounds (mode PC_GI_OFF turns it
 * off); resets the probe field. */
rd_vk_result rd_renderer_configure_gi(rd_renderer *r, const float bmin[3], const float bmax[3],
                                      const rd_ddgi_settings *gi, char *err, size_t errlen);
/* Renders one frame of scene from camera into the renderer's buffers (blocking): with GI on
 * and no path tracing, settings->gi_updates probe updates (at least 1) first. The image is a
 * still: while the view settles (rd_view_settling: its near-field history is young), it renders
 * the frame again, without probe updates, up to PC_NEAR_SETTLE_FRAMES times; stats hold the
 * world's updates and the last of those frames. */
rd_vk_result rd_renderer_render(rd_renderer *r, rd_gpu_scene *scene, const rd_view_camera *camera,
                                const rd_frame_settings *settings, char *err, size_t errlen);
/* Reads back the last frame: tone-mapped RGBA8 (width*height*4 bytes) or linear radiance
 * (width*height*3 floats). */
rd_vk_result rd_renderer_read_rgba8(rd_renderer *r, uint8_t *out, char *err, size_t errlen);
rd_vk_result rd_renderer_read_hdr(rd_renderer *r, float *rgb, char *err, size_t errlen);

#endif
