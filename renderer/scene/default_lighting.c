/* default_lighting.c: the default-lighting rule and the lighting it adds (default_lighting.h). */
#include "renderer/scene/default_lighting.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/scene/xform.h"

#define PI 3.14159265358979323846

/* Rec. 709 luminance of linear RGB. */
static double luminance(double r, double g, double b)
{
    return 0.2126 * r + 0.7152 * g + 0.0722 * b;
}

bool rd_default_lighting_env_lights(const rd_environment *e)
{
    bool sky = e->sky[0] > 0 || e->sky[1] > 0 || e->sky[2] > 0;
    bool ground = e->ground[0] > 0 || e->ground[1] > 0 || e->ground[2] > 0;
    return sky || (e->mode == RD_ENV_GRADIENT && ground) || e->mode == RD_ENV_IMAGE;
}

/* Mean linear colour of an sRGB-encoded texture (the shader decodes emissive textures so). */
static void texture_mean(const rd_texture *t, double mean[3])
{
    size_t n = (size_t)t->width * t->height;
    mean[0] = mean[1] = mean[2] = 0;
    if (!t->rgba || n == 0) return;
    uint64_t *hist = calloc(3 * 256, sizeof *hist); /* per channel: how often each byte value */
    if (!hist) abort();
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            hist[c * 256 + t->rgba[i * 4 + c]]++;
    for (int v = 0; v < 256; v++) {
        double x = v / 255.0;
        double lin = x <= 0.04045 ? x / 12.92 : pow((x + 0.055) / 1.055, 2.4);
        for (int c = 0; c < 3; c++)
            mean[c] += lin * (double)hist[c * 256 + v];
    }
    for (int c = 0; c < 3; c++)
        mean[c] /= (double)n;
    free(hist);
}

/* Emitted power per m^2 of each material: pi x luminance (x2 double sided), 0 when dark. */
static double *material_exitance(const rd_scene *s)
{
    double *m = calloc(s->material_count ? s->material_count : 1, sizeof *m);
    double(*tex)[3] = calloc(s->texture_count ? s->texture_count : 1, sizeof *tex);
    bool *tex_done = calloc(s->texture_count ? s->texture_count : 1, sizeof *tex_done);
    if (!m || !tex || !tex_done) abort();
    for (uint32_t i = 0; i < s->material_count; i++) {
        const rd_material *mat = &s->materials[i];
        double e[3];
        for (int c = 0; c < 3; c++)
            e[c] = mat->emission[c] > 0 && isfinite(mat->emission[c]) ? mat->emission[c] : 0;
        if (e[0] == 0 && e[1] == 0 && e[2] == 0) continue;
        int32_t ti = mat->emissive_texture;
        if (ti >= 0 && (uint32_t)ti < s->texture_count) {
            if (!tex_done[ti]) texture_mean(&s->textures[ti], tex[ti]);
            tex_done[ti] = true;
            for (int c = 0; c < 3; c++)
                e[c] *= tex[ti][c];
        }
        m[i] = PI * luminance(e[0], e[1], e[2]) * (mat->double_sided ? 2 : 1);
    }
    free(tex);
    free(tex_done);
    return m;
}

double rd_default_lighting_emitted_power(const rd_scene *s)
{
    double *exitance = material_exitance(s);
    bool any = false;
    for (uint32_t i = 0; i < s->material_count; i++)
        any = any || exitance[i] > 0;
    double power = 0;
    for (uint32_t i = 0; any && i < s->instance_count; i++) {
        const rd_mesh *mesh = &s->meshes[s->instances[i].mesh];
        const float *world = s->nodes[s->instances[i].node].world;
        for (uint32_t t = 0; t < mesh->tri_count; t++) {
            uint32_t mi = mesh->material[t];
            if (mi >= s->material_count || exitance[mi] <= 0) continue;
            float p[3][3], e1[3], e2[3], n[3];
            for (int v = 0; v < 3; v++)
                rd_mat4_transform_point(world, &mesh->positions[t * 9 + v * 3], p[v]);
            rd_vec3_sub(e1, p[1], p[0]);
            rd_vec3_sub(e2, p[2], p[0]);
            rd_vec3_cross(n, e1, e2);
            double area = 0.5 * rd_vec3_length(n);
            if (isfinite(area)) power += exitance[mi] * area;
        }
    }
    free(exitance);
    return power;
}

