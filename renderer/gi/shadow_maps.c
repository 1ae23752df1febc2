/* shadow_maps.c: the lights' distance maps for probe-hit shading (see shadow_maps.h). */
#include "renderer/gi/shadow_maps.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "shaders/shadow_map.spv.h"
#include "renderer/scene/xform.h"

#define FACE_TEXELS ((uint64_t)PC_SHADOW_MAP_SIDE * PC_SHADOW_MAP_SIDE)
#define SUN_TEXELS ((uint64_t)PC_SHADOW_MAP_SUN_SIDE * PC_SHADOW_MAP_SUN_SIDE)
/* Memory the maps may take, in 4-byte words (128 MiB: 80 point lights and 20 suns at once);
 * lights past it keep shadow rays. */
#define BUDGET_WORDS (32ull << 20)

void rd_shadow_maps_init(rd_vk *vk, rd_shadow_maps *m)
{
    memset(m, 0, sizeof *m);
    m->vk = vk;
}

void rd_shadow_maps_release(rd_shadow_maps *m)
{
    if (!m->vk) return;
    if (m->maps.buffer) vkDeviceWaitIdle(m->vk->device); /* view frames may read them (rare) */
    rd_buffer_destroy(m->vk, &m->maps);
    m->capacity = 0;
    m->lights = 0;
    memset(m->layout, 0, sizeof m->layout);
    memset(m->shown, 0, sizeof m->shown);
    memset(m->table, 0, sizeof m->table);
}

unsigned rd_shadow_maps_valid(const rd_shadow_maps *m)
{
    unsigned n = 0;
    for (unsigned i = 0; m->maps.buffer && i < PC_SHADOW_MAP_MAX_LIGHTS; i++)
        n += m->table[i] != 0;
    return n;
}

uint32_t rd_shadow_maps_view_lights(const rd_shadow_maps *m, const rd_gpu_scene *scene)
{
    if (!m->maps.buffer || m->geometry != scene->geometry_revision) return 0;
    uint32_t n = 0, lights = scene->refs.counts.y;
    while (n < lights && n < PC_SHADOW_MAP_MAX_LIGHTS && m->table[n] != 0 &&
           m->shown[n] == scene->light_revision[n])
        n++;
    return n;
}

/* Texels (one ray each) of light i's map. */
static uint64_t light_texels(const rd_gpu_scene *scene, uint32_t i)
{
    return scene->placed_lights[i].info.x == PC_LIGHT_DIRECTIONAL ? SUN_TEXELS : 6 * FACE_TEXELS;
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
    uint64_t at = PC_SHADOW_MAP_HEADER_WORDS;
    memset(layout, 0, sizeof(uint32_t) * PC_SHADOW_MAP_MAX_LIGHTS);
    for (uint32_t i = 0; i < n; i++) {
        uint64_t texels = light_texels(scene, i);
        if (at + texels > BUDGET_WORDS) continue;
        layout[i] = (uint32_t)at;
        at += texels;
    }
    return at;
}

/* Grows the rectangle [lo, hi] (in uv of [-1, 1]^2) into texels of a side x side grid, one
 * texel wider on every side (the lookup's filter and rounding), and appends it. */
static void add_rect(rd_shadow_map_rect *out, uint32_t *n, uint32_t light, uint32_t face,
                     uint32_t side, const double lo[2], const double hi[2])
{
    if (lo[0] > 1 || lo[1] > 1 || hi[0] < -1 || hi[1] < -1) return;
    uint32_t x[2], y[2];
    for (int e = 0; e < 2; e++) {
        double u = (e ? hi[0] : lo[0]) * 0.5 + 0.5, v = (e ? hi[1] : lo[1]) * 0.5 + 0.5;
        double fx = floor(u * side) + (e ? 1 : -1), fy = floor(v * side) + (e ? 1 : -1);
        x[e] = (uint32_t)fmin(fmax(fx, 0), side - 1);
        y[e] = (uint32_t)fmin(fmax(fy, 0), side - 1);
    }
    out[(*n)++] = (rd_shadow_map_rect){light, face, x[0], y[0], x[1] - x[0] + 1, y[1] - y[0] + 1};
}

