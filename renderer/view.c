/* view.c: one camera's frame of a world. */
#include "renderer/view.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "shaders/ddgi_sample.spv.h"
#include "shaders/ddgi_sample.masked.spv.h"
#include "shaders/near_field.spv.h"
#include "shaders/near_field.masked.spv.h"
#include "shaders/pathtrace.spv.h"
#include "shaders/pathtrace.masked.spv.h"
#include "shaders/primary.spv.h"
#include "shaders/primary.masked.spv.h"
#include "shaders/reflect.spv.h"
#include "shaders/reflect.masked.spv.h"
#include "shaders/reflect_filter.spv.h"
#include "shaders/shade.spv.h"
#include "shaders/shade.masked.spv.h"
#include "shaders/tonemap.spv.h"

/* The per-view passes, one line each (the world's passes are in renderer/gi). */
static const rd_pipeline_desc pipelines[] = {
    RD_PIPELINE_DESC_MASKED(rd_view_passes, primary, "primary", pc_spv_primary, sizeof(pc_push)),
    RD_PIPELINE_DESC_MASKED(rd_view_passes, shade, "shade", pc_spv_shade, sizeof(pc_push)),
    RD_PIPELINE_DESC(rd_view_passes, tonemap, "tonemap", pc_spv_tonemap, sizeof(pc_push)),
    RD_PIPELINE_DESC_MASKED(rd_view_passes, gi_sample, "gi sample", pc_spv_ddgi_sample,
                            sizeof(pc_push)),
    RD_PIPELINE_DESC_MASKED(rd_view_passes, pathtrace, "path trace", pc_spv_pathtrace,
                            sizeof(pc_push)),
    RD_PIPELINE_DESC_MASKED(rd_view_passes, reflect, "reflect", pc_spv_reflect, sizeof(pc_push)),
    RD_PIPELINE_DESC(rd_view_passes, reflect_filter, "reflect filter", pc_spv_reflect_filter,
                     sizeof(pc_push)),
    RD_PIPELINE_DESC_MASKED(rd_view_passes, near_field, "near field", pc_spv_near_field,
                            sizeof(pc_push)),
};
#define PIPELINE_COUNT (sizeof pipelines / sizeof pipelines[0])

rd_vk_result rd_view_passes_create(rd_vk *vk, rd_view_passes *p, char *err, size_t errlen)
{
    memset(p, 0, sizeof *p);
    rd_vk_result res = rd_pipelines_create(vk, p, pipelines, PIPELINE_COUNT, err, errlen);
    if (res != RD_VK_OK) rd_view_passes_destroy(vk, p);
    return res;
}

void rd_view_passes_destroy(rd_vk *vk, rd_view_passes *p)
{
    rd_pipelines_destroy(vk, p, pipelines, PIPELINE_COUNT);
}

rd_vk_result rd_view_create(rd_vk *vk, const rd_view_passes *passes, rd_view *v, char *err,
                            size_t errlen)
{
    memset(v, 0, sizeof *v);
    v->vk = vk;
    v->passes = passes;
    rd_vk_result res =
        rd_buffer_create(vk, &v->globals, sizeof(pc_globals), RD_MEMORY_UPLOAD, err, errlen);
    if (res == RD_VK_OK)
        res = rd_buffer_create(vk, &v->counters, sizeof(pc_counters), RD_MEMORY_READBACK, err,
                               errlen);
    if (res == RD_VK_OK)
        res = rd_buffer_create(vk, &v->reflect_ctrl, sizeof(pc_reflect_control), RD_MEMORY_UPLOAD,
                               err, errlen);
    if (res == RD_VK_OK) res = rd_timer_create(vk, &v->timer, err, errlen);
    if (res != RD_VK_OK) rd_view_destroy(v);
    return res;
}

static void free_images(rd_view *v)
{
    rd_buffer_destroy(v->vk, &v->reflect.buffer);
    rd_buffer_destroy(v->vk, &v->near.buffer);
    v->reflect.keyed = v->near.keyed = v->near_on = false;
    rd_buffer_destroy(v->vk, &v->rgba8);
    rd_buffer_destroy(v->vk, &v->jpeg_coefs);
    rd_buffer_destroy(v->vk, &v->i420);
    rd_buffer_destroy(v->vk, &v->radiance);
    rd_buffer_destroy(v->vk, &v->gbuffer);
    v->width = v->height = 0;
    v->pathtrace_samples = 0;
}

