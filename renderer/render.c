#include "render.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "shaders/ddgi_sample.spv.h"
#include "shaders/pathtrace.spv.h"
#include "shaders/primary.spv.h"
#include "shaders/shade.spv.h"
#include "shaders/tonemap.spv.h"

#define DEFAULT_WIDTH 960
#define DEFAULT_HEIGHT 540

rd_vk_result rd_renderer_create(rd_vk *vk, rd_renderer *r, char *err, size_t errlen)
{
    memset(r, 0, sizeof *r);
    r->vk = vk;
    rd_vk_result res = rd_pipeline_create(vk, &r->primary, "primary", pc_spv_primary,
                                          sizeof pc_spv_primary, sizeof(pc_push), err, errlen);
    if (res == RD_VK_OK)
        res = rd_pipeline_create(vk, &r->shade, "shade", pc_spv_shade, sizeof pc_spv_shade,
                                 sizeof(pc_push), err, errlen);
    if (res == RD_VK_OK)
        res = rd_pipeline_create(vk, &r->tonemap, "tonemap", pc_spv_tonemap,
                                 sizeof pc_spv_tonemap, sizeof(pc_push), err, errlen);
    if (res == RD_VK_OK)
        res = rd_pipeline_create(vk, &r->gi_sample, "gi sample", pc_spv_ddgi_sample,
                                 sizeof pc_spv_ddgi_sample, sizeof(pc_push), err, errlen);
    if (res == RD_VK_OK)
        res = rd_pipeline_create(vk, &r->pathtrace, "path trace", pc_spv_pathtrace,
                                 sizeof pc_spv_pathtrace, sizeof(pc_push), err, errlen);
    if (res == RD_VK_OK)
        res = rd_buffer_create(vk, &r->globals, sizeof(pc_globals), RD_MEMORY_UPLOAD, err, errlen);
    if (res == RD_VK_OK)
        res = rd_buffer_create(vk, &r->counters, sizeof(pc_counters), RD_MEMORY_READBACK, err,
                               errlen);
    if (res == RD_VK_OK) res = rd_timer_create(vk, &r->timer, err, errlen);
    if (res != RD_VK_OK) rd_renderer_destroy(r);
    return res;
}

void rd_renderer_destroy(rd_renderer *r)
{
    if (!r->vk) return;
    rd_ddgi_destroy(&r->ddgi);
    r->gi = false;
    rd_pipeline_destroy(r->vk, &r->gi_sample);
    rd_pipeline_destroy(r->vk, &r->pathtrace);
    rd_timer_destroy(r->vk, &r->timer);
    rd_buffer_destroy(r->vk, &r->rgba8);
    rd_buffer_destroy(r->vk, &r->radiance);
    rd_buffer_destroy(r->vk, &r->gbuffer);
    rd_buffer_destroy(r->vk, &r->counters);
    rd_buffer_destroy(r->vk, &r->globals);
    rd_pipeline_destroy(r->vk, &r->tonemap);
    rd_pipeline_destroy(r->vk, &r->shade);
    rd_pipeline_destroy(r->vk, &r->primary);
    r->width = r->height = 0;
}

rd_vk_result rd_renderer_configure_gi(rd_renderer *r, const float bmin[3], const float bmax[3],
                                      const rd_ddgi_settings *gi, char *err, size_t errlen)
{
    r->gi = false;
    if (gi->mode == PC_GI_OFF) {
        rd_ddgi_destroy(&r->ddgi); /* model only what is used: no probe memory when off */
        return RD_VK_OK;
    }
    if (gi->mode != PC_GI_CLASSIC && gi->mode != PC_GI_DDGI) {
        snprintf(err, errlen, "unknown GI mode %u", gi->mode);
        return RD_VK_ERR_UNSUPPORTED;
    }
    rd_vk_result res = RD_VK_OK;
    if (!r->ddgi.vk) res = rd_ddgi_create(r->vk, &r->ddgi, err, errlen);
    if (res == RD_VK_OK) res = rd_ddgi_configure(&r->ddgi, bmin, bmax, gi, err, errlen);
    r->gi = res == RD_VK_OK;
    return res;
}

