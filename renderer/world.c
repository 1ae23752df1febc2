/* world.c: the scene-wide state shared by views, and probe updates. */
#include "renderer/world.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "shaders/brdf_albedo.spv.h"

/* Fills *table with brdf_albedo.comp (blocking; a one-off pipeline). */
static rd_vk_result compute_brdf_albedo(rd_vk *vk, rd_buffer *table, char *err, size_t errlen)
{
    const uint32_t entries = PC_BRDF_ALBEDO_SIDE * PC_BRDF_ALBEDO_SIDE;
    rd_pipeline gen = {0};
    rd_vk_result res =
        rd_buffer_create(vk, table, entries * 2 * sizeof(float), RD_MEMORY_DEVICE, err, errlen);
    if (res == RD_VK_OK)
        res = rd_pipeline_create(vk, &gen, "brdf albedo", pc_spv_brdf_albedo,
                                 sizeof pc_spv_brdf_albedo, sizeof(pc_push), err, errlen);
    rd_cmd cmd;
    if (res == RD_VK_OK) res = rd_cmd_begin(vk, &cmd, err, errlen);
    if (res == RD_VK_OK) {
        pc_push push = {.buf0 = table->address};
        rd_cmd_dispatch(&cmd, &gen, &push, (entries + PC_WG_1D - 1) / PC_WG_1D, 1, 1);
        rd_cmd_barrier(&cmd);
        res = rd_cmd_submit_wait(vk, &cmd, err, errlen);
    }
    rd_pipeline_destroy(vk, &gen);
    return res;
}

rd_vk_result rd_world_create(rd_vk *vk, rd_world *w, char *err, size_t errlen)
{
    memset(w, 0, sizeof *w);
    w->vk = vk;
    rd_vk_result res =
        rd_buffer_create(vk, &w->globals, sizeof(pc_globals), RD_MEMORY_UPLOAD, err, errlen);
    if (res == RD_VK_OK)
        res = rd_buffer_create(vk, &w->counters, sizeof(pc_counters), RD_MEMORY_READBACK, err,
                               errlen);
    if (res == RD_VK_OK) res = rd_timer_create(vk, &w->timer, err, errlen);
    if (res == RD_VK_OK) res = compute_brdf_albedo(vk, &w->brdf_albedo, err, errlen);
    rd_shadow_maps_init(vk, &w->shadow_maps);
    if (res != RD_VK_OK) rd_world_destroy(w);
    const float black[3] = {0, 0, 0};
    if (res == RD_VK_OK) rd_world_set_sky(w, black);
    return res;
}

void rd_world_destroy(rd_world *w)
{
    if (!w->vk) return;
    rd_ddgi_destroy(&w->ddgi);
    w->gi = false;
    rd_shadow_maps_destroy(&w->shadow_maps);
    rd_timer_destroy(w->vk, &w->timer);
    rd_buffer_destroy(w->vk, &w->brdf_albedo);
    rd_buffer_destroy(w->vk, &w->counters);
    rd_buffer_destroy(w->vk, &w->globals);
    rd_buffer_destroy(w->vk, &w->env_texels);
    rd_env_image_free(&w->image);
    w->scene = NULL;
    w->vk = NULL;
}

void rd_world_set_scene(rd_world *w, rd_gpu_scene *scene)
{
    w->scene = scene;
}

void rd_world_set_sky(rd_world *w, const float sky[3])
{
    rd_environment e = {.mode = RD_ENV_UNIFORM, .intensity = 1};
    memcpy(e.sky, sky, sizeof e.sky);
    rd_world_set_environment(w, &e);
}

void rd_world_set_environment(rd_world *w, const rd_environment *e)
{
    w->env = *e;
    w->env.image = w->image.rgb ? &w->image : NULL;
    rd_env_irradiance_sh(&w->env, w->env_sh);
}

/* IEEE half of a finite non-negative float (radiance), rounded to nearest, saturating at the
 * largest half (65504) and flushing below the smallest normal to zero. */