void rd_view_destroy(rd_view *v)
{
    if (!v->vk) return;
    /* work submitted elsewhere (a frame readback copying rgba8) may still read the images */
    if (v->width || v->height) vkDeviceWaitIdle(v->vk->device);
    free_images(v);
    rd_timer_destroy(v->vk, &v->timer);
    rd_buffer_destroy(v->vk, &v->reflect_ctrl);
    rd_buffer_destroy(v->vk, &v->counters);
    rd_buffer_destroy(v->vk, &v->globals);
    v->passes = NULL;
    v->vk = NULL;
}

/* (Re)creates the per-pixel buffers when the resolution changes. */
static rd_vk_result ensure_size(rd_view *v, unsigned w, unsigned h, char *err, size_t errlen)
{
    if (w == v->width && h == v->height) return RD_VK_OK;
    /* resizes are rare: wait for any readback of the old images before freeing them */
    if (v->width || v->height) vkDeviceWaitIdle(v->vk->device);
    free_images(v);
    size_t px = (size_t)w * h;
    rd_vk_result res = rd_buffer_create(v->vk, &v->gbuffer, px * sizeof(pc_gbuffer_texel),
                                        RD_MEMORY_DEVICE, err, errlen);
    if (res == RD_VK_OK)
        res = rd_buffer_create(v->vk, &v->radiance, px * 16, RD_MEMORY_DEVICE, err, errlen);
    if (res == RD_VK_OK)
        res = rd_buffer_create(v->vk, &v->rgba8, px * 4, RD_MEMORY_DEVICE, err, errlen);
    if (res != RD_VK_OK) {
        free_images(v);
        return res;
    }
    v->width = w;
    v->height = h;
    return RD_VK_OK;
}

static rd_vk_result collect_times(rd_view *v, char *err, size_t errlen)
{
    rd_vk_result res = rd_timer_resolve(v->vk, &v->timer, err, errlen);
    if (res == RD_VK_OK) rd_frame_stats_add_timer(&v->stats, &v->timer);
    return res;
}

/* Reference path tracing: spp dispatches accumulate into the radiance buffer (w counts
 * samples), submitted in batches so that no single submission runs for long. */
static rd_vk_result render_pathtraced(rd_view *v, rd_gpu_scene *gs, const rd_view_settings *s,
                                      char *err, size_t errlen)
{
    const rd_view_passes *p = v->passes;
    uint32_t gx = (v->width + PC_WG_2D_X - 1) / PC_WG_2D_X;
    uint32_t gy = (v->height + PC_WG_2D_Y - 1) / PC_WG_2D_Y;
    unsigned batch = v->vk->is_cpu ? 1 : 16;
    rd_vk_result res = RD_VK_OK;
    unsigned first = s->pathtrace_first;
    if (v->frame_index == 0 || first > v->pathtrace_samples) first = 0; /* nothing to continue */
    unsigned end = first + s->pathtrace_spp;
    for (unsigned k0 = first; res == RD_VK_OK && k0 < end; k0 += batch) {
        rd_cmd cmd;
        res = rd_cmd_begin(v->vk, &cmd, err, errlen);
        if (res != RD_VK_OK) break;
        rd_gpu_scene_record_updates(gs, &cmd);
        rd_timer_begin(&cmd, &v->timer);
        for (unsigned k = k0; k < k0 + batch && k < end; k++) {
            pc_push push = {.globals = v->globals.address,
                            .buf0 = v->radiance.address,
                            .buf1 = v->counters.address,
                            .params = {k, s->max_bounces, 0, 0}};
            rd_cmd_dispatch(&cmd, &p->pathtrace, &push, gx, gy, 1);
            rd_cmd_barrier(&cmd);
        }
        rd_timer_mark(&cmd, &v->timer, "path trace");
        if (k0 + batch >= end) {
            pc_push push = {.globals = v->globals.address,
                            .buf0 = v->radiance.address,
                            .buf1 = v->rgba8.address};
            rd_cmd_dispatch(&cmd, &p->tonemap, &push, gx, gy, 1);
            rd_cmd_barrier(&cmd);
            rd_timer_mark(&cmd, &v->timer, "tonemap");
        }
        res = rd_cmd_submit_wait(v->vk, &cmd, err, errlen);
        if (res == RD_VK_OK) res = collect_times(v, err, errlen);
    }
    memcpy(&v->stats.rays, v->counters.mapped, sizeof v->stats.rays);
    v->frame_index++;
    v->pathtrace_samples = res == RD_VK_OK ? end : 0;
    return res;
}

