/* gpu_scene_materials.c: a GPU scene's materials (pc_material, whether any is glossy enough for
 * reflection rays), its texture table and texels, uploaded or staged; and the buffer upload the
 * scene's files share. */
#include <stdio.h>
#include <stdlib.h>

#include "renderer/accel/gpu_scene.h"
#include "renderer/accel/gpu_scene_internal.h"

/* Creates a device buffer holding size bytes of data: written at once without st, staged into
 * st with it (vk_staging.h). */
rd_vk_result rd_gpu_scene_upload_new(rd_vk *vk, rd_staging *st, rd_buffer *b, const void *data,
                                     size_t size, char *err, size_t errlen)
{
    rd_vk_result r = rd_buffer_create(vk, b, size, RD_MEMORY_DEVICE, err, errlen);
    if (r == RD_VK_OK && size > 0) r = rd_upload(vk, st, b, 0, data, size, err, errlen);
    return r;
}

/* Texture index + 1 for the GPU (0 = none or out of range). */
static uint32_t tex_ref(int32_t index, uint32_t texture_count)
{
    return index >= 0 && (uint32_t)index < texture_count ? (uint32_t)index + 1 : 0;
}

static void fill_material(pc_material *g, const rd_material *m, uint32_t texture_count)
{
    memset(g, 0, sizeof *g);
    g->base_color =
        (pc_vec4){m->base_color[0], m->base_color[1], m->base_color[2], m->base_color[3]};
    g->emission = (pc_vec4){m->emission[0], m->emission[1], m->emission[2], 0};
    g->tex.x = tex_ref(m->base_color_texture, texture_count);
    g->tex.y = tex_ref(m->emissive_texture, texture_count);
    g->tex.z = m->alpha_mode == RD_ALPHA_MASK    ? PC_ALPHA_MASK
               : m->alpha_mode == RD_ALPHA_BLEND ? PC_ALPHA_BLEND
                                                 : PC_ALPHA_OPAQUE;
    g->tex.w = m->double_sided ? 1u : 0u;
    g->params = (pc_vec4){m->alpha_cutoff, m->normal_scale, clamp01(m->occlusion_strength),
                          clamp01(m->specular)};
    g->pbr = (pc_vec4){clamp01(m->metallic), clamp01(m->roughness), 0, 0};
    g->tex2.x = tex_ref(m->metallic_roughness_texture, texture_count);
    g->tex2.y = tex_ref(m->normal_texture, texture_count);
    g->tex2.z = tex_ref(m->occlusion_texture, texture_count);
}

/* Whether a surface of material g can trace reflection rays (gbuffer_traces_reflection in
 * shaders/common.glsl): it has a specular part and a roughness that may fall below the cutoff.
 * A metallic-roughness texture only scales the factors down, so the factors bound what the
 * texels can give: metallic 0 stays 0, but any roughness factor may become glossy. */
static bool material_glossy(const pc_material *g)
{
    bool specular = g->pbr.x > 0 || g->params.w > 0;
    return specular && (g->pbr.y < PC_REFLECT_MAX_ROUGHNESS || g->tex2.x != 0);
}

rd_vk_result rd_gpu_scene_upload_materials(rd_vk *vk, rd_staging *st, rd_gpu_scene *gs,
                                           const rd_scene *s, char *err, size_t errlen)
{
    pc_material *mats = xcalloc(s->material_count, sizeof *mats);
    gs->glossy = false;
    for (uint32_t i = 0; i < s->material_count; i++) {
        fill_material(&mats[i], &s->materials[i], s->texture_count);
        gs->glossy |= material_glossy(&mats[i]);
    }
    rd_vk_result r = rd_gpu_scene_upload_new(vk, st, &gs->materials, mats,
                                             sizeof *mats * s->material_count, err, errlen);
    free(mats);
    if (r != RD_VK_OK) return r;

    uint64_t texel_total = 0;
    pc_texture *texs = xcalloc(s->texture_count, sizeof *texs);
    for (uint32_t i = 0; i < s->texture_count; i++) {
        const rd_texture *t = &s->textures[i];
        texs[i].info = (pc_uvec4){(uint32_t)texel_total, t->width, t->height,
                                  t->wrap_s | t->wrap_t << 4 | (t->nearest ? 0x100u : 0u)};
        texel_total += (uint64_t)t->width * t->height;
    }
    if (texel_total > UINT32_MAX) {
        free(texs);
        snprintf(err, errlen, "textures hold %llu texels, more than the 4 Gi texel limit",
                 (unsigned long long)texel_total);
        return RD_VK_ERR_OUT_OF_MEMORY;
    }
    r = rd_gpu_scene_upload_new(vk, st, &gs->textures, texs, sizeof *texs * s->texture_count, err,
                                errlen);
    free(texs);
    if (r != RD_VK_OK) return r;
    r = rd_buffer_create(vk, &gs->texels, texel_total * 4, RD_MEMORY_DEVICE, err, errlen);
    uint64_t offset = 0;
    for (uint32_t i = 0; r == RD_VK_OK && i < s->texture_count; i++) {
        const rd_texture *t = &s->textures[i];
        uint64_t bytes = (uint64_t)t->width * t->height * 4;
        if (bytes) r = rd_upload(vk, st, &gs->texels, offset, t->rgba, bytes, err, errlen);
        offset += bytes;
    }
    return r;
}
