/* shadow_maps.h: distance maps of the scene's lights (cubes around point and spot lights,
 * orthographic squares for directional ones), the visibility that probe-ray hits read instead
 * of tracing a shadow ray (shaders/shadow_map.glsl has the layout and the lookup,
 * shaders/shadow_map.comp the build).
 *
 * Why: a probe update shades every hit of its probe rays with one shadow ray; on an interior
 * with 11 lights those rays cost more than the probe rays themselves (issue 14; measurements in
 * tests/bench/results/h100/probe_shading.txt). A map costs one ray per texel once (6 x
 * PC_SHADOW_MAP_SIDE^2 for a point light, PC_SHADOW_MAP_SUN_SIDE^2 for a sun) and then serves
 * every update until the geometry changes (every map) or its light moves (that light's map),
 * so an idle or static scene pays for it once. View frames read them too, as a cull of camera
 * pixels' shadow rays (rd_shadow_maps_view_lights), so the maps' memory is freed or replaced only
 * after the device is idle.
 *
 * When maps are stale, each update decides whether rebuilding them pays: a rebuild is worth it
 * when its rays are at most the shadow rays it saves, i.e. the update's probe hits times the
 * updates the maps are expected to serve: as many as the scene's previous revision lasted, or
 * as the current one has lasted so far, whichever is more. A scene that changes every update
 * with few probe hits traces shadow rays for its stale lights; a new scene, or one that stands
 * still, gets its maps once its shadow rays have cost about one rebuild (the rent-or-buy rule,
 * never more than twice the better choice's cost: builtin:interior at 256 rays per probe
 * builds them at its first update, at 64 rays at its fourth; a tiny probe grid may never).
 * Render thread only (this is Vulkan).
 */
#ifndef RD_SHADOW_MAPS_H
#define RD_SHADOW_MAPS_H

#include "renderer/accel/gpu_scene.h"
#include "renderer/vk/vk_buffer.h"
#include "renderer/vk/vk_compute.h"

/* How probe hits see the lights (render --probe-shadows): distance maps where they pay (the
 * default), shadow rays always (the exact reference), or maps rebuilt every update (what a scene
 * that changes every update costs at most; for benchmarks). */
typedef enum rd_probe_shadows {
    RD_PROBE_SHADOWS_MAPS = 0,
    RD_PROBE_SHADOWS_RAYS,
    RD_PROBE_SHADOWS_REBUILD,
} rd_probe_shadows;

/* A rectangle of one face of a light's map (face PC_SHADOW_MAP_SUN_FACE: a sun's square) that
 * a partial rebuild re-traces: texels [x0, x0 + w) x [y0, y0 + h). */
typedef struct rd_shadow_map_rect {
    uint32_t light, face, x0, y0, w, h;
} rd_shadow_map_rect;

typedef struct rd_shadow_maps {
    rd_vk *vk;
    rd_probe_shadows mode;
    rd_pipeline build; /* created with the first build */
    rd_buffer maps;    /* tables and distances (layout: shaders/shadow_map.glsl) */
    uint64_t capacity; /* words the buffer holds */
    uint32_t lights;   /* lights the layout covers (the first PC_SHADOW_MAP_MAX_LIGHTS) */
    uint32_t layout[PC_SHADOW_MAP_MAX_LIGHTS]; /* light i's map offset in words (0: none) */
    /* what the maps show: the scene's geometry revision, and per light the light revision
     * (0: no valid map); a light whose map is stale traces shadow rays until it is rebuilt */
    uint64_t geometry;
    uint64_t shown[PC_SHADOW_MAP_MAX_LIGHTS];
    uint32_t table[PC_SHADOW_MAP_MAX_LIGHTS]; /* offsets as the GPU has them (0: no map) */
    bool complete;  /* every light of the scene has a valid map this update */
    float frame[4]; /* the suns' frame: centre xyz and radius (GPU frame) */
    rd_shadow_map_rect rects[6 * PC_SHADOW_MAP_MAX_LIGHTS]; /* a partial rebuild's (scratch) */
    /* revision change tracking: the revision last seen, the updates since it changed, and the
     * updates the one before it lasted (0 before any change was seen) */
    uint64_t seen;
    uint64_t seen_updates;
    uint64_t interval;
    uint64_t builds; /* maps built since creation (for tests and statistics) */
} rd_shadow_maps;

/* Sets m up empty for vk (no pipeline, no memory until a scene needs them). */
void rd_shadow_maps_init(rd_vk *vk, rd_shadow_maps *m);
/* Frees the pipeline and the maps. Idempotent. */
void rd_shadow_maps_destroy(rd_shadow_maps *m);
/* Frees the maps' memory (GI went off, or the scene has no light). */
void rd_shadow_maps_release(rd_shadow_maps *m);
/* Lights whose map the last update could read. */
unsigned rd_shadow_maps_valid(const rd_shadow_maps *m);
/* Lights [0, n) whose maps show the scene as it is now (its geometry and those lights'
 * revisions), for view frames recorded between updates: camera pixels cull their shadow rays
 * by them (shaders/shadow_map.glsl, direct_radiance) and reflection hits read their visibility
 * (direct_radiance with DIRECT_MAP_VISIBILITY). 0 when the maps show an older geometry or there
 * are none. */
uint32_t rd_shadow_maps_view_lights(const rd_shadow_maps *m, const rd_gpu_scene *scene);

/* Called once per probe update before its shading is recorded into c, after the scene's
 * pending light values (rd_gpu_scene_record_updates). Records a rebuild when the maps are stale
 * and rebuilding pays for `hits` probe hits per update (see above), marking the timer section
 * "shadow maps". *mapped gets the number of lights whose maps the update's shading may read
 * (lights [0, *mapped); 0: shadow rays for all; m->complete: every light has one) and
 * *address the maps' address. globals and
 * counters as for any pass (the build reads the scene's lights and counts its rays). */
rd_vk_result rd_shadow_maps_prepare(rd_shadow_maps *m, rd_cmd *c, rd_timer *timer,
                                    const rd_gpu_scene *scene, uint64_t hits,
                                    VkDeviceAddress globals, VkDeviceAddress counters,
                                    uint32_t *mapped, VkDeviceAddress *address, char *err,
                                    size_t errlen);

#endif
