/* render_loop.h: the render thread. It owns Vulkan, the world (scene_service.h) and the views
 * (views.h); network threads reach it only through commands posted to its mailbox (mailbox.h),
 * and read what it publishes (snapshot.h, the encoder pool's frames, the stats) without
 * waiting for it.
 *
 * Each turn it applies the queued commands, then asks the scheduler (scheduler.h) what to do:
 * advance the world once (probe updates, the demo animation) while it converges or moves and
 * someone watches, render the dirty watched views in turn (paced to max_fps), re-encode a still
 * frame once a view's input stopped, or sleep on the mailbox. An idle, converged scene costs
 * nothing. Each frame's RGBA8 result is read back through a ring of fenced copies
 * (renderer/vk/readback.h) and handed to the encoder pool tagged with its view.
 */
#ifndef SRV_RENDER_LOOP_H
#define SRV_RENDER_LOOP_H

#include <cjson/cJSON.h>

#include "server/api/commands.h"
#include "server/encode/encoder_pool.h"
#include "server/render/frame_output.h"
#include "server/api/mailbox.h"
#include "server/scene/persist.h"
#include "server/render/render_stats.h"
#include "renderer/vk/vk_compute.h"
#include "server/scene/snapshot.h"

#define SRV_DEFAULT_VIEW 0u

typedef struct srv_render_config {
    const char *device;       /* Vulkan device selector, NULL = automatic */
    srv_settings settings;    /* initial settings */
    uint64_t generation_base; /* uploads get generations above this (and the scene's) */
    /* On a CPU device (lavapipe) start smaller: these flags say which settings the user chose
     * (SRV_SET_* bits); the others get CPU-friendly values. */
    bool adapt_to_cpu;
    unsigned settings_given;
    unsigned max_views;        /* views in all, the default view included (0 = 64) */
    uint64_t max_total_pixels; /* pixels over all views (0 = 16 Mi) */
    srv_encoder_pool *encoders;
    srv_jpeg_path jpeg_path; /* where JPEGs are transformed (frame_output.h) */
    srv_snapshot *snapshot;
    srv_persist *persist; /* may be NULL */
} srv_render_config;

typedef struct srv_render_loop srv_render_loop;

/* Creates the Vulkan device, the world and the default view and uploads scene (taken over;
 * left zeroed). When saved_state is not NULL it is applied first (scene_state.h). NULL with a
 * message on error. */
srv_render_loop *srv_render_loop_create(const srv_render_config *cfg, rd_scene *scene,
                                        const char *source, uint64_t generation,
                                        const cJSON *saved_state, char *err, size_t errlen);
bool srv_render_loop_start(srv_render_loop *l);
/* Stops the thread after its current frame; commands queued or posted later are answered 503.
 * Idempotent. */
void srv_render_loop_stop(srv_render_loop *l);
/* Vulkan validation warnings and errors so far (0 unless validation is on). */
unsigned srv_render_loop_validation_messages(srv_render_loop *l);
/* Stops, waits for the GPU and destroys everything in reverse order (NULL is fine). */
void srv_render_loop_destroy(srv_render_loop *l);

/* The loop's Vulkan device, for connection threads that stage an upload's GPU buffers before
 * posting it (rd_gpu_scene_stage, rd_world_stage_environment: buffer creation and host writes
 * only; the queue stays the render thread's). Valid until srv_render_loop_destroy. */
rd_vk *srv_render_loop_device(srv_render_loop *l);

/* srv_mailbox_call / srv_mailbox_post on the loop's mailbox. */
bool srv_render_call(srv_render_loop *l, srv_cmd *c, unsigned timeout_ms);
uint64_t srv_render_post(srv_render_loop *l, srv_cmd *c);

/* A fresh view id for a stream connection's own view (any thread). */
uint32_t srv_render_new_view_id(srv_render_loop *l);
/* The limits views are held to. */
void srv_render_view_limits(const srv_render_loop *l, srv_view_limits *out);
/* The number of connected viewers (the animation runs only while someone watches). */
void srv_render_set_viewers(srv_render_loop *l, unsigned viewers);
void srv_render_get_stats(srv_render_loop *l, srv_render_stats *out);

#endif