/* Sizes the images and writes this frame's globals (the world's part copied, the camera's part
 * filled here). */
static rd_vk_result prepare(rd_view *v, const rd_world *w, const rd_view_camera *camera,
                            const rd_view_settings *s, pc_globals *out, char *err, size_t errlen)
{
    memset(&v->stats, 0, sizeof v->stats);
    if (!w->scene) {
        snprintf(err, errlen, "rendering a world without a scene");
        return RD_VK_ERR_UNSUPPORTED;
    }
    unsigned width = s->width ? s->width : RD_VIEW_DEFAULT_WIDTH;
    unsigned height = s->height ? s->height : RD_VIEW_DEFAULT_HEIGHT;
    if (width > 16384 || height > 16384) {
        snprintf(err, errlen, "resolution %ux%u exceeds 16384 in a dimension", width, height);
        return RD_VK_ERR_UNSUPPORTED;
    }
    if (s->reflections > PC_REFLECT_OFF) {
        snprintf(err, errlen, "unknown reflections mode %u", s->reflections);
        return RD_VK_ERR_UNSUPPORTED;
    }
    if (s->near_field > PC_NEAR_OFF) {
        snprintf(err, errlen, "unknown near-field mode %u", s->near_field);
        return RD_VK_ERR_UNSUPPORTED;
    }
    if (s->shadow_cull > PC_SHADOW_CULL_OFF) {
        snprintf(err, errlen, "unknown shadow cull mode %u", s->shadow_cull);
        return RD_VK_ERR_UNSUPPORTED;
    }
    rd_vk_result res = ensure_size(v, width, height, err, errlen);
    if (res != RD_VK_OK) return res;
    pc_globals g;
    memset(&g, 0, sizeof g);
    rd_world_fill_view_globals(w, &g);
    if (s->shadow_cull == PC_SHADOW_CULL_OFF) g.ddgi.control.w = 0; /* a ray to every light */
    rd_world_fill_camera(w, camera, width, height, &g);
    g.view.size = (pc_uvec4){width, height, v->frame_index, s->seed};
    g.view.tonemap = (pc_vec4){exp2f(s->exposure_ev), (float)s->tonemap, (float)s->view, 0};
    memcpy(v->globals.mapped, &g, sizeof g);
    memset(v->counters.mapped, 0, sizeof(pc_counters));
    if (out) *out = g;
    return RD_VK_OK;
}

/* Opens a history for this frame: its buffer (created zeroed at the view's size when missing)
 * and its epoch, a new one when the key (what the view sees) changed since the last frame that
 * used it. */
static rd_vk_result history_begin(rd_view *v, rd_view_history *h, const rd_world *w,
                                  const pc_globals *g, char *err, size_t errlen)
{
    if (!h->buffer.buffer) {
        VkDeviceSize bytes = (VkDeviceSize)v->width * v->height * 16;
        rd_vk_result res =
            rd_buffer_create(v->vk, &h->buffer, bytes, RD_MEMORY_DEVICE, err, errlen);
        if (res == RD_VK_OK) res = rd_buffer_fill(v->vk, &h->buffer, 0, err, errlen);
        if (res != RD_VK_OK) {
            rd_buffer_destroy(v->vk, &h->buffer);
            return res;
        }
        h->keyed = false;
    }
    rd_view_history_key key;
    memset(&key, 0, sizeof key);
    key.view = g->view;
    key.view.size.z = 0; /* the frame index */
    memset(&key.view.tonemap, 0, sizeof key.view.tonemap);
    key.scene = g->scene;
    key.env = g->env;
    key.world_changes = w->changes;
    key.gi = w->gi;
    key.converged = rd_world_converged(w);
    key.mapped = g->ddgi.control.w;
    if (!h->keyed || memcmp(&key, &h->key, sizeof key) != 0) {
        h->epoch = (h->epoch + 1) & 0xffffffu;
        h->frames = 0;
    }
    h->frames++;
    h->key = key;
    h->keyed = true;
    return RD_VK_OK;
}

/* Whether this frame traces reflections: GI on (the hits need the probe field, and GI off
 * means direct light only), reflections not turned off, a scene with glossy materials, and a
 * view mode that shows them. If so, opens the frame's reflection bookkeeping: the history and
 * the indirect arguments, closed (x = 0) until primary.comp sees a glossy pixel. */
