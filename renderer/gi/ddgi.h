/* ddgi.h: the DDGI probe volume (Majercik et al. 2019) on the GPU: grid placement, probe
 * atlases, and the per-update passes (trace, shade, blend distance, blend irradiance,
 * borders). The world (world.h) runs updates in their own submissions; views only sample
 * the field (sampling reads neither the rotation nor the update index).
 */
#ifndef RD_DDGI_H
#define RD_DDGI_H

#include "shaders/gpu_types.h"
#include "renderer/vk/vk_buffer.h"
#include "renderer/vk/vk_compute.h"

/* Sides of a probe's atlas tiles: the octahedral interior and a one-texel border. */
#define RD_DDGI_IRR_SIDE (PC_DDGI_IRR_INTERIOR + 2)
#define RD_DDGI_DIST_SIDE (PC_DDGI_DIST_INTERIOR + 2)

/* The probe field's defaults (what zero rays or an unset has_hysteresis in rd_ddgi_settings stand
 * for) and limits (rd_ddgi_configure refuses settings beyond them). The server's settings table
 * (server/api/settings.h) takes its defaults and ranges from here. */
#define RD_DDGI_DEFAULT_HYSTERESIS 0.97f
#define RD_DDGI_MAX_PATH_BOUNCES 8u     /* probe paths (ddgi_shade.comp) */
#define RD_DDGI_DEFAULT_PATH_BOUNCES 3u /* with near-field rays at camera pixels (gpu_types.h) */
#define RD_DDGI_MAX_HYSTERESIS 0.999f   /* hysteresis in [0, this]; 1 would never change */
#define RD_DDGI_DEFAULT_RAYS 256u       /* rays in 1..PC_DDGI_MAX_RAYS (shaders/gpu_types.h) */
#define RD_DDGI_MAX_AXIS_PROBES 256u    /* probes per axis */
#define RD_DDGI_MAX_PROBES 65535u       /* in all: a workgroup row each, the dispatch limit */

typedef struct rd_ddgi_settings {
    unsigned mode;      /* PC_GI_OFF, PC_GI_CLASSIC or PC_GI_DDGI */
    unsigned counts[3]; /* probes per axis; 0 = fit to the scene */
    float spacing[3];   /* 0 = derived (from counts, or from the scene's size) */
    float origin[3];    /* position of probe (0,0,0), used when has_origin */
    bool has_origin;
    unsigned rays;         /* rays per probe per update; 0 = RD_DDGI_DEFAULT_RAYS */
    float hysteresis;      /* maximum weight of the old value, used when has_hysteresis is set */
    bool has_hysteresis;   /* (0 too: no history); unset = RD_DDGI_DEFAULT_HYSTERESIS */
    unsigned seed;         /* ray rotations are a deterministic function of seed and update */
    unsigned visibility;   /* PC_DDGI_VIS_* (0: ALL, the default) */
    bool relocation;       /* probes move out of geometry and off surfaces (PC_DDGI_RELOCATE_*) */
    unsigned path_bounces; /* bounces a probe ray's path takes before the field ends it (0: the
                              paper's first hit), at most RD_DDGI_MAX_PATH_BOUNCES, used when
                              has_path_bounces is set */
    bool has_path_bounces; /* unset = RD_DDGI_DEFAULT_PATH_BOUNCES */
} rd_ddgi_settings;

/* Probes per state after the last update (or reset). */
typedef struct rd_ddgi_census {
    unsigned awake, sleeping, off;
    unsigned updated; /* probes the last update worked on (awake ones and off re-checks) */
} rd_ddgi_census;

typedef struct rd_ddgi {
    rd_vk *vk;
    rd_pipeline trace, shade, blend_distance, blend_irradiance, border, select, wake, bin, scan,
        weights;
    rd_buffer irradiance, distance, rays, hits, probes, stats, list, order;
    rd_buffer weight_lists;     /* the update's blend weights (ddgi_weights.comp) */
    rd_buffer bins, sorted;     /* probe-hit binning for sorted shading (ddgi_bin.comp) */
    rd_buffer ctrl, wake_boxes; /* host-visible: pc_ddgi_control, pc_ddgi_wake[] */
    pc_ddgi_volume vol;         /* what the shaders see (rotation of the current update) */
    rd_ddgi_settings settings;
    unsigned updates; /* since the last reset */
    bool configured;
    rd_ddgi_census census;
    /* drift of the awake field (renderer/gi/ddgi.c, "convergence"): exponential mean of the
     * relative change of its luminance per update that each update's fresh values ask for, the
     * noise variance of those measures, the last two, how many since the awake set was last
     * new, hold = significant drift (ages hold); drift_unit: the drift sums' fixed point
     * (pc_ddgi_volume.params.w) */
    double drift, drift_var, drift_recent[2], drift_unit;
    unsigned drift_measures;
    bool hold;
    unsigned wake_count; /* wake boxes waiting for the next update */
    /* Sort the hits by place before shading them (probe sort) when shading traces shadow rays:
     * neighbouring hits' shadow rays then run side by side. When every light's visibility
     * comes from its distance map (shadow_maps.h) the hits are shaded in the trace's order
     * instead, which measured cheaper than sorting on builtin:interior (H100, 256 rays: 0.69
     * against 0.20 + 0.60 ms; tests/bench/results/h100/probe_shading.txt). Set by the world
     * before each update. */
    bool sort_hits;
    pc_ddgi_wake wakes[PC_DDGI_WAKE_MAX];
} rd_ddgi;

