/* shadow_maps.c: the lights' distance maps for probe-hit shading (see shadow_maps.h). */
#include "shadow_maps.h"

#include <stdint.h>
#include <string.h>

#include "shaders/shadow_map.spv.h"

#define FACE_TEXELS ((uint64_t)PC_SHADOW_MAP_SIDE * PC_SHADOW_MAP_SIDE)
#define SUN_TEXELS ((uint64_t)PC_SHADOW_MAP_SUN_SIDE * PC_SHADOW_MAP_SUN_SIDE)
/* The tables before the maps: offsets, then build flags (shaders/shadow_map.glsl). */
#define TABLE_WORDS (2u * PC_SHADOW_MAP_MAX_LIGHTS)
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
    memset(m->layout, 0, sizeof m->layout);
    memset(m->shown, 0, sizeof m->shown);
    memset(m->table, 0, sizeof m->table);
}

/* Texels (one ray each) of light i's map. */
static uint64_t light_texels(const rd_gpu_scene *scene, uint32_t i)
{
    bool directional = (scene->directional[i / 64] >> (i % 64)) & 1u;
    return directional ? SUN_TEXELS : 6 * FACE_TEXELS;
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
 * past the memory budget get none. Returns the words the buffer needs. */
static uint64_t lay_out(const rd_gpu_scene *scene, uint32_t n, uint32_t layout[])
{
    uint64_t at = TABLE_WORDS;
    memset(layout, 0, sizeof(uint32_t) * PC_SHADOW_MAP_MAX_LIGHTS);
    for (uint32_t i = 0; i < n; i++) {
        uint64_t texels = light_texels(scene, i);
        if (at + texels > BUDGET_WORDS) continue;
        layout[i] = (uint32_t)at;
        at += texels;
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
    m->complete = false;
    uint32_t n = scene->refs.counts.y;
    if (n > PC_SHADOW_MAP_MAX_LIGHTS) n = PC_SHADOW_MAP_MAX_LIGHTS;
    if (n == 0 || m->mode == RD_PROBE_SHADOWS_RAYS) {
        rd_shadow_maps_release(m);
        return RD_VK_OK;
    }
    track(m, scene->revision);
    /* what is stale: everything after a new layout or new geometry; else the moved lights */
    uint32_t layout[PC_SHADOW_MAP_MAX_LIGHTS];
    uint64_t words = lay_out(scene, n, layout);
    if (n != m->lights || memcmp(layout, m->layout, sizeof layout) != 0 ||
        m->geometry != scene->geometry_revision || m->mode == RD_PROBE_SHADOWS_REBUILD) {
        memcpy(m->layout, layout, sizeof layout);
        m->lights = n;
        memset(m->shown, 0, sizeof m->shown);
    }
    uint32_t flags[PC_SHADOW_MAP_MAX_LIGHTS] = {0};
    uint64_t rays = 0, stale = 0;
    bool local = false, sun = false;
    for (uint32_t i = 0; i < n; i++) {
        if (!layout[i] || m->shown[i] == scene->light_revision[i]) continue;
        flags[i] = 1;
        stale++;
        rays += light_texels(scene, i);
        if (light_texels(scene, i) == SUN_TEXELS)
            sun = true;
        else
            local = true;
    }
    bool forced = m->mode == RD_PROBE_SHADOWS_REBUILD;
    /* the updates the maps would serve: as many as the last revision lasted, or as this one
     * has lasted so far, whichever is more (a scene that stops changing gets its maps once its
     * shadow rays have cost what a rebuild costs) */
    uint64_t serves = m->interval > m->seen_updates ? m->interval : m->seen_updates;
    bool build = stale && (forced || serves == UINT64_MAX || rays <= hits * serves);
    rd_vk_result r = RD_VK_OK;
    if (build && !m->build.pipeline)
        r = rd_pipeline_create(m->vk, &m->build, "shadow map", pc_spv_shadow_map,
                               sizeof pc_spv_shadow_map, sizeof(pc_push), err, errlen);
    if (r == RD_VK_OK && build && words > m->capacity) {
        /* probe updates are waited for (rd_world_update), so nothing in flight reads the maps;
         * a new buffer holds no map yet */
        rd_buffer_destroy(m->vk, &m->maps);
        m->capacity = 0;
        memset(m->table, 0, sizeof m->table);
        r = rd_buffer_create(m->vk, &m->maps, words * 4, RD_MEMORY_DEVICE, err, errlen);
        if (r == RD_VK_OK) m->capacity = words;
        for (uint32_t i = 0; r == RD_VK_OK && i < n; i++)
            if (layout[i] && !flags[i]) { /* nothing of it survived */
                flags[i] = 1;
                rays += light_texels(scene, i);
                if (light_texels(scene, i) == SUN_TEXELS)
                    sun = true;
                else
                    local = true;
            }
    }
    if (r != RD_VK_OK) return r;
    if (!m->maps.buffer) return RD_VK_OK; /* nothing built yet: shadow rays */
    if (build) {
        for (uint32_t i = 0; i < n; i++)
            if (flags[i]) m->shown[i] = scene->light_revision[i];
        m->geometry = scene->geometry_revision;
    }
    /* the GPU's table: offsets of the valid maps; then the lights to build */
    uint32_t table[PC_SHADOW_MAP_MAX_LIGHTS] = {0};
    bool all = n == scene->refs.counts.y;
    for (uint32_t i = 0; i < n; i++) {
        bool valid = layout[i] && m->shown[i] == scene->light_revision[i];
        table[i] = valid ? layout[i] : 0;
        all = all && valid;
    }
    if (memcmp(table, m->table, sizeof table) != 0 || build) {
        rd_cmd_barrier(c);
        vkCmdUpdateBuffer(c->cb, m->maps.buffer, 0, sizeof table, table);
        if (build) vkCmdUpdateBuffer(c->cb, m->maps.buffer, sizeof table, sizeof flags, flags);
        rd_cmd_barrier(c);
        memcpy(m->table, table, sizeof table);
    }
    if (build) {
        pc_push push = {.globals = globals, .buf0 = m->maps.address, .buf1 = counters};
        if (local)
            rd_cmd_dispatch(c, &m->build, &push, (uint32_t)(6 * FACE_TEXELS / PC_WG_1D), 1, n);
        push.params.x = 1;
        if (sun) rd_cmd_dispatch(c, &m->build, &push, (uint32_t)(SUN_TEXELS / PC_WG_1D), 1, n);
        rd_cmd_barrier(c);
        if (timer) rd_timer_mark(c, timer, "shadow maps");
        m->builds++;
    }
    m->complete = all;
    *mapped = n;
    *address = m->maps.address;
    return RD_VK_OK;
}