static rd_vk_result reflections_begin(rd_view *v, const rd_world *w, const rd_view_settings *s,
                                      const pc_globals *g, bool *on, char *err, size_t errlen)
{
    *on = w->gi && s->reflections != PC_REFLECT_OFF && s->view != PC_VIEW_IRRADIANCE &&
          w->scene->glossy;
    if (!*on) return RD_VK_OK;
    rd_vk_result res = history_begin(v, &v->reflect, w, g, err, errlen);
    if (res != RD_VK_OK) return res;
    pc_reflect_control ctrl = {.args = {0, (v->height + PC_WG_2D_Y - 1) / PC_WG_2D_Y, 1, 0}};
    memcpy(v->reflect_ctrl.mapped, &ctrl, sizeof ctrl);
    return RD_VK_OK;
}

/* Whether this frame traces near-field rays (GI on, the setting not off) and, if so, opens
 * their history. */
static rd_vk_result near_begin(rd_view *v, const rd_world *w, const rd_view_settings *s,
                               const pc_globals *g, char *err, size_t errlen)
{
    v->near_on = w->gi && s->near_field != PC_NEAR_OFF;
    return v->near_on ? history_begin(v, &v->near, w, g, err, errlen) : RD_VK_OK;
}

bool rd_view_settling(const rd_view *v)
{
    return v->near_on && v->near.frames < PC_NEAR_SETTLE_FRAMES;
}

rd_vk_result rd_view_record(rd_view *v, const rd_world *w, const rd_view_camera *camera,
                            const rd_view_settings *s, rd_cmd *cmd, char *err, size_t errlen)
{
    if (s->pathtrace_spp > 0) {
        snprintf(err, errlen, "path tracing is rendered with rd_view_render");
        return RD_VK_ERR_UNSUPPORTED;
    }
    pc_globals g;
    bool reflect = false;
    rd_vk_result res = prepare(v, w, camera, s, &g, err, errlen);
    if (res == RD_VK_OK) res = reflections_begin(v, w, s, &g, &reflect, err, errlen);
    if (res == RD_VK_OK) res = near_begin(v, w, s, &g, err, errlen);
    if (res != RD_VK_OK) return res;
    v->pathtrace_samples = 0; /* this frame overwrites the accumulation */
    rd_gpu_scene_record_updates(w->scene, cmd);
    const rd_view_passes *p = v->passes;
    uint32_t gx = (v->width + PC_WG_2D_X - 1) / PC_WG_2D_X;
    uint32_t gy = (v->height + PC_WG_2D_Y - 1) / PC_WG_2D_Y;
    rd_timer_begin(cmd, &v->timer);
    pc_push push = {.globals = v->globals.address,
                    .buf0 = v->gbuffer.address,
                    .buf1 = v->counters.address,
                    .buf2 = reflect ? v->reflect_ctrl.address : 0};
    rd_cmd_dispatch(cmd, &p->primary, &push, gx, gy, 1);
    rd_cmd_barrier(cmd);
    rd_timer_mark(cmd, &v->timer, "primary");
    push.buf2 = v->radiance.address;
    rd_cmd_dispatch(cmd, &p->shade, &push, gx, gy, 1);
    rd_cmd_barrier(cmd);
    rd_timer_mark(cmd, &v->timer, "shade");
    /* settled (and the field asleep): the history stays */
    if (v->near_on && (v->near.frames <= PC_NEAR_SETTLE_FRAMES || !v->near.key.converged)) {
        pc_push np = {.globals = v->globals.address,
                      .buf0 = v->gbuffer.address,
                      .buf1 = v->counters.address,
                      .buf2 = v->near.buffer.address,
                      .params = {v->near.epoch, 0, 0, 0}};
        rd_cmd_dispatch(cmd, &p->near_field, &np, gx, gy, 1);
        rd_cmd_barrier(cmd);
        rd_timer_mark(cmd, &v->timer, "near field");
    }
    if (w->gi) {
        pc_push gp = {.globals = v->globals.address,
                      .buf0 = v->gbuffer.address,
                      .buf1 = v->near_on ? v->near.buffer.address : 0,
                      .buf2 = v->radiance.address,
                      .params = {s->reflections != PC_REFLECT_OFF, /* indirect specular */
                                 v->near.epoch, 0, 0}};
        rd_cmd_dispatch(cmd, &p->gi_sample, &gp, gx, gy, 1);
        rd_cmd_barrier(cmd);
        rd_timer_mark(cmd, &v->timer, "gi sample");
    }
    if (reflect) { /* both dispatches are empty when no glossy pixel is in sight */
        const VkDeviceSize args = offsetof(pc_reflect_control, args);
        pc_push rp = {.globals = v->globals.address,
                      .buf0 = v->gbuffer.address,
                      .buf1 = v->counters.address,
                      .buf2 = v->reflect.buffer.address,
                      .params = {v->reflect.epoch, 0, 0, 0}};
        rd_cmd_dispatch_indirect(cmd, &p->reflect, &rp, &v->reflect_ctrl, args);
        rd_cmd_barrier(cmd);
        rd_timer_mark(cmd, &v->timer, "reflect");
        rp.buf1 = v->reflect.buffer.address;
        rp.buf2 = v->radiance.address;
        rd_cmd_dispatch_indirect(cmd, &p->reflect_filter, &rp, &v->reflect_ctrl, args);
        rd_cmd_barrier(cmd);
        rd_timer_mark(cmd, &v->timer, "reflect filter");
    }
    push.buf0 = v->radiance.address;
    push.buf1 = v->rgba8.address;
    rd_cmd_dispatch(cmd, &p->tonemap, &push, gx, gy, 1);
    rd_cmd_barrier(cmd);
    rd_timer_mark(cmd, &v->timer, "tonemap");
    v->frame_index++;
    return RD_VK_OK;
}

