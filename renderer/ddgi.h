/* ddgi.h: the DDGI probe volume (Majercik et al. 2019) on the GPU: grid placement, probe
 * atlases, and the per-update passes (trace, shade, blend distance, blend irradiance,
 * borders). The world (world.h) runs updates in their own submissions; views only sample
 * the field (sampling reads neither the rotation nor the update index).
 */
#ifndef RD_DDGI_H
#define RD_DDGI_H

#include "../shaders/gpu_types.h"
#include "vk_buffer.h"
#include "vk_compute.h"

/* What a zero rays or an unset hysteresis in rd_ddgi_settings stands for (the server's
 * settings table takes its defaults from here too). */
#define RD_DDGI_DEFAULT_HYSTERESIS 0.97f
#define RD_DDGI_DEFAULT_RAYS 256u

typedef struct rd_ddgi_settings {
    unsigned mode;       /* PC_GI_OFF, PC_GI_CLASSIC or PC_GI_DDGI */
    unsigned counts[3];  /* probes per axis; 0 = fit to the scene */
    float spacing[3];    /* 0 = derived (from counts, or from the scene's size) */
    float origin[3];     /* position of probe (0,0,0), used when has_origin */
    bool has_origin;
    unsigned rays;       /* rays per probe per update; 0 = RD_DDGI_DEFAULT_RAYS */
    float hysteresis;    /* weight of the old value; 0 = RD_DDGI_DEFAULT_HYSTERESIS unless... */
    bool has_hysteresis; /* ...this is set: then hysteresis is used as given, 0 included */
    unsigned seed;       /* ray rotations are a deterministic function of seed and update */
} rd_ddgi_settings;

typedef struct rd_ddgi {
    rd_vk *vk;
    rd_pipeline trace, shade, blend, border;
    rd_buffer irradiance, distance, rays, hits, probes;
    pc_ddgi_volume vol;     /* what the shaders see (rotation of the current update) */
    rd_ddgi_settings settings;
    unsigned updates;       /* since the last reset */
    bool configured;
} rd_ddgi;

rd_vk_result rd_ddgi_create(rd_vk *vk, rd_ddgi *d, char *err, size_t errlen);
void rd_ddgi_destroy(rd_ddgi *d); /* idempotent */

/* Places the grid for scene bounds and settings (allocating atlases when the probe or ray
 * count changes) and resets the field. Returns RD_VK_ERR_UNSUPPORTED with a message for
 * settings out of range. */
rd_vk_result rd_ddgi_configure(rd_ddgi *d, const float bmin[3], const float bmax[3],
                               const rd_ddgi_settings *s, char *err, size_t errlen);
/* Forgets all probe history (next update starts from scratch). */
rd_vk_result rd_ddgi_reset(rd_ddgi *d, char *err, size_t errlen);
/* Chooses the next update's random rotation; call before writing pc_globals for it. */
void rd_ddgi_begin_update(rd_ddgi *d);
/* Records one probe update. globals must hold d->vol as set by rd_ddgi_begin_update.
 * Timer marks: "probe trace", "probe shade", "blend distance", "blend irradiance", "borders".
 * Off probes (inside geometry) trace PC_DDGI_INACTIVE_RAYS rays and are not shaded or blended. */
void rd_ddgi_record_update(rd_ddgi *d, rd_cmd *c, rd_timer *timer, VkDeviceAddress globals,
                           VkDeviceAddress counters);
/* Call after the update's command buffer was submitted. */
void rd_ddgi_end_update(rd_ddgi *d);
/* Probe count and total rays per update. */
unsigned rd_ddgi_probe_count(const rd_ddgi *d);

/* Downloads the atlases as images: tiles in probe order, ceil(sqrt(probes)) per row.
 * irradiance: decoded linear E/pi (rgb); distance: (mean, mean square, 0). Caller frees. */
rd_vk_result rd_ddgi_read_atlases(rd_ddgi *d, float **irr_rgb, unsigned *irr_w, unsigned *irr_h,
                                  float **dist_rgb, unsigned *dist_w, unsigned *dist_h,
                                  char *err, size_t errlen);

/* Uniformly random rotation (rows of a 3x3) from a 64-bit state (Shoemake's quaternion
 * method); advances the state. Exposed for tests. */
void rd_ddgi_random_rotation(uint64_t *state, float rows[3][3]);

#endif