/* The rectangles of light i's map whose rays may cross the boxes: per cube face, the box
 * corners' projections (the whole face when a box straddles the face's plane through the
 * light); for a sun, their projections on its square. Returns how many (at most 6). */
static uint32_t rects_of(const rd_shadow_maps *m, const rd_gpu_scene *scene, uint32_t i,
                         const float boxes[][8], uint32_t nbox, rd_shadow_map_rect *out)
{
    uint32_t n = 0;
    if (light_texels(scene, i) == SUN_TEXELS) {
        /* the square's axes, as shadow_map_sun_frame makes them */
        const pc_vec4 dir = scene->placed_lights[i].direction;
        const float d[3] = {dir.x, dir.y, dir.z};
        const float y[3] = {0, 1, 0}, x[3] = {1, 0, 0};
        float u[3], v[3];
        rd_vec3_cross(u, fabsf(d[1]) < 0.9f ? y : x, d);
        rd_vec3_normalize(u, u, x);
        rd_vec3_cross(v, d, u);
        double lo[2] = {1e30, 1e30}, hi[2] = {-1e30, -1e30};
        for (uint32_t b = 0; b < nbox; b++)
            for (int c = 0; c < 8; c++) {
                double p[3], pu = 0, pv = 0;
                for (int k = 0; k < 3; k++) {
                    p[k] = boxes[b][((c >> k) & 1) ? 4 + k : k] - m->frame[k];
                    pu += p[k] * u[k];
                    pv += p[k] * v[k];
                }
                lo[0] = fmin(lo[0], pu / m->frame[3]), hi[0] = fmax(hi[0], pu / m->frame[3]);
                lo[1] = fmin(lo[1], pv / m->frame[3]), hi[1] = fmax(hi[1], pv / m->frame[3]);
            }
        if (nbox) add_rect(out, &n, i, PC_SHADOW_MAP_SUN_FACE, PC_SHADOW_MAP_SUN_SIDE, lo, hi);
        return n;
    }
    const pc_vec4 pos = scene->placed_lights[i].position_range;
    const float l[3] = {pos.x, pos.y, pos.z};
    for (uint32_t f = 0; f < 6; f++) {
        uint32_t ax = f / 2, bx = (ax + 1) % 3, cx = (ax + 2) % 3;
        double s = (f & 1) ? -1 : 1;
        double lo[2] = {1e30, 1e30}, hi[2] = {-1e30, -1e30};
        bool seen = false;
        for (uint32_t b = 0; b < nbox; b++) {
            /* the box relative to the light; a point of it shows on this face only where its
             * distance along the axis, da, is at least its distance off the axis in either
             * other coordinate, so the box can be cut to da >= the least such distance */
            double blo[3], bhi[3];
            for (int k = 0; k < 3; k++) {
                blo[k] = boxes[b][k] - l[k];
                bhi[k] = boxes[b][4 + k] - l[k];
            }
            double a0 = s > 0 ? blo[ax] : -bhi[ax], a1 = s > 0 ? bhi[ax] : -blo[ax];
            double off_b = blo[bx] > 0 ? blo[bx] : (bhi[bx] < 0 ? -bhi[bx] : 0);
            double off_c = blo[cx] > 0 ? blo[cx] : (bhi[cx] < 0 ? -bhi[cx] : 0);
            double cut = fmax(off_b, off_c);
            a0 = fmax(a0, cut);
            if (a1 <= 0 || a0 > a1) continue; /* never on this face */
            double ulo[2], uhi[2];
            if (a0 <= 1e-9) { /* it holds the light's axis: all of the face */
                ulo[0] = ulo[1] = -1, uhi[0] = uhi[1] = 1;
            } else { /* extremes of d[b] / da and d[c] / da lie at da = a0 or a1 */
                const double ob[2] = {blo[bx], bhi[bx]}, oc[2] = {blo[cx], bhi[cx]};
                ulo[0] = ulo[1] = 1e30, uhi[0] = uhi[1] = -1e30;
                for (int e = 0; e < 2; e++)
                    for (int q = 0; q < 2; q++) {
                        double da = q ? a1 : a0;
                        ulo[0] = fmin(ulo[0], ob[e] / da), uhi[0] = fmax(uhi[0], ob[e] / da);
                        ulo[1] = fmin(ulo[1], oc[e] / da), uhi[1] = fmax(uhi[1], oc[e] / da);
                    }
            }
            for (int k = 0; k < 2; k++)
                lo[k] = fmin(lo[k], ulo[k]), hi[k] = fmax(hi[k], uhi[k]);
            seen = true;
        }
        if (seen) add_rect(out, &n, i, f, PC_SHADOW_MAP_SIDE, lo, hi);
    }
    return n;
}