/* (Re)creates the per-pixel buffers when the resolution changes. */
static rd_vk_result ensure_size(rd_renderer *r, unsigned w, unsigned h, char *err, size_t errlen)
{
    if (w == r->width && h == r->height) return RD_VK_OK;
    /* Work submitted elsewhere (a frame readback copying rgba8) may still read these buffers:
     * resizes are rare, so wait for the device before freeing them. */
    if (r->width || r->height) vkDeviceWaitIdle(r->vk->device);
    r->pathtrace_samples = 0;
    rd_buffer_destroy(r->vk, &r->gbuffer);
    rd_buffer_destroy(r->vk, &r->radiance);
    rd_buffer_destroy(r->vk, &r->rgba8);
    r->width = r->height = 0;
    size_t px = (size_t)w * h;
    rd_vk_result res = rd_buffer_create(r->vk, &r->gbuffer, px * sizeof(pc_gbuffer_texel),
                                        RD_MEMORY_DEVICE, err, errlen);
    if (res == RD_VK_OK)
        res = rd_buffer_create(r->vk, &r->radiance, px * 16, RD_MEMORY_DEVICE, err, errlen);
    if (res == RD_VK_OK)
        res = rd_buffer_create(r->vk, &r->rgba8, px * 4, RD_MEMORY_DEVICE, err, errlen);
    if (res == RD_VK_OK) {
        r->width = w;
        r->height = h;
    }
    return res;
}

/* The probe volume as the GPU sees it: its origin moved by the scene's floating origin. */
static pc_ddgi_volume shifted_volume(const rd_ddgi *d, const rd_gpu_scene *scene)
{
    pc_ddgi_volume v = d->vol;
    v.origin.x -= scene->origin_shift[0];
    v.origin.y -= scene->origin_shift[1];
    v.origin.z -= scene->origin_shift[2];
    return v;
}

/* Copies the timer's sections into the frame statistics (accumulating over submits). */
static rd_vk_result collect_times(rd_renderer *r, char *err, size_t errlen)
{
    rd_vk_result res = rd_timer_resolve(r->vk, &r->timer, err, errlen);
    if (res != RD_VK_OK) return res;
    rd_frame_stats *st = &r->stats;
    st->timed = r->timer.valid;
    for (uint32_t i = 1; i < r->timer.count && i < RD_TIMER_MAX; i++) {
        unsigned k = 0;
        while (k < st->pass_count && strcmp(st->pass_name[k], r->timer.names[i]) != 0) k++;
        if (k == st->pass_count) {
            if (k == RD_TIMER_MAX) continue;
            st->pass_name[k] = r->timer.names[i];
            st->pass_ms[k] = 0;
            st->pass_count++;
        }
        st->pass_ms[k] += r->timer.ms[i];
    }
    return RD_VK_OK;
}

/* Reference path tracing: spp dispatches accumulate into the radiance buffer (w counts
 * samples), submitted in batches so that no single submission runs for long. */
