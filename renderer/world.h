/* world.h: everything scene-wide that views share: the scene being rendered, the sky, and the
 * DDGI probe field with its updates.
 *
 * A world is advanced explicitly (rd_world_update: a number of probe updates, each its own
 * blocking submission) and read by any number of views (view.h) in between; rendering a view
 * never writes the world, so the field advances at most as often as its owner asks, whatever
 * the number of views. Render thread only: this is Vulkan.
 */
#ifndef RD_WORLD_H
#define RD_WORLD_H

#include "renderer/scene/camera.h"
#include "renderer/gi/ddgi.h"
#include "renderer/env/environment.h"
#include "renderer/vk/frame_stats.h"
#include "renderer/accel/gpu_scene.h"
#include "renderer/gi/shadow_maps.h"
#include "renderer/vk/vk_buffer.h"
#include "renderer/vk/vk_compute.h"

typedef struct rd_world {
    rd_vk *vk;
    rd_gpu_scene *scene; /* the scene being rendered; NOT owned (the caller owns and
                                  destroys it) */
    /* the environment seen by primary misses, probe rays and path tracing (environment.h);
     * env.image points at image, the world's own copy of an HDR image (none: width 0) */
    rd_environment env;
    rd_env_image image;             /* the image's floats, reduced to RD_WORLD_SH_WIDTH: what the
                                       irradiance projection reads (none: width 0) */
    rd_buffer env_texels;           /* the image as RGBA16F, on the GPU; only while there is one */
    uint32_t env_width, env_height; /* of env_texels (0 without an image) */
    float env_sh[9][3];             /* irradiance SH9 of env */
    rd_ddgi ddgi;                   /* the probe field; valid when gi */
    rd_shadow_maps shadow_maps;     /* the lights' distance maps its updates shade hits with */
    bool gi;                        /* a GI mode other than off is configured */
    rd_buffer globals, counters;    /* for probe updates */
    /* the specular albedo table (shaders/brdf_albedo.comp, computed once at creation) that
     * camera pixels, probe-ray hits and reflection hits reflect with (brdf_hit_albedo) */
    rd_buffer brdf_albedo;
    rd_timer timer;
    uint64_t updates_total; /* probe updates run since creation (never reset; for stats) */
    /* in-place changes of what the world looks like (wake events: nodes or lights changed;
     * GI reconfigured), counted whether GI is on or not, so that views can restart what they
     * accumulate over frames (reflections); a new scene or environment shows in the globals */
    uint64_t changes;
    rd_frame_stats stats; /* GPU times and rays of the last rd_world_update call (all its
                             updates summed) */
} rd_world;

rd_vk_result rd_world_create(rd_vk *vk, rd_world *w, char *err, size_t errlen);
/* Frees what the world owns (not the scene). Idempotent. */
void rd_world_destroy(rd_world *w);
/* The scene that updates and views trace; NULL until set. Changing it does not reset the probe
 * field (call rd_world_configure_gi for a different scene). */
void rd_world_set_scene(rd_world *w, rd_gpu_scene *scene);
/* A uniform sky of this radiance (rd_world_set_environment with RD_ENV_UNIFORM). */
void rd_world_set_sky(rd_world *w, const float sky[3]);
/* The environment's mode and parameters (e->image is ignored: the world's own image, set by
 * rd_world_set_environment_image, is used in RD_ENV_IMAGE mode; without one that mode shows
 * e->sky uniformly). Recomputes the irradiance SH. */
void rd_world_set_environment(rd_world *w, const rd_environment *e);
/* Takes *img (left zeroed; width 0 drops the image), reduces it to RD_ENV_IMAGE_MAX_WIDTH and
 * uploads it (rd_world_stage_environment, then rd_world_set_environment_staged). */
rd_vk_result rd_world_set_environment_image(rd_world *w, rd_env_image *img, char *err,
                                            size_t errlen);

/* The width of the floats a world keeps of its environment image for the irradiance SH (SH9
 * has no detail finer than ~30 degrees; 512 texels are 0.7 degrees). */
