/* eval_internal.h: what the parts of `probecast eval` share: its options, the device and
 * renderer it measures with, and the cached path-traced references. */
#ifndef SRV_EVAL_INTERNAL_H
#define SRV_EVAL_INTERNAL_H

#include <stdbool.h>

#include "renderer/render.h"

/* The material families eval renders each case in (--materials): the builtin's own Lambertian
 * materials, and its glTF twins NAME+gltf and NAME+metal (renderer/builtin/procedural.h). */
enum { EVAL_LAMBERT = 1, EVAL_GLTF = 2, EVAL_METAL = 4 };

typedef struct eval_args {
    const char *cases, *out_dir, *cache_dir, *device;
    unsigned width, height, ref_spp, timing_frames;
    unsigned rays[8], nrays;
    unsigned updates[8], nupdates;
    float density[8];
    unsigned ndensity;
    unsigned probes[8][3], nprobes; /* explicit probe counts (replace densities) */
    float hysteresis[8];
    unsigned nhysteresis;
    unsigned families; /* bit per material family: EVAL_LAMBERT, EVAL_GLTF, EVAL_METAL */
    bool noise_floor, list;
    bool dynamic; /* --dynamic: the dynamic cases instead of the static suite */
    bool no_default_lighting;
    const char *replot;
    /* the GI settings every row starts from: the defaults, with the setting flags eval does not
     * sweep (--visibility-rays, --probe-relocation, --probe-paths; --near-field is a view
     * setting, kept in near_field); rows set mode, counts,
     * rays, hysteresis and seed */
    rd_ddgi_settings base;
    unsigned near_field;  /* PC_NEAR_* of every row (--near-field) */
    unsigned shadow_cull; /* PC_SHADOW_CULL_* of every row (--shadow-cull) */
    unsigned reflections; /* PC_REFLECT_* of every row (--reflections on|off) */
    char base_label[48];  /* those flags as row labels show them ("" at the defaults) */
} eval_args;

typedef struct eval_ctx {
    rd_vk vk;
    rd_renderer r;
    const eval_args *a;
    rd_environment env; /* the current scene's: black, or the default lighting's */
    char err[512];
} eval_ctx;

/* The renderer's default lighting (renderer/scene/default_lighting.h) for scene s of case name,
 * as `probecast render` applies it: c->env becomes black or the default environment, and a
 * scene that needs it gets the key light for cam (before its GPU scene is built). */
void eval_default_lighting(eval_ctx *c, const char *name, rd_scene *s, const rd_view_camera *cam);

/* Renders (or loads from the cache in a->cache_dir, keyed by a hash of the scene as it is
 * now, the image size, the sample count and seed) the path-traced reference of scene; name
 * prefixes the cache file. NULL with c->err on failure; *ms = GPU time (0 when cached). */
float *eval_reference(eval_ctx *c, const char *name, rd_scene *s, rd_gpu_scene *gs,
                      const rd_view_camera *cam, unsigned seed, double *ms);

/* probecast eval --dynamic: how the probe field follows a moving light and a moving object
 * (updates, GPU ms and error against the reference of the new state, at fixed update counts
 * after the change). Prints a table, writes DIR/eval-dynamic.csv. Returns 0 or 1. */
int eval_dynamic_run(eval_ctx *c);

#endif
