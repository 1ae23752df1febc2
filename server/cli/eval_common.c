/* eval_common.c: what the static suite (cmd_eval.c) and the dynamic cases (eval_dynamic.c)
 * share: the cached path-traced references and the default lighting of a case (see
 * eval_internal.h). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/scene/default_lighting.h"
#include "server/cli/eval_internal.h"
#include "server/cli/image_io.h"

/* FNV-1a over the bytes that decide a reference image. */
static uint64_t fnv(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; i++)
        h = (h ^ p[i]) * 0x100000001b3ull;
    return h;
}

static uint64_t scene_hash(const rd_scene *s, const eval_args *a, unsigned seed)
{
    uint64_t h = 0xcbf29ce484222325ull;
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        h = fnv(h, s->meshes[m].positions, sizeof(float) * 9 * s->meshes[m].tri_count);
        h = fnv(h, s->meshes[m].material, sizeof(uint32_t) * s->meshes[m].tri_count);
    }
    for (uint32_t i = 0; i < s->node_count; i++)
        h = fnv(h, s->nodes[i].world, sizeof(float) * 16);
    for (uint32_t i = 0; i < s->material_count; i++) {
        const rd_material *m = &s->materials[i];
        h = fnv(h, m->base_color, sizeof m->base_color);
        h = fnv(h, m->emission, sizeof m->emission);
        const float f[5] = {m->metallic, m->roughness, m->specular, m->normal_scale,
                            m->occlusion_strength};
        const int32_t t[7] = {m->base_color_texture, m->emissive_texture,
                              m->metallic_roughness_texture, m->normal_texture,
                              m->occlusion_texture, (int32_t)m->alpha_mode, m->double_sided};
        h = fnv(h, f, sizeof f);
        h = fnv(h, t, sizeof t);
        h = fnv(h, &m->alpha_cutoff, sizeof m->alpha_cutoff);
    }
    for (uint32_t i = 0; i < s->texture_count; i++)
        h = fnv(h, s->textures[i].rgba, (size_t)s->textures[i].width * s->textures[i].height * 4);
    for (uint32_t i = 0; i < s->light_count; i++) {
        const rd_light *l = &s->lights[i];
        h = fnv(h, l->position, sizeof l->position);
        h = fnv(h, l->direction, sizeof l->direction);
        h = fnv(h, l->color, sizeof l->color);
        h = fnv(h, &l->intensity, sizeof l->intensity);
        h = fnv(h, &l->type, sizeof l->type);
    }
    unsigned key[4] = {a->width, a->height, a->ref_spp, seed};
    h = fnv(h, key, sizeof key);
    return fnv(h, PROBECAST_VERSION, strlen(PROBECAST_VERSION));
}

float *eval_reference(eval_ctx *c, const char *name, rd_scene *s, rd_gpu_scene *gs,
                      const rd_view_camera *cam, unsigned seed, double *ms)
{
    const eval_args *a = c->a;
    char path[1024];
    snprintf(path, sizeof path, "%s/%s-%016llx.pfm", a->cache_dir, name,
             (unsigned long long)scene_hash(s, a, seed));
    float *rgb = NULL;
    unsigned w, h;
    *ms = 0;
    if (rd_image_read_pfm(path, &rgb, &w, &h, c->err, sizeof c->err) == RD_IMAGE_OK &&
        w == a->width && h == a->height)
        return rgb;
    free(rgb);
    rd_frame_settings fs = {
        .width = a->width, .height = a->height, .pathtrace_spp = a->ref_spp, .seed = seed};
    fs.env = &c->env;
    rd_ddgi_settings off = {0};
    if (rd_renderer_configure_gi(&c->r, s->bounds_min, s->bounds_max, &off, c->err,
                                 sizeof c->err) != RD_VK_OK ||
        rd_renderer_render(&c->r, gs, cam, &fs, c->err, sizeof c->err) != RD_VK_OK)
        return NULL;
    *ms = rd_frame_stats_total_ms(&c->r.stats);
    rgb = malloc(sizeof(float) * 3 * a->width * a->height);
    if (!rgb) abort();
    if (rd_renderer_read_hdr(&c->r, rgb, c->err, sizeof c->err) != RD_VK_OK) {
        free(rgb);
        return NULL;
    }
    if (rd_image_write_pfm(path, rgb, a->width, a->height, c->err, sizeof c->err) != RD_IMAGE_OK)
        fprintf(stderr, "probecast eval: warning: cannot cache the reference: %s\n", c->err);
    return rgb;
}

void eval_default_lighting(eval_ctx *c, const char *name, rd_scene *s, const rd_view_camera *cam)
{
    c->env = (rd_environment){.mode = RD_ENV_UNIFORM, .intensity = 1};
    rd_default_lighting_check check;
    if (c->a->no_default_lighting || !rd_default_lighting_apply(s, cam, &c->env, &check)) return;
    char why[160];
    rd_default_lighting_describe(&check, why, sizeof why);
    fprintf(stderr, "probecast eval: %s: default lighting added (%s)\n", name, why);
}