static uint16_t half_of(float f)
{
    if (!(f > 6.1035156e-5f)) return 0; /* also NaN */
    if (f >= 65504.0f) return 0x7bff;
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    uint32_t exp = ((u >> 23) & 0xff) - 127 + 15, mant = u & 0x7fffff;
    uint32_t h = exp << 10 | mant >> 13;
    if ((mant & 0x1fff) > 0x1000 || ((mant & 0x1fff) == 0x1000 && (h & 1))) h++;
    return (uint16_t)(h > 0x7bff ? 0x7bff : h);
}

rd_vk_result rd_world_stage_environment(rd_vk *vk, rd_env_staged *out, rd_env_image *img, char *err,
                                        size_t errlen)
{
    memset(out, 0, sizeof *out);
    rd_env_image im = *img;
    memset(img, 0, sizeof *img);
    if (!im.width || !im.rgb) {
        rd_env_image_free(&im);
        return RD_VK_OK;
    }
    rd_env_image_limit(&im, RD_ENV_IMAGE_MAX_WIDTH);
    size_t n = (size_t)im.width * im.height;
    out->vk = vk;
    out->width = im.width;
    out->height = im.height;
    /* the texels as halves straight into staging memory (written once, in order: it may be
     * write-combined); then the floats shrunk for the SH and freed, and only then the GPU
     * buffer (host memory too on lavapipe): the peak is the floats and the halves */
    rd_buffer upload;
    rd_vk_result res = rd_buffer_create(vk, &upload, n * 8, RD_MEMORY_UPLOAD, err, errlen);
    if (res == RD_VK_OK) {
        uint16_t *texels = upload.mapped;
        for (size_t i = 0; i < n; i++) {
            const float *rgb = im.rgb + i * 3;
            uint16_t t[4] = {half_of(rgb[0]), half_of(rgb[1]), half_of(rgb[2]), 0x3c00 /* 1 */};
            memcpy(texels + i * 4, t, sizeof t);
        }
        rd_env_image_shrunk(&im, RD_WORLD_SH_WIDTH, &out->sh_image);
        rd_env_image_free(&im); /* before the GPU buffer: the peak is the floats and the halves */
        res = rd_buffer_create(vk, &out->texels, n * 8, RD_MEMORY_DEVICE, err, errlen);
        if (res == RD_VK_OK)
            res = rd_staging_adopt(&out->copies, &upload, &out->texels, 0, err, errlen);
        rd_buffer_destroy(vk, &upload); /* when not adopted */
    }
    rd_env_image_free(&im); /* when the staging buffer could not be had */
    if (res != RD_VK_OK) rd_env_staged_destroy(out);
    return res;
}

void rd_env_staged_destroy(rd_env_staged *st)
{
    if (!st->vk) return;
    rd_staging_release(st->vk, &st->copies);
    rd_buffer_destroy(st->vk, &st->texels);
    rd_env_image_free(&st->sh_image);
    memset(st, 0, sizeof *st);
}

rd_vk_result rd_world_set_environment_staged(rd_world *w, rd_env_staged *st, char *err,
                                             size_t errlen)
{
    /* in-flight frames may still sample the image that is replaced here (a rare event) */
    if (w->env_texels.buffer) rd_vk_wait_idle(w->vk);
    rd_buffer_destroy(w->vk, &w->env_texels);
    rd_env_image_free(&w->image);
    w->env_width = w->env_height = 0;
    rd_vk_result res = RD_VK_OK;
    if (st && st->vk) {
        res = rd_staging_submit_wait(w->vk, &st->copies, err, errlen);
        if (res == RD_VK_OK) {
            w->env_texels = st->texels;
            w->image = st->sh_image;
            w->env_width = st->width;
            w->env_height = st->height;
            memset(st, 0, sizeof *st);
        } else {
            rd_env_staged_destroy(st);
        }
    }
    rd_world_set_environment(w, &w->env); /* the image (or its absence) and its irradiance */
    return res;
}