/* Does the suns' frame sphere still hold the scene's box? */
static bool frame_holds(const rd_shadow_maps *m, const float bounds[6])
{
    for (int c = 0; c < 8; c++) {
        double d2 = 0;
        for (int a = 0; a < 3; a++) {
            double d = bounds[((c >> a) & 1) ? 3 + a : a] - m->frame[a];
            d2 += d * d;
        }
        if (d2 > (double)m->frame[3] * m->frame[3]) return false;
    }
    return true;
}

/* One update's plan: the layout, what each map needs (its order), the moved boxes and the
 * rectangles a partial rebuild re-traces, and the rays it all costs. */
typedef struct plan {
    uint32_t n; /* lights considered: the first PC_SHADOW_MAP_MAX_LIGHTS */
    uint32_t layout[PC_SHADOW_MAP_MAX_LIGHTS];
    uint32_t order[PC_SHADOW_MAP_MAX_LIGHTS];
    float boxes[PC_SHADOW_MAP_BOXES][8];
    uint32_t nbox, nrect;
    uint64_t words, rays;
    bool suns, sun_whole, any;
} plan;

/* Every map of the layout traced whole (a new buffer holds none). */
static void plan_whole(plan *p, const rd_gpu_scene *scene)
{
    p->rays = 0;
    p->nrect = 0;
    for (uint32_t i = 0; i < p->n; i++) {
        p->order[i] = p->layout[i] ? PC_SHADOW_MAP_WHOLE : PC_SHADOW_MAP_KEEP;
        if (p->layout[i]) p->rays += light_texels(scene, i);
    }
    p->sun_whole = p->suns;
}

/* What is stale: every map after a new layout, or after geometry changes that the scene's log
 * does not cover (or that left the suns' frame); else the texels whose rays cross the moved
 * boxes, and the maps of lights that moved. Forgets (m->shown) what no longer holds. */