static rd_vk_result render_pathtraced(rd_renderer *r, pc_globals *g, const rd_frame_settings *fs,
                                      char *err, size_t errlen)
{
    memcpy(r->globals.mapped, g, sizeof *g);
    memset(&r->stats, 0, sizeof r->stats);
    uint32_t gx = (r->width + PC_WG_2D_X - 1) / PC_WG_2D_X;
    uint32_t gy = (r->height + PC_WG_2D_Y - 1) / PC_WG_2D_Y;
    unsigned batch = r->vk->is_cpu ? 1 : 16;
    rd_vk_result res = RD_VK_OK;
    unsigned first = fs->pathtrace_first, end = first + fs->pathtrace_spp;
    if (r->frame_index == 0 || first > r->pathtrace_samples) first = 0; /* nothing to continue */
    end = first + fs->pathtrace_spp;
    for (unsigned s = first; res == RD_VK_OK && s < end; s += batch) {
        rd_cmd cmd;
        res = rd_cmd_begin(r->vk, &cmd, err, errlen);
        if (res != RD_VK_OK) return res;
        rd_timer_begin(&cmd, &r->timer);
        for (unsigned k = s; k < s + batch && k < end; k++) {
            pc_push push = {.globals = r->globals.address, .buf0 = r->radiance.address,
                            .buf1 = r->counters.address, .params = {k, fs->max_bounces, 0, 0}};
            rd_cmd_dispatch(&cmd, &r->pathtrace, &push, gx, gy, 1);
            rd_cmd_barrier(&cmd);
        }
        rd_timer_mark(&cmd, &r->timer, "path trace");
        bool last = s + batch >= end;
        if (last) {
            pc_push push = {.globals = r->globals.address, .buf0 = r->radiance.address,
                            .buf1 = r->rgba8.address};
            rd_cmd_dispatch(&cmd, &r->tonemap, &push, gx, gy, 1);
            rd_cmd_barrier(&cmd);
            rd_timer_mark(&cmd, &r->timer, "tonemap");
        }
        res = rd_cmd_submit_wait(r->vk, &cmd, err, errlen);
        if (res == RD_VK_OK) res = collect_times(r, err, errlen);
    }
    memcpy(&r->stats.rays, r->counters.mapped, sizeof r->stats.rays);
    r->frame_index++;
    r->pathtrace_samples = res == RD_VK_OK ? end : 0;
    return res;
}

