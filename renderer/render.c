/* render.c: one world and one view, advanced and rendered together. */
#include "renderer/render.h"

#include <string.h>

rd_vk_result rd_renderer_create(rd_vk *vk, rd_renderer *r, char *err, size_t errlen)
{
    memset(r, 0, sizeof *r);
    r->vk = vk;
    rd_vk_result res = rd_view_passes_create(vk, &r->passes, err, errlen);
    if (res == RD_VK_OK) res = rd_world_create(vk, &r->world, err, errlen);
    if (res == RD_VK_OK) res = rd_view_create(vk, &r->passes, &r->view, err, errlen);
    if (res != RD_VK_OK) rd_renderer_destroy(r);
    return res;
}

void rd_renderer_destroy(rd_renderer *r)
{
    if (!r->vk) return;
    rd_view_destroy(&r->view);
    rd_world_destroy(&r->world);
    rd_view_passes_destroy(r->vk, &r->passes);
    r->vk = NULL;
}

rd_vk_result rd_renderer_configure_gi(rd_renderer *r, const float bmin[3], const float bmax[3],
                                      const rd_ddgi_settings *gi, char *err, size_t errlen)
{
    return rd_world_configure_gi(&r->world, bmin, bmax, gi, err, errlen);
}

rd_vk_result rd_renderer_render(rd_renderer *r, rd_gpu_scene *scene, const rd_view_camera *camera,
                                const rd_frame_settings *fs, char *err, size_t errlen)
{
    memset(&r->stats, 0, sizeof r->stats);
    rd_world_set_scene(&r->world, scene);
    if (fs->env)
        rd_world_set_environment(&r->world, fs->env);
    else
        rd_world_set_sky(&r->world, fs->sky);
    unsigned updates = 0;
    if (r->world.gi && fs->pathtrace_spp == 0) updates = fs->gi_updates ? fs->gi_updates : 1;
    rd_vk_result res = rd_world_update(&r->world, updates, err, errlen);
    if (res != RD_VK_OK) return res;
    rd_view_settings vs = {
        .width = fs->width,
        .height = fs->height,
        .exposure_ev = fs->exposure_ev,
        .tonemap = fs->tonemap,
        .seed = fs->seed,
        .view = fs->view,
        .pathtrace_spp = fs->pathtrace_spp,
        .max_bounces = fs->max_bounces,
        .pathtrace_first = fs->pathtrace_first,
        .reflections = fs->reflections,
        .near_field = fs->near_field,
        .shadow_cull = fs->shadow_cull,
    };
    res = rd_view_render_still(&r->view, &r->world, camera, &vs, err, errlen);
    rd_frame_stats_add(&r->stats, &r->world.stats);
    rd_frame_stats_add(&r->stats, &r->view.stats);
    return res;
}

rd_vk_result rd_renderer_read_rgba8(rd_renderer *r, uint8_t *out, char *err, size_t errlen)
{
    return rd_view_read_rgba8(&r->view, out, err, errlen);
}

rd_vk_result rd_renderer_read_hdr(rd_renderer *r, float *rgb, char *err, size_t errlen)
{
    return rd_view_read_hdr(&r->view, rgb, err, errlen);
}