#define RD_WORLD_SH_WIDTH 512u

/* An environment image made ready for the GPU on any thread, so that the render thread only
 * swaps it in (a 4096 x 2048 image's conversion and upload held every view's frame for 200 ms
 * on lavapipe, 100 ms on an H100): reduced to RD_ENV_IMAGE_MAX_WIDTH, converted to half RGBA
 * into staging memory (vk_staging.h), its floats shrunk to RD_WORLD_SH_WIDTH, its GPU buffer
 * created. */
typedef struct rd_env_staged {
    rd_vk *vk;              /* NULL: nothing staged */
    uint32_t width, height; /* of the texels */
    rd_env_image sh_image;  /* becomes rd_world.image */
    rd_buffer texels;       /* becomes rd_world.env_texels once the copies ran */
    rd_staging copies;
} rd_env_staged;
/* Stages *img (taken: left zeroed). Any thread; nothing is submitted. */
rd_vk_result rd_world_stage_environment(rd_vk *vk, rd_env_staged *out, rd_env_image *img, char *err,
                                        size_t errlen);
/* On the queue's thread: waits for frames in flight (they may sample the image replaced), runs
 * st's copies and makes it the world's image; st NULL (or empty) drops the image. st is left
 * empty either way. */
rd_vk_result rd_world_set_environment_staged(rd_world *w, rd_env_staged *st, char *err,
                                             size_t errlen);
void rd_env_staged_destroy(rd_env_staged *st); /* idempotent; any thread */
/* Configures global illumination for scene bounds (PC_GI_OFF frees the probe field) and resets
 * the field. RD_VK_ERR_UNSUPPORTED with a message for settings out of range; gi is then off. */
rd_vk_result rd_world_configure_gi(rd_world *w, const float bmin[3], const float bmax[3],
                                   const rd_ddgi_settings *gi, char *err, size_t errlen);
/* Runs n probe updates (blocking, submitted and waited); no-op returning OK when GI is off or
 * n == 0. Fills w->stats with the summed pass times ("probe trace", "probe shade", ...) and
 * rays. Needs a scene. */
rd_vk_result rd_world_update(rd_world *w, unsigned n, char *err, size_t errlen);
/* The cap of the offline tools' default convergence (`probecast render` without --frames,
 * eval's default row, the tests): a field still awake after this many updates is reported. */
#define RD_WORLD_CONVERGE_CAP 2000u
/* Runs probe updates until the field has converged (rd_ddgi_converged) or `cap` updates ran;
 * *done gets the number run. OK with *done = 0 when GI is off or the field is converged. */
rd_vk_result rd_world_converge(rd_world *w, unsigned cap, unsigned *done, char *err, size_t errlen);
/* No probe work is wanted: GI is off, or the field has converged and nothing woke it. */
bool rd_world_converged(const rd_world *w);
/* Wake events (world coordinates; see rd_ddgi_wake_box): the probe work is a no-op when GI is
 * off; both count as a change (w->changes) either way. */
void rd_world_wake_box(rd_world *w, const float lo[3], const float hi[3], float age);
void rd_world_wake_all(rd_world *w, float age);
/* Fills the world part of a pass's globals: scene refs, the probe volume shifted by the scene's
 * floating origin (zero when GI is off), sky. Leaves g->view alone. */
void rd_world_fill_globals(const rd_world *w, pc_globals *g);
/* rd_world_fill_globals for a view frame: the lights' distance maps in g->ddgi only as far as
 * they show the scene as it is now (rd_shadow_maps_view_lights), for the cull of camera pixels'
 * shadow rays. */
void rd_world_fill_view_globals(const rd_world *w, pc_globals *g);
/* Fills the camera part of g->view (eye shifted by the scene's floating origin, basis scaled by
 * the field of view and the aspect of width x height) and its size (x, y); a view's frames and
 * picks (pick.h) see the same rays. Needs a scene. */
void rd_world_fill_camera(const rd_world *w, const rd_view_camera *camera, unsigned width,
                          unsigned height, pc_globals *g);

#endif