rd_vk_result rd_view_collect(rd_view *v, char *err, size_t errlen)
{
    memset(&v->stats, 0, sizeof v->stats);
    memcpy(&v->stats.rays, v->counters.mapped, sizeof v->stats.rays);
    return collect_times(v, err, errlen);
}

rd_vk_result rd_view_render(rd_view *v, const rd_world *w, const rd_view_camera *camera,
                            const rd_view_settings *s, char *err, size_t errlen)
{
    if (s->pathtrace_spp > 0) {
        rd_vk_result res = prepare(v, w, camera, s, NULL, err, errlen);
        return res == RD_VK_OK ? render_pathtraced(v, w->scene, s, err, errlen) : res;
    }
    rd_cmd cmd;
    rd_vk_result res = rd_cmd_begin(v->vk, &cmd, err, errlen);
    if (res != RD_VK_OK) return res;
    res = rd_view_record(v, w, camera, s, &cmd, err, errlen);
    if (res != RD_VK_OK) {
        rd_cmd_abandon(v->vk, &cmd);
        return res;
    }
    res = rd_cmd_submit_wait(v->vk, &cmd, err, errlen);
    if (res != RD_VK_OK) return res;
    return rd_view_collect(v, err, errlen);
}

rd_vk_result rd_view_render_still(rd_view *v, const rd_world *w, const rd_view_camera *camera,
                                  const rd_view_settings *s, char *err, size_t errlen)
{
    rd_vk_result res = rd_view_render(v, w, camera, s, err, errlen);
    for (unsigned k = 0; res == RD_VK_OK && rd_view_settling(v) && k < PC_NEAR_SETTLE_FRAMES; k++)
        res = rd_view_render(v, w, camera, s, err, errlen);
    return res;
}

rd_vk_result rd_view_read_rgba8(rd_view *v, uint8_t *out, char *err, size_t errlen)
{
    return rd_buffer_download(v->vk, &v->rgba8, 0, out, (VkDeviceSize)v->width * v->height * 4, err,
                              errlen);
}

rd_vk_result rd_view_read_hdr(rd_view *v, float *rgb, char *err, size_t errlen)
{
    size_t px = (size_t)v->width * v->height;
    float *rgba = malloc(px * 16);
    if (!rgba) abort();
    rd_vk_result res = rd_buffer_download(v->vk, &v->radiance, 0, rgba, px * 16, err, errlen);
    for (size_t i = 0; res == RD_VK_OK && i < px; i++) {
        float n = rgba[i * 4 + 3] > 1 ? rgba[i * 4 + 3] : 1; /* accumulated samples */
        rgb[i * 3 + 0] = rgba[i * 4 + 0] / n;
        rgb[i * 3 + 1] = rgba[i * 4 + 1] / n;
        rgb[i * 3 + 2] = rgba[i * 4 + 2] / n;
    }
    free(rgba);
    return res;
}
