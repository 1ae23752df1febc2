/* gltf_materials.c: glTF 2.0 metallic-roughness material factors to rd_material (see
 * gltf_import.h; textures are resolved by gltf_textures.c), and the labels messages use. */
#include "renderer/gltf/gltf_import.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void *rd_gltf_alloc(size_t n, size_t size)
{
    void *p = calloc(n ? n : 1, size);
    if (!p) {
        fprintf(stderr, "probecast: out of memory (%zu x %zu bytes)\n", n, size);
        abort();
    }
    return p;
}

bool rd_gltf_to_float(double d, float *out)
{
    if (!isfinite(d) || fabs(d) > (double)FLT_MAX) return false;
    *out = (float)d;
    return true;
}

void rd_gltf_clean(const char *s, size_t len, size_t max, char out[128])
{
    size_t n = len > max ? max - 3 : len;
    memcpy(out, s, n);
    if (len > max) memcpy(out + n, "...", 3), n += 3;
    out[n] = '\0';
    for (size_t i = 0; i < n; i++)
        if ((unsigned char)out[i] < 0x20 || (unsigned char)out[i] >= 0x7f) out[i] = '?';
}

void rd_gltf_label(const char *kind, size_t index, rd_gltf_str name, char out[RD_GLTF_LABEL_MAX])
{
    char clean[128];
    if (name.len == 0) {
        snprintf(out, RD_GLTF_LABEL_MAX, "%s %zu", kind, index);
        return;
    }
    rd_gltf_clean(name.s, name.len, 64, clean);
    snprintf(out, RD_GLTF_LABEL_MAX, "%s %zu '%s'", kind, index, clean);
}

/* As std::max and std::min (a signed zero stays as it is). */
static float max_of(float a, float b)
{
    return a < b ? b : a;
}
static float clamp01(float v)
{
    v = max_of(v, 0.0f);
    return 1.0f < v ? 1.0f : v;
}

static bool is(const rd_gltf_material_factors *f, const char *mode)
{
    return f->alpha_mode_len == strlen(mode) && memcmp(f->alpha_mode, mode, f->alpha_mode_len) == 0;
}

rd_gltf_result rd_gltf_material_colors(rd_scene *s, size_t i, const rd_gltf_material_factors *f,
                                       rd_material *mt, char *err, size_t errlen)
{
    if (f->base_color_count != 4 || f->emissive_count != 3)
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                            "material %zu has a malformed colour factor", i);
    bool ok = true;
    for (int k = 0; k < 4; k++) {
        ok = ok && rd_gltf_to_float(f->base_color[k], &mt->base_color[k]);
        mt->base_color[k] = clamp01(mt->base_color[k]);
    }
    float strength = 1.0f;
    if (f->has_strength &&
        (!f->strength_is_number || !rd_gltf_to_float(f->strength, &strength) || strength < 0.0f))
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                            "material %zu has an invalid emissiveStrength", i);
    for (int k = 0; k < 3; k++) {
        ok = ok && rd_gltf_to_float(f->emissive[k], &mt->emission[k]);
        mt->emission[k] = max_of(mt->emission[k], 0.0f) * strength;
        ok = ok && isfinite(mt->emission[k]);
    }
    ok = ok && rd_gltf_to_float(f->alpha_cutoff, &mt->alpha_cutoff);
    if (!ok)
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                            "material %zu has a factor that is not a finite number", i);
    mt->alpha_cutoff = max_of(mt->alpha_cutoff, 0.0f);
    if (is(f, "OPAQUE")) {
        mt->alpha_mode = RD_ALPHA_OPAQUE;
    } else if (is(f, "MASK")) {
        mt->alpha_mode = RD_ALPHA_MASK;
    } else if (is(f, "BLEND")) {
        mt->alpha_mode = RD_ALPHA_BLEND;
    } else {
        char mode[128];
        rd_gltf_clean(f->alpha_mode, f->alpha_mode_len, 32, mode);
        rd_scene_warn(s, "material %zu has an unknown alphaMode '%s'; OPAQUE is used", i, mode);
        mt->alpha_mode = RD_ALPHA_OPAQUE;
    }
    mt->double_sided = f->double_sided;
    return RD_GLTF_OK;
}

rd_gltf_result rd_gltf_material_pbr(size_t i, const rd_gltf_material_factors *f, rd_material *mt,
                                    char *err, size_t errlen)
{
    bool ok = rd_gltf_to_float(f->metallic, &mt->metallic) &&
              rd_gltf_to_float(f->roughness, &mt->roughness) &&
              rd_gltf_to_float(f->normal_scale, &mt->normal_scale) &&
              rd_gltf_to_float(f->occlusion_strength, &mt->occlusion_strength);
    if (!ok)
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                            "material %zu has a factor that is not a finite number", i);
    mt->metallic = clamp01(mt->metallic);
    mt->roughness = clamp01(mt->roughness);
    mt->occlusion_strength = clamp01(mt->occlusion_strength);
    mt->specular = 1.0f;
    return RD_GLTF_OK;
}

void rd_gltf_material_warnings(rd_scene *s, size_t blend)
{
    if (blend)
        rd_scene_warn(s,
                      "%zu material(s) use alphaMode BLEND; transparency is not supported, they "
                      "are drawn opaque",
                      blend);
}