static void plan_stale(rd_shadow_maps *m, const rd_gpu_scene *scene, plan *p)
{
    p->words = lay_out(scene, p->n, p->layout);
    for (uint32_t i = 0; i < p->n; i++)
        p->suns = p->suns || (p->layout[i] && light_texels(scene, i) == SUN_TEXELS);
    bool moved = m->geometry != scene->geometry_revision;
    bool partial = moved && m->geometry != 0 && m->geometry >= scene->dirty_since &&
                   (!p->suns || frame_holds(m, scene->bounds));
    if (p->n != m->lights || memcmp(p->layout, m->layout, sizeof p->layout) != 0 ||
        m->mode == RD_PROBE_SHADOWS_REBUILD || (moved && !partial)) {
        memcpy(m->layout, p->layout, sizeof p->layout);
        m->lights = p->n;
        memset(m->shown, 0, sizeof m->shown);
    }
    for (uint32_t k = 0; partial && k < scene->dirty_count; k++) {
        const rd_gpu_scene_dirty *d = &scene->dirty[k];
        if (d->revision <= m->geometry || p->nbox == PC_SHADOW_MAP_BOXES) continue;
        float *b = p->boxes[p->nbox++];
        memcpy(b, d->lo, sizeof d->lo);
        memcpy(b + 4, d->hi, sizeof d->hi);
        b[3] = b[7] = 0;
    }
    for (uint32_t i = 0; i < p->n; i++) {
        if (!p->layout[i]) continue;
        if (m->shown[i] != scene->light_revision[i]) {
            p->order[i] = PC_SHADOW_MAP_WHOLE;
            p->sun_whole = p->sun_whole || light_texels(scene, i) == SUN_TEXELS;
        } else if (moved) {
            p->order[i] = PC_SHADOW_MAP_PART;
        }
    }
    /* a sun traced whole gets a new frame, and so do the other suns */
    for (uint32_t i = 0; p->sun_whole && i < p->n; i++)
        if (p->order[i] == PC_SHADOW_MAP_PART && light_texels(scene, i) == SUN_TEXELS)
            p->order[i] = PC_SHADOW_MAP_WHOLE;
    /* a partial rebuild re-traces rectangles around the moved boxes' projections */
    for (uint32_t i = 0; i < p->n; i++) {
        if (p->order[i] == PC_SHADOW_MAP_WHOLE) p->rays += light_texels(scene, i);
        if (p->order[i] == PC_SHADOW_MAP_PART) {
            uint32_t k = rects_of(m, scene, i, p->boxes, p->nbox, m->rects + p->nrect);
            for (uint32_t j = 0; j < k; j++)
                p->rays += (uint64_t)m->rects[p->nrect + j].w * m->rects[p->nrect + j].h;
            p->nrect += k;
        }
        p->any = p->any || p->order[i] != PC_SHADOW_MAP_KEEP;
    }
}

/* Takes a planned build as done: the maps it traces show the scene's revisions, and suns traced
 * whole get a new frame (the scene's bounding sphere, a little wider). Before write_header. */
static void accept_build(rd_shadow_maps *m, const rd_gpu_scene *scene, const plan *p)
{
    for (uint32_t i = 0; i < p->n; i++)
        if (p->order[i] != PC_SHADOW_MAP_KEEP) m->shown[i] = scene->light_revision[i];
    m->geometry = scene->geometry_revision;
    if (!p->sun_whole) return;
    double r2 = 0;
    for (int a = 0; a < 3; a++) {
        double h = 0.5 * ((double)scene->bounds[3 + a] - scene->bounds[a]);
        m->frame[a] = 0.5f * (scene->bounds[a] + scene->bounds[3 + a]);
        r2 += h * h;
    }
    m->frame[3] = (float)fmax(sqrt(r2), 1e-3) * 1.001f;
}

/* Records the build's dispatches into c: whole cubes, whole suns, then the rectangles. */
static void record_build(rd_shadow_maps *m, rd_cmd *c, const rd_gpu_scene *scene, const plan *p,
                         VkDeviceAddress globals, VkDeviceAddress counters)
{
    bool local = false, sun = false;
    for (uint32_t i = 0; i < p->n; i++) {
        if (p->order[i] != PC_SHADOW_MAP_WHOLE) continue; /* partial ones go by rectangle */
        sun = sun || light_texels(scene, i) == SUN_TEXELS;
        local = local || light_texels(scene, i) != SUN_TEXELS;
    }
    pc_push push = {.globals = globals, .buf0 = m->maps.address, .buf1 = counters};
    if (local)
        rd_cmd_dispatch(c, &m->build, &push, (uint32_t)(6 * FACE_TEXELS / PC_WG_1D), 1, p->n);
    push.params.x = PC_SHADOW_MAP_PASS_SUNS;
    if (sun) rd_cmd_dispatch(c, &m->build, &push, (uint32_t)(SUN_TEXELS / PC_WG_1D), 1, p->n);
    for (uint32_t k = 0; k < p->nrect; k++) {
        const rd_shadow_map_rect *g = &m->rects[k];
        push.params = (pc_uvec4){PC_SHADOW_MAP_PASS_RECT, g->light, g->face, g->x0 | g->y0 << 16};
        push.buf2 = g->w | (uint64_t)g->h << 32;
        rd_cmd_dispatch(c, &m->build, &push, (g->w * g->h + PC_WG_1D - 1) / PC_WG_1D, 1, 1);
    }
}