rd_vk_result rd_renderer_render(rd_renderer *r, const rd_gpu_scene *scene,
                                const rd_view_camera *camera, const rd_frame_settings *fs,
                                char *err, size_t errlen)
{
    unsigned w = fs->width ? fs->width : DEFAULT_WIDTH;
    unsigned h = fs->height ? fs->height : DEFAULT_HEIGHT;
    if (w > 16384 || h > 16384) {
        snprintf(err, errlen, "resolution %ux%u exceeds 16384 in a dimension", w, h);
        return RD_VK_ERR_UNSUPPORTED;
    }
    rd_vk_result res = ensure_size(r, w, h, err, errlen);
    if (res != RD_VK_OK) return res;

    pc_globals g;
    memset(&g, 0, sizeof g);
    g.scene = scene->refs;
    rd_view_camera shifted = *camera;
    for (int k = 0; k < 3; k++) shifted.eye[k] -= scene->origin_shift[k];
    rd_camera_to_view(&shifted, w, h, &g.view);
    g.view.size = (pc_uvec4){w, h, r->frame_index, fs->seed};
    g.view.sky = (pc_vec4){fs->sky[0], fs->sky[1], fs->sky[2], 0};
    g.view.tonemap = (pc_vec4){exp2f(fs->exposure_ev), (float)fs->tonemap, (float)fs->view, 0};
    memset(r->counters.mapped, 0, sizeof(pc_counters));

    if (fs->pathtrace_spp > 0) return render_pathtraced(r, &g, fs, err, errlen);
    r->pathtrace_samples = 0; /* this frame overwrites the accumulation */

    /* All probe updates but the last run on their own; the last is recorded with the frame so
     * that the frame's timings show every pass. */
    unsigned updates = r->gi ? (fs->gi_updates ? fs->gi_updates : 1) : 0;
    rd_cmd cmd;
    for (unsigned u = 0; u + 1 < updates; u++) {
        rd_ddgi_begin_update(&r->ddgi);
        g.ddgi = shifted_volume(&r->ddgi, scene);
        memcpy(r->globals.mapped, &g, sizeof g);
        res = rd_cmd_begin(r->vk, &cmd, err, errlen);
        if (res != RD_VK_OK) return res;
        rd_ddgi_record_update(&r->ddgi, &cmd, NULL, r->globals.address, r->counters.address);
        res = rd_cmd_submit_wait(r->vk, &cmd, err, errlen);
        if (res != RD_VK_OK) return res;
        rd_ddgi_end_update(&r->ddgi);
        memset(r->counters.mapped, 0, sizeof(pc_counters)); /* count the frame's rays only */
    }
    if (r->gi) {
        rd_ddgi_begin_update(&r->ddgi);
        g.ddgi = shifted_volume(&r->ddgi, scene);
    }
    memcpy(r->globals.mapped, &g, sizeof g);

    res = rd_cmd_begin(r->vk, &cmd, err, errlen);
    if (res != RD_VK_OK) return res;
    uint32_t gx = (w + PC_WG_2D_X - 1) / PC_WG_2D_X, gy = (h + PC_WG_2D_Y - 1) / PC_WG_2D_Y;
    rd_timer_begin(&cmd, &r->timer);
    if (r->gi) rd_ddgi_record_update(&r->ddgi, &cmd, &r->timer, r->globals.address, r->counters.address);
    pc_push push = {.globals = r->globals.address, .buf1 = r->counters.address};
    push.buf0 = r->gbuffer.address;
    rd_cmd_dispatch(&cmd, &r->primary, &push, gx, gy, 1);
    rd_cmd_barrier(&cmd);
    rd_timer_mark(&cmd, &r->timer, "primary");
    push.buf2 = r->radiance.address;
    rd_cmd_dispatch(&cmd, &r->shade, &push, gx, gy, 1);
    rd_cmd_barrier(&cmd);
    rd_timer_mark(&cmd, &r->timer, "shade");
    if (r->gi) {
        rd_cmd_dispatch(&cmd, &r->gi_sample, &push, gx, gy, 1);
        rd_cmd_barrier(&cmd);
        rd_timer_mark(&cmd, &r->timer, "gi sample");
    }
    push.buf0 = r->radiance.address;
    push.buf1 = r->rgba8.address;
    rd_cmd_dispatch(&cmd, &r->tonemap, &push, gx, gy, 1);
    rd_cmd_barrier(&cmd);
    rd_timer_mark(&cmd, &r->timer, "tonemap");
    res = rd_cmd_submit_wait(r->vk, &cmd, err, errlen);
    if (res != RD_VK_OK) return res;
    if (r->gi) rd_ddgi_end_update(&r->ddgi);
    r->frame_index++;

    memset(&r->stats, 0, sizeof r->stats);
    memcpy(&r->stats.rays, r->counters.mapped, sizeof r->stats.rays);
    return collect_times(r, err, errlen);
}

rd_vk_result rd_renderer_read_rgba8(rd_renderer *r, uint8_t *out, char *err, size_t errlen)
{
    return rd_buffer_download(r->vk, &r->rgba8, 0, out, (VkDeviceSize)r->width * r->height * 4,
                              err, errlen);
}

rd_vk_result rd_renderer_read_hdr(rd_renderer *r, float *rgb, char *err, size_t errlen)
{
    size_t px = (size_t)r->width * r->height;
    float *rgba = malloc(px * 16);
    if (!rgba) abort();
    rd_vk_result res = rd_buffer_download(r->vk, &r->radiance, 0, rgba, px * 16, err, errlen);
    for (size_t i = 0; res == RD_VK_OK && i < px; i++) {
        float n = rgba[i * 4 + 3] > 1 ? rgba[i * 4 + 3] : 1; /* accumulated samples */
        rgb[i * 3 + 0] = rgba[i * 4 + 0] / n;
        rgb[i * 3 + 1] = rgba[i * 4 + 1] / n;
        rgb[i * 3 + 2] = rgba[i * 4 + 2] / n;
    }
    free(rgba);
    return res;
}