rd_vk_result rd_world_set_environment_image(rd_world *w, rd_env_image *img, char *err,
                                            size_t errlen)
{
    rd_env_staged st;
    rd_vk_result res = rd_world_stage_environment(w->vk, &st, img, err, errlen);
    if (res == RD_VK_OK) return rd_world_set_environment_staged(w, &st, err, errlen);
    rd_world_set_environment_staged(w, NULL, err, errlen); /* as before: the old image goes */
    return res;
}

rd_vk_result rd_world_configure_gi(rd_world *w, const float bmin[3], const float bmax[3],
                                   const rd_ddgi_settings *gi, char *err, size_t errlen)
{
    /* frames of views recorded without waiting (rd_view_record) may still read the field that
     * is freed or reallocated below; reconfiguring is rare, so wait for them */
    if (w->ddgi.vk) vkDeviceWaitIdle(w->vk->device);
    w->gi = false;
    w->changes++;
    if (gi->mode == PC_GI_OFF) {
        rd_ddgi_destroy(&w->ddgi); /* model only what is used: no probe memory when off */
        rd_shadow_maps_release(&w->shadow_maps);
        return RD_VK_OK;
    }
    if (gi->mode != PC_GI_CLASSIC && gi->mode != PC_GI_DDGI) {
        snprintf(err, errlen, "unknown GI mode %u", gi->mode);
        return RD_VK_ERR_UNSUPPORTED;
    }
    rd_vk_result res = RD_VK_OK;
    if (!w->ddgi.vk) res = rd_ddgi_create(w->vk, &w->ddgi, err, errlen);
    if (res == RD_VK_OK) res = rd_ddgi_configure(&w->ddgi, bmin, bmax, gi, err, errlen);
    w->gi = res == RD_VK_OK;
    return res;
}

void rd_world_fill_globals(const rd_world *w, pc_globals *g)
{
    if (w->scene)
        g->scene = w->scene->refs;
    else
        memset(&g->scene, 0, sizeof g->scene);
    memset(&g->ddgi, 0, sizeof g->ddgi);
    if (w->gi) {
        /* the probe volume as the GPU sees it: its origin moved by the floating origin */
        g->ddgi = w->ddgi.vol;
        if (w->scene) {
            g->ddgi.origin.x -= w->scene->origin_shift[0];
            g->ddgi.origin.y -= w->scene->origin_shift[1];
            g->ddgi.origin.z -= w->scene->origin_shift[2];
        }
    }
    rd_env_fill_gpu(&w->env, w->env_sh, &g->env);
    if (g->env.mode == PC_ENV_IMAGE) { /* the texels' size, not that of the floats kept */
        g->env.image = w->env_texels.address;
        g->env.width = w->env_width;
        g->env.height = w->env_height;
    }
    g->brdf_albedo = w->brdf_albedo.address;
}

void rd_world_fill_view_globals(const rd_world *w, pc_globals *g)
{
    rd_world_fill_globals(w, g);
    if (!w->gi || !w->scene) return;
    g->ddgi.control.w = rd_shadow_maps_view_lights(&w->shadow_maps, w->scene);
    g->ddgi.shadow_maps = g->ddgi.control.w ? w->shadow_maps.maps.address : 0;
}

void rd_world_fill_camera(const rd_world *w, const rd_view_camera *camera, unsigned width,
                          unsigned height, pc_globals *g)
{
    rd_view_camera shifted = *camera;
    for (int k = 0; k < 3; k++)
        shifted.eye[k] -= w->scene->origin_shift[k];
    rd_camera_to_view(&shifted, width, height, &g->view);
    g->view.size.x = width;
    g->view.size.y = height;
}

/* The probe hits an update is expected to shade: the probes the last update worked on (all of
 * them before the first), times the rays per probe. */
static uint64_t probe_hits(const rd_ddgi *d)
{
    uint64_t probes = d->census.updated ? d->census.updated : rd_ddgi_probe_count(d);
    return probes * d->vol.counts.w;
}

