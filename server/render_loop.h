/* render_loop.h: the render thread. It owns Vulkan, the GPU scene and the scene state; network
 * threads reach it only through commands (commands.h) posted to its queue.
 *
 * The thread renders while anything changes: a command changed the view, the demo animation
 * runs (only while viewers watch), or the probes have not converged since the last lighting
 * change; frames are paced to the max_fps setting. Otherwise it sleeps on its queue, so an idle,
 * converged scene costs nothing. Each frame's RGBA8 result is read back through a ring of
 * fenced copies (readback.h) and handed to the encoder pool; ~still_delay_ms after the last
 * input the last image is re-encoded once at still quality.
 */
#ifndef SRV_RENDER_LOOP_H
#define SRV_RENDER_LOOP_H

#include <cjson/cJSON.h>

#include "commands.h"
#include "encoder_pool.h"
#include "persist.h"
#include "renderer/vk_compute.h"

typedef struct srv_render_config {
    const char *device;       /* Vulkan device selector, NULL = automatic */
    srv_settings settings;    /* initial settings */
    uint64_t generation_base; /* uploads get generations above this (and the scene's) */
    /* On a CPU device (lavapipe) start smaller: these flags say which settings the user chose
     * (SRV_SET_* bits); the others get CPU-friendly values. */
    bool adapt_to_cpu;
    unsigned settings_given;
    srv_encoder_pool *encoders;
    srv_persist *persist; /* may be NULL */
} srv_render_config;

#define SRV_PASS_NAME_MAX 24

typedef struct srv_render_stats {
    char device[256];
    bool device_lost;
    char last_error[256];
    uint64_t frames_rendered, stills_reencoded, commands_applied;
    double fps;           /* frames rendered in the last second */
    double frame_ms_last; /* wall time of the last render call */
    unsigned width, height;
    unsigned pass_count;
    char pass_name[RD_TIMER_MAX][SRV_PASS_NAME_MAX];
    double pass_ms[RD_TIMER_MAX];
    double gpu_ms_last;     /* sum of the passes */
    uint64_t rays_last;     /* rays traced by the last frame (all kinds) */
    double rays_per_second; /* rays_last / gpu_ms_last */
    bool rendering;         /* something is changing (not idle) */
    unsigned gi_mode;
    unsigned probes, probe_counts[3], rays_per_probe, gi_updates, gi_converge_updates;
    uint64_t scene_generation, triangles;
    unsigned viewers;
} srv_render_stats;

typedef struct srv_render_loop srv_render_loop;

/* Creates the Vulkan device and renderer and uploads scene (taken over; left zeroed). When
 * saved_state is not NULL it is applied first (scene_state.h). NULL with a message on error. */
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

/* A new command with one reference (the caller's). */
srv_cmd *srv_cmd_new(srv_cmd_kind kind);
void srv_cmd_unref(srv_cmd *c);

/* Posts c and waits up to timeout_ms for its reply (c->reply). On timeout the reply is a 503
 * and false is returned (the command may still be applied later). c stays the caller's. */
bool srv_render_call(srv_render_loop *l, srv_cmd *c, unsigned timeout_ms);
/* Posts c without waiting (takes the caller's reference). Returns its input ticket, or 0 when
 * the queue is full or the loop stopped (then c is dropped). */
uint64_t srv_render_post(srv_render_loop *l, srv_cmd *c);

/* The number of connected viewers (animation runs only while someone watches). */
void srv_render_set_viewers(srv_render_loop *l, unsigned viewers);
void srv_render_get_stats(srv_render_loop *l, srv_render_stats *out);

#endif
