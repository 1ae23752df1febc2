/* shadow_maps.c: the lights' distance maps for probe-hit shading (see shadow_maps.h). */
#include "shadow_maps.h"

#include <stdint.h>
#include <string.h>

#include "shaders/shadow_map.spv.h"

#define FACE_TEXELS ((uint64_t)PC_SHADOW_MAP_SIDE * PC_SHADOW_MAP_SIDE)
#define SUN_TEXELS ((uint64_t)PC_SHADOW_MAP_SUN_SIDE * PC_SHADOW_MAP_SUN_SIDE)
/* Memory the maps may take, in 4-byte words (128 MiB: 80 point lights and 20 suns at once);
 * lights past it keep shadow rays. */
#define BUDGET_WORDS (32ull << 20)

void rd_shadow_maps_init(rd_vk *vk, rd_shadow_maps *m)
{
    memset(m, 0, sizeof *m);
    m->vk = vk;
    m->interval = UINT64_MAX;
}

void rd_shadow_maps_release(rd_shadow_maps *m)
{
    if (!m->vk) return;
    rd_buffer_destroy(m->vk, &m->maps);
    m->capacity = 0;
    m->lights = 0;
}

void rd_shadow_maps_destroy(rd_shadow_maps *m)
{
    if (!m->vk) return;
    rd_shadow_maps_release(m);
    rd_pipeline_destroy(m->vk, &m->build);
    m->vk = NULL;
}

/* The revision's age bookkeeping: how many updates the previous revision lasted. */
static void track(rd_shadow_maps *m, uint64_t revision)
{
    if (revision != m->seen) {
        if (m->seen != 0) m->interval = m->seen_updates;
        m->seen = revision;
        m->seen_updates = 0;
    }
    m->seen_updates++;
}

/* Map offsets (in words) of lights [0, n) per the layout of shaders/shadow_map.glsl; lights
 * past the memory budget get none. Returns the words the buffer needs; *rays the texels. */
static uint64_t lay_out(const rd_gpu_scene *scene, uint32_t n, uint32_t table[], uint64_t *rays,
                        bool *local, bool *sun, bool *complete)
{
    uint64_t at = PC_SHADOW_MAP_MAX_LIGHTS;
    *rays = 0;
    *local = *sun = false;
    *complete = n == scene->refs.counts.y;
    memset(table, 0, sizeof(uint32_t) * PC_SHADOW_MAP_MAX_LIGHTS);
    for (uint32_t i = 0; i < n; i++) {
        bool directional = (scene->directional[i / 64] >> (i % 64)) & 1u;
        uint64_t texels = directional ? SUN_TEXELS : 6 * FACE_TEXELS;
        if (at + texels > BUDGET_WORDS) {
            *complete = false;
            continue;
        }
        table[i] = (uint32_t)at;
        at += texels;
        *rays += texels;
        *sun = *sun || directional;
        *local = *local || !directional;
    }
    return at;
}

rd_vk_result rd_shadow_maps_prepare(rd_shadow_maps *m, rd_cmd *c, rd_timer *timer,
                                    const rd_gpu_scene *scene, uint64_t hits,
                                    VkDeviceAddress globals, VkDeviceAddress counters,
                                    uint32_t *mapped, VkDeviceAddress *address, char *err,
                                    size_t errlen)
{
    *mapped = 0;
    *address = 0;
    uint32_t n = scene->refs.counts.y;
    if (n > PC_SHADOW_MAP_MAX_LIGHTS) n = PC_SHADOW_MAP_MAX_LIGHTS;
    if (n == 0 || m->mode == RD_PROBE_SHADOWS_RAYS) {
        rd_shadow_maps_release(m);
        return RD_VK_OK;
    }
    track(m, scene->revision);
    if (m->mode == RD_PROBE_SHADOWS_REBUILD) m->lights = 0;
    if (m->lights == n && m->revision == scene->revision) {
        *mapped = n;
        *address = m->maps.address;
        return RD_VK_OK;
    }
    m->lights = 0; /* stale from here on */
    uint32_t table[PC_SHADOW_MAP_MAX_LIGHTS];
    uint64_t rays;
    bool local, sun, complete;
    uint64_t words = lay_out(scene, n, table, &rays, &local, &sun, &complete);
    bool forced = m->mode == RD_PROBE_SHADOWS_REBUILD;
    /* the updates the maps would serve: as many as the last revision lasted, or as this one
     * has lasted so far, whichever is more (a scene that stops changing gets its maps once its
     * shadow rays have cost what a rebuild costs) */
    uint64_t serves = m->interval > m->seen_updates ? m->interval : m->seen_updates;
    if (!forced && serves != UINT64_MAX && rays > hits * serves) return RD_VK_OK; /* rays pay */
    rd_vk_result r = RD_VK_OK;
    if (!m->build.pipeline)
        r = rd_pipeline_create(m->vk, &m->build, "shadow map", pc_spv_shadow_map,
                               sizeof pc_spv_shadow_map, sizeof(pc_push), err, errlen);
    if (r == RD_VK_OK && words > m->capacity) {
        /* probe updates are waited for (rd_world_update), so nothing in flight reads the maps */
        rd_buffer_destroy(m->vk, &m->maps);
        m->capacity = 0;
        r = rd_buffer_create(m->vk, &m->maps, words * 4, RD_MEMORY_DEVICE, err, errlen);
        if (r == RD_VK_OK) m->capacity = words;
    }
    if (r != RD_VK_OK) return r;
    rd_cmd_barrier(c);
    vkCmdUpdateBuffer(c->cb, m->maps.buffer, 0, sizeof table, table);
    rd_cmd_barrier(c);
    pc_push push = {.globals = globals, .buf0 = m->maps.address, .buf1 = counters};
    if (local) rd_cmd_dispatch(c, &m->build, &push, (uint32_t)(6 * FACE_TEXELS / PC_WG_1D), 1, n);
    push.params.x = 1;
    if (sun) rd_cmd_dispatch(c, &m->build, &push, (uint32_t)(SUN_TEXELS / PC_WG_1D), 1, n);
    rd_cmd_barrier(c);
    if (timer) rd_timer_mark(c, timer, "shadow maps");
    m->lights = n;
    m->revision = scene->revision;
    m->complete = complete;
    m->builds++;
    *mapped = n;
    *address = m->maps.address;
    return RD_VK_OK;
}
