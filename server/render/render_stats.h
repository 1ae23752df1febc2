/* render_stats.h: what the render thread reports to /v1/stats and /metrics, behind a lock so
 * the HTTP threads can read it at any time. */
#ifndef SRV_RENDER_STATS_H
#define SRV_RENDER_STATS_H

#include <pthread.h>
#include <stdbool.h>
#include <stdint.h>

#include "renderer/vk/frame_stats.h"

#define SRV_PASS_NAME_MAX 24
#define SRV_FPS_WINDOW 256
#define SRV_STATS_PT_VIEWS 64 /* views whose path-trace sample counts /v1/stats lists */

/* GPU passes of one submission, copied out of an rd_frame_stats. */
typedef struct srv_pass_times {
    unsigned count;
    char name[RD_TIMER_MAX][SRV_PASS_NAME_MAX];
    double ms[RD_TIMER_MAX];
    double total_ms;
    uint64_t rays;
} srv_pass_times;

typedef struct srv_render_stats {
    char device[256];
    bool jpeg_gpu; /* JPEGs transformed on the GPU (frame_output.h) */
    bool device_lost;
    char last_error[256];
    uint64_t frames_rendered, stills_reencoded, commands_applied;
    double fps;                 /* frames rendered (all views) in the last second */
    double frame_ms_last;       /* wall time of the last view render */
    unsigned width, height;     /* of the last rendered view */
    srv_pass_times view_passes; /* the last view frame */
    double rays_per_second;     /* rays of the last view frame / its GPU time */
    bool rendering;             /* something is changing (not idle) */
    /* the world */
    uint64_t world_ticks;         /* times the world advanced */
    uint64_t world_updates_total; /* probe updates run */
    srv_pass_times world_passes;  /* the last tick's probe updates */
    double world_updates_per_second;
    unsigned gi_mode;
    unsigned probes, probe_counts[3], rays_per_probe;
    unsigned gi_updates;                                /* since the last change that woke probes */
    unsigned probes_awake, probes_sleeping, probes_off; /* per state (renderer/gi/ddgi.h) */
    bool gi_converged;                                  /* no probe awake: no probe work */
    double gi_drift;            /* relative change per update of the awake field (smoothed) */
    unsigned shadow_map_lights; /* lights whose distance map is valid (renderer/gi/shadow_maps.h) */
    uint64_t shadow_map_builds, shadow_map_bytes;
    uint64_t scene_generation, triangles;
    /* deforming meshes (rd_gpu_scene): the last pose that changed one (all its mesh work, the
     * GPU time of the posing and of the refits), and the mesh poses refitted on the GPU,
     * rebuilt on the CPU or rebuilt on the GPU since the scene was loaded */
    double deform_build_ms, deform_ms, refit_ms;
    uint64_t deform_refits, deform_rebuilds, deform_gpu_rebuilds;
    /* path tracing (gi_mode pathtrace; pt_target 0 otherwise) */
    unsigned pt_target;  /* samples each view accumulates */
    unsigned pt_samples; /* the fewest of the watched views (srv_views_pt_samples_min) */
    unsigned pt_view_count;
    struct {
        uint32_t view;
        unsigned samples;
    } pt_views[SRV_STATS_PT_VIEWS]; /* the first SRV_STATS_PT_VIEWS views (view 0 first) */
    /* views */
    unsigned views, views_watched;
    unsigned viewers; /* stream connections */
} srv_render_stats;

typedef struct srv_stats_board {
    pthread_mutex_t mu;
    srv_render_stats s;
    double frame_times[SRV_FPS_WINDOW];
    unsigned frame_next;
    double tick_times[SRV_FPS_WINDOW];
    unsigned tick_updates[SRV_FPS_WINDOW];
    unsigned tick_next;
} srv_stats_board;

void srv_stats_board_init(srv_stats_board *b);
void srv_stats_board_dispose(srv_stats_board *b);
/* A view frame was rendered at now_ms taking wall_ms; fs are its GPU passes. */
void srv_stats_board_frame(srv_stats_board *b, const rd_frame_stats *fs, unsigned width,
                           unsigned height, double now_ms, double wall_ms);
/* The world advanced by updates probe updates; fs are their GPU passes. */
void srv_stats_board_tick(srv_stats_board *b, const rd_frame_stats *fs, unsigned updates,
                          double now_ms);
void srv_stats_board_error(srv_stats_board *b, const char *message, bool device_lost);
/* A consistent copy, with fps and updates per second over the last second. */
void srv_stats_board_get(srv_stats_board *b, srv_render_stats *out);

#endif