rd_vk_result rd_ddgi_create(rd_vk *vk, rd_ddgi *d, char *err, size_t errlen);
void rd_ddgi_destroy(rd_ddgi *d); /* idempotent */

/* Places the grid for scene bounds and settings (allocating atlases when the probe or ray
 * count changes) and resets the field. Returns RD_VK_ERR_UNSUPPORTED with a message for
 * settings out of range. */
rd_vk_result rd_ddgi_configure(rd_ddgi *d, const float bmin[3], const float bmax[3],
                               const rd_ddgi_settings *s, char *err, size_t errlen);
/* Forgets all probe history (next update starts from scratch; every probe awake). */
rd_vk_result rd_ddgi_reset(rd_ddgi *d, char *err, size_t errlen);
/* Wakes, at the next update, the probes within one probe spacing of the box [lo, hi] (GPU
 * frame: world minus the scene's origin shift): sleeping ones wake and every one reached gets
 * an age of at most `age` (PC_DDGI_WAKE_AGE_*); off probes there are re-checked. */
void rd_ddgi_wake_box(rd_ddgi *d, const float lo[3], const float hi[3], float age);
void rd_ddgi_wake_all(rd_ddgi *d, float age);
/* Converged: at least one update ran, no probe is awake and no wake is pending; updating
 * would change nothing. */
bool rd_ddgi_converged(const rd_ddgi *d);
/* The age at which a probe falls asleep for the configured maximum hysteresis. */
float rd_ddgi_sleep_age(float max_hysteresis);
/* The most updates after a wake event (or a reset) before a probe falls asleep, however the field
 * drifts: ages hold for at most PC_DDGI_HOLD_FACTOR sleep ages, plus one off re-check period for
 * a probe that flips between off and awake (601 at the default 0.97). */
unsigned rd_ddgi_sleep_bound(float max_hysteresis);
/* Chooses the next update's random rotation; call before writing pc_globals for it. */
void rd_ddgi_begin_update(rd_ddgi *d);
/* Records one probe update. globals must hold d->vol as set by rd_ddgi_begin_update.
 * Timer marks: "probe trace", "probe sort" (only with sort_hits), "probe shade",
 * "blend distance", "blend irradiance", "borders".
 * Off probes (inside geometry) trace PC_DDGI_INACTIVE_RAYS rays and are not shaded or blended. */
void rd_ddgi_record_update(rd_ddgi *d, rd_cmd *c, rd_timer *timer, VkDeviceAddress globals,
                           VkDeviceAddress counters);
/* Call after the update's command buffer completed: reads back the census and the drift. */
void rd_ddgi_end_update(rd_ddgi *d);
/* The order in which a probe's threads take its rays (pc_ddgi_volume.order): a permutation of
 * 0..rays-1 that keeps neighbouring directions in neighbouring threads. */
void rd_ddgi_ray_order(unsigned rays, uint32_t *order);
/* Probe count and total rays per update. */
unsigned rd_ddgi_probe_count(const rd_ddgi *d);

/* Downloads the atlases as images: tiles in probe order, ceil(sqrt(probes)) per row.
 * irradiance: decoded linear E/pi (rgb); distance: (mean, mean square, 0). Caller frees. */
rd_vk_result rd_ddgi_read_atlases(rd_ddgi *d, float **irr_rgb, unsigned *irr_w, unsigned *irr_h,
                                  float **dist_rgb, unsigned *dist_w, unsigned *dist_h, char *err,
                                  size_t errlen);

/* One probe as the GPU holds it (rd_ddgi_read_probes). */
typedef struct rd_ddgi_probe_info {
    float position[3]; /* world position: grid point plus its offset */
    unsigned state;    /* PC_DDGI_PROBE_OFF, _AWAKE or _SLEEPING */
    float age;         /* updates blended since its last wake (sleeps at rd_ddgi_sleep_age) */
    float held;        /* updates its age was held while the field drifted */
    unsigned edges;    /* bits 0-2: geometry crosses the segment to the +x, +y, +z neighbour */
} rd_ddgi_probe_info;
/* Downloads every probe's position, state and ages (rd_ddgi_probe_count entries; caller frees). */
rd_vk_result rd_ddgi_read_probes(rd_ddgi *d, rd_ddgi_probe_info **out, char *err, size_t errlen);

/* Uniformly random rotation (rows of a 3x3) from a 64-bit state (Shoemake's quaternion
 * method); advances the state. Exposed for tests. */
void rd_ddgi_random_rotation(uint64_t *state, float rows[3][3]);

#endif