double rd_default_lighting_key_power(const rd_scene *s)
{
    double d[3];
    for (int k = 0; k < 3; k++) {
        d[k] = (double)s->bounds_max[k] - s->bounds_min[k];
        if (!(d[k] > 0) || !isfinite(d[k])) d[k] = 0;
    }
    double surface = 2 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0]);
    return RD_DEFAULT_KEY_LUX * surface / 4;
}

void rd_default_lighting_decide(const rd_scene *s, const rd_environment *env,
                                rd_default_lighting_check *out)
{
    memset(out, 0, sizeof *out);
    for (uint32_t i = 0; i < s->light_count; i++) {
        const rd_light *l = &s->lights[i];
        double y = luminance(l->color[0], l->color[1], l->color[2]);
        out->lights += l->intensity > 0 && y > 0 && isfinite(l->intensity * y);
    }
    out->environment = env && rd_default_lighting_env_lights(env);
    out->emitted_w = rd_default_lighting_emitted_power(s);
    out->key_w = rd_default_lighting_key_power(s);
    out->threshold_w = out->key_w * RD_DEFAULT_LIGHTING_EMITTER_SHARE;
    bool emitters = out->emitted_w > 0 && out->emitted_w >= out->threshold_w;
    out->needed = out->lights == 0 && !out->environment && !emitters;
}

void rd_default_lighting_key(const rd_view_camera *cam, rd_light *out)
{
    const float up[3] = {0, 1, 0}, fallback[3] = {1, 0, 0}, down[3] = {0, -1, 0};
    float right[3], d[3];
    rd_vec3_cross(right, cam->forward, up);
    rd_vec3_normalize(right, right, fallback);
    for (int i = 0; i < 3; i++)
        d[i] = cam->forward[i] - 0.9f * up[i] + 0.5f * right[i];
    memset(out, 0, sizeof *out);
    out->name = (char *)"default key light";
    out->type = RD_LIGHT_DIRECTIONAL;
    rd_vec3_set(out->color, 1, 1, 1);
    out->intensity = RD_DEFAULT_KEY_LUX;
    out->outer_cone = (float)(PI / 4);
    out->node = -1;
    rd_vec3_normalize(out->direction, d, down);
}

void rd_default_lighting_environment(rd_environment *out)
{
    memset(out, 0, sizeof *out);
    out->mode = RD_ENV_UNIFORM;
    rd_vec3_set(out->sky, RD_DEFAULT_SKY_R, RD_DEFAULT_SKY_G, RD_DEFAULT_SKY_B);
    out->intensity = 1;
}

bool rd_default_lighting_apply(rd_scene *s, const rd_view_camera *cam, rd_environment *env,
                               rd_default_lighting_check *out)
{
    rd_default_lighting_check c;
    rd_default_lighting_decide(s, env, &c);
    if (out) *out = c;
    if (!c.needed) return false;
    rd_light key;
    rd_default_lighting_key(cam, &key);
    rd_scene_add_light(s, &key);
    rd_default_lighting_environment(env);
    return true;
}

void rd_default_lighting_describe(const rd_default_lighting_check *c, char *buf, size_t len)
{
    if (c->needed)
        snprintf(buf, len, "no lights, no environment, emitters too weak: %.3g W vs %.3g W",
                 c->emitted_w, c->threshold_w);
    else if (c->lights)
        snprintf(buf, len, "the scene has %u light%s", c->lights, c->lights == 1 ? "" : "s");
    else if (c->environment)
        snprintf(buf, len, "the environment lights the scene");
    else
        snprintf(buf, len, "the emitters light the scene: %.3g W vs %.3g W", c->emitted_w,
                 c->threshold_w);
}