/* Writes the GPU's header when it changed or a build needs its orders: offsets of the valid
 * maps, the build orders, the suns' frame, the boxes. Returns whether every light of the scene
 * has a valid map. The recording comes before the build's dispatches and the shading. */
static bool write_header(rd_shadow_maps *m, rd_cmd *c, const rd_gpu_scene *scene, const plan *p,
                         bool build)
{
    uint32_t header[PC_SHADOW_MAP_HEADER_WORDS] = {0};
    bool all = p->n == scene->refs.counts.y;
    for (uint32_t i = 0; i < p->n; i++) {
        bool valid = p->layout[i] && m->shown[i] == scene->light_revision[i] &&
                     m->geometry == scene->geometry_revision;
        header[i] = valid ? p->layout[i] : 0;
        all = all && valid;
    }
    memcpy(header + PC_SHADOW_MAP_FRAME_WORD, m->frame, sizeof m->frame); /* lookups read it */
    if (build) {
        memcpy(header + PC_SHADOW_MAP_MAX_LIGHTS, p->order, sizeof p->order);
        header[PC_SHADOW_MAP_FRAME_WORD + 4] = p->nbox;
        memcpy(header + PC_SHADOW_MAP_BOX_WORD, p->boxes, sizeof(float) * 8 * p->nbox);
    }
    if (build || memcmp(header, m->table, sizeof m->table) != 0) {
        rd_cmd_barrier(c);
        vkCmdUpdateBuffer(c->cb, m->maps.buffer, 0, sizeof header, header);
        rd_cmd_barrier(c);
        memcpy(m->table, header, sizeof m->table);
    }
    return all;
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
    plan p = {0}; /* 3 KB */
    p.n = scene->refs.counts.y < PC_SHADOW_MAP_MAX_LIGHTS ? scene->refs.counts.y
                                                          : PC_SHADOW_MAP_MAX_LIGHTS;
    if (p.n == 0 || m->mode == RD_PROBE_SHADOWS_RAYS) {
        rd_shadow_maps_release(m);
        return RD_VK_OK;
    }
    track(m, scene->revision);
    plan_stale(m, scene, &p);
    /* the updates the maps would serve: as many as the last revision lasted, or as this one
     * has lasted so far, whichever is more (a scene, new or one that stops changing, gets its
     * maps once its shadow rays have cost what a rebuild costs) */
    uint64_t serves = m->interval > m->seen_updates ? m->interval : m->seen_updates;
    bool build = p.any && (m->mode == RD_PROBE_SHADOWS_REBUILD || p.rays <= hits * serves);
    rd_vk_result r = RD_VK_OK;
    if (build && !m->build.pipeline)
        r = rd_pipeline_create(m->vk, &m->build, "shadow map", pc_spv_shadow_map,
                               sizeof pc_spv_shadow_map, sizeof(pc_push), err, errlen);
    if (r == RD_VK_OK && build && p.words > m->capacity) {
        /* view frames in flight may read the maps (rd_shadow_maps_view_lights); a new buffer
         * holds no map yet */
        if (m->maps.buffer) vkDeviceWaitIdle(m->vk->device);
        rd_buffer_destroy(m->vk, &m->maps);
        m->capacity = 0;
        memset(m->table, 0, sizeof m->table);
        r = rd_buffer_create(m->vk, &m->maps, p.words * 4, RD_MEMORY_DEVICE, err, errlen);
        if (r == RD_VK_OK) m->capacity = p.words;
        plan_whole(&p, scene);
    }
    if (r != RD_VK_OK) return r;
    if (!m->maps.buffer) return RD_VK_OK; /* nothing built yet: shadow rays */
    if (build) accept_build(m, scene, &p);
    m->complete = write_header(m, c, scene, &p, build);
    if (build) {
        record_build(m, c, scene, &p, globals, counters);
        rd_cmd_barrier(c);
        if (timer) rd_timer_mark(c, timer, "shadow maps");
        m->builds++;
    }
    *mapped = p.n;
    *address = m->maps.address;
    return RD_VK_OK;
}
