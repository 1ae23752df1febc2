/* gltf_lights.c: KHR_lights_punctual lights and perspective cameras (see gltf_import.h). */
#include "renderer/gltf/gltf_import.h"

#include <string.h>

#include "renderer/scene/xform.h"

static bool is(const rd_gltf_light_params *p, const char *type)
{
    return p->type_len == strlen(type) && memcmp(p->type, type, p->type_len) == 0;
}

rd_gltf_result rd_gltf_light(rd_scene *s, size_t index, const rd_gltf_light_params *p, rd_light *l,
                             bool *ignored, char *err, size_t errlen)
{
    *ignored = false;
    if (is(p, "point")) {
        l->type = RD_LIGHT_POINT;
    } else if (is(p, "spot")) {
        l->type = RD_LIGHT_SPOT;
    } else if (is(p, "directional")) {
        l->type = RD_LIGHT_DIRECTIONAL;
    } else {
        char type[128];
        rd_gltf_clean(p->type, p->type_len, 32, type);
        rd_scene_warn(s, "light %zu has an unknown type '%s'; it is ignored", index, type);
        *ignored = true;
        return RD_GLTF_OK;
    }
    bool ok = true;
    l->color[0] = l->color[1] = l->color[2] = 1.0f;
    if (p->color_count) {
        ok = p->color_count == 3;
        for (size_t k = 0; ok && k < 3; k++)
            ok = rd_gltf_to_float(p->color[k], &l->color[k]) && l->color[k] >= 0.0f;
    }
    ok = ok && rd_gltf_to_float(p->intensity, &l->intensity) && l->intensity >= 0.0f;
    ok = ok && rd_gltf_to_float(p->range, &l->range) && l->range >= 0.0f;
    if (!ok)
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                            "light %zu has an invalid color, intensity or range", index);
    if (l->type == RD_LIGHT_DIRECTIONAL) l->range = 0.0f;
    if (l->type == RD_LIGHT_SPOT) {
        if (!rd_gltf_to_float(p->inner_cone, &l->inner_cone) ||
            !rd_gltf_to_float(p->outer_cone, &l->outer_cone) || l->inner_cone < 0.0f ||
            !(l->inner_cone < l->outer_cone) || l->outer_cone > 1.5707964f)
            return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                                "light %zu has invalid spot cone angles (inner %g, outer %g)",
                                index, p->inner_cone, p->outer_cone);
    }
    rd_vec3_set(l->direction, 0.0f, 0.0f, -1.0f);
    return RD_GLTF_OK;
}

rd_gltf_result rd_gltf_perspective(size_t index, double yfov, double znear, double aspect,
                                   rd_camera *c, char *err, size_t errlen)
{
    if (!rd_gltf_to_float(yfov, &c->yfov) || !(c->yfov > 0.0f) || !(c->yfov < 3.14159f) ||
        !rd_gltf_to_float(znear, &c->znear) || !(c->znear > 0.0f) ||
        !rd_gltf_to_float(aspect, &c->aspect) || c->aspect < 0.0f)
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                            "camera %zu has an invalid yfov, znear or aspectRatio", index);
    return RD_GLTF_OK;
}