rd_vk_result rd_world_update(rd_world *w, unsigned n, char *err, size_t errlen)
{
    memset(&w->stats, 0, sizeof w->stats);
    if (!w->gi || n == 0) return RD_VK_OK;
    if (!w->scene) {
        snprintf(err, errlen, "probe update without a scene");
        return RD_VK_ERR_UNSUPPORTED;
    }
    memset(w->counters.mapped, 0, sizeof(pc_counters));
    rd_vk_result res = RD_VK_OK;
    for (unsigned u = 0; u < n && res == RD_VK_OK; u++) {
        /* each update has its own ray rotation in the globals: one submission per update */
        rd_ddgi_begin_update(&w->ddgi);
        rd_cmd cmd;
        res = rd_cmd_begin(w->vk, &cmd, err, errlen);
        if (res != RD_VK_OK) break;
        rd_gpu_scene_record_updates(w->scene, &cmd);
        rd_timer_begin(&cmd, &w->timer);
        /* the lights' distance maps, when they are stale and rebuilding pays (shadow_maps.h) */
        uint32_t mapped;
        VkDeviceAddress maps;
        res = rd_shadow_maps_prepare(&w->shadow_maps, &cmd, &w->timer, w->scene,
                                     probe_hits(&w->ddgi), w->globals.address, w->counters.address,
                                     &mapped, &maps, err, errlen);
        if (res != RD_VK_OK) {
            rd_cmd_abandon(w->vk, &cmd);
            break;
        }
        w->ddgi.vol.control.w = mapped;
        w->ddgi.vol.shadow_maps = maps;
        w->ddgi.sort_hits = !w->shadow_maps.complete; /* some hits trace shadow rays */
        /* the GPU reads the globals when the commands run, after this */
        pc_globals g;
        memset(&g, 0, sizeof g);
        rd_world_fill_globals(w, &g);
        memcpy(w->globals.mapped, &g, sizeof g);
        rd_ddgi_record_update(&w->ddgi, &cmd, &w->timer, w->globals.address, w->counters.address);
        res = rd_cmd_submit_wait(w->vk, &cmd, err, errlen);
        if (res != RD_VK_OK) break;
        rd_ddgi_end_update(&w->ddgi);
        w->updates_total++;
        res = rd_timer_resolve(w->vk, &w->timer, err, errlen);
        if (res == RD_VK_OK) rd_frame_stats_add_timer(&w->stats, &w->timer);
    }
    memcpy(&w->stats.rays, w->counters.mapped, sizeof w->stats.rays);
    return res;
}

rd_vk_result rd_world_converge(rd_world *w, unsigned cap, unsigned *done, char *err, size_t errlen)
{
    *done = 0;
    rd_frame_stats sum;
    memset(&sum, 0, sizeof sum);
    rd_vk_result res = RD_VK_OK;
    while (res == RD_VK_OK && *done < cap && !rd_world_converged(w)) {
        res = rd_world_update(w, 1, err, errlen);
        if (res != RD_VK_OK) break;
        (*done)++;
        rd_frame_stats_add(&sum, &w->stats);
    }
    w->stats = sum;
    return res;
}

bool rd_world_converged(const rd_world *w)
{
    return !w->gi || rd_ddgi_converged(&w->ddgi);
}

void rd_world_wake_box(rd_world *w, const float lo[3], const float hi[3], float age)
{
    w->changes++;
    if (!w->gi) return;
    float a[3], b[3];
    for (int k = 0; k < 3; k++) {
        float shift = w->scene ? w->scene->origin_shift[k] : 0;
        a[k] = lo[k] - shift;
        b[k] = hi[k] - shift;
    }
    rd_ddgi_wake_box(&w->ddgi, a, b, age);
}

void rd_world_wake_all(rd_world *w, float age)
{
    w->changes++;
    if (w->gi) rd_ddgi_wake_all(&w->ddgi, age);
}
