/* builtin.c: a builtin scene by its spec (builtin.h): "hard:" cases, the procedural scenes,
 * and the material families every one of them can be asked in. */
#include "renderer/builtin/builtin.h"

#include <stdio.h>
#include <string.h>

#include "renderer/builtin/hard_cases.h"
#include "renderer/builtin/procedural.h"

/* The material families a builtin scene can be asked in (NAME+FAMILY). Builtins are written
 * Lambertian (specular 0); uploads are glTF metallic-roughness with the dielectric lobe of
 * Appendix B (specular 1): "gltf" is the glTF default dielectric at roughness 1 (what a plain
 * uploaded material is), "metal" a half-metallic, mid-rough variant that has both lobes and
 * reflection rays (roughness 0.5 < PC_REFLECT_MAX_ROUGHNESS). Base colour and emission stay. */
static const struct {
    const char *name;
    float metallic, roughness, specular;
} families[] = {{"gltf", 0.0f, 1.0f, 1.0f}, {"metal", 0.5f, 0.5f, 1.0f}};

static void set_family(rd_scene *s, int family)
{
    for (uint32_t m = 0; m < s->material_count; m++) {
        s->materials[m].metallic = families[family].metallic;
        s->materials[m].roughness = families[family].roughness;
        s->materials[m].specular = families[family].specular;
    }
}

/* Splits "NAME+FAMILY": the family's index (-1 without a suffix) and NAME's length; false for an
 * unknown family. */
static bool split_family(const char *name, size_t *len, int *family, char *err, size_t errlen)
{
    const char *plus = strrchr(name, '+');
    *family = -1;
    *len = strlen(name);
    if (!plus) return true;
    for (int f = 0; f < (int)(sizeof families / sizeof families[0]); f++)
        if (strcmp(plus + 1, families[f].name) == 0) {
            *family = f;
            *len = (size_t)(plus - name);
            return true;
        }
    snprintf(err, errlen, "unknown material family '+%s' (known: +gltf, +metal)", plus + 1);
    return false;
}

bool rd_procedural_build(const char *spec, rd_scene *s, char *err, size_t errlen)
{
    size_t len;
    int family;
    if (!split_family(spec, &len, &family, err, errlen)) return false;
    char name[256];
    if (len >= sizeof name) {
        snprintf(err, errlen, "builtin scene name too long");
        return false;
    }
    memcpy(name, spec, len);
    name[len] = 0;
    bool ok = strncmp(name, "hard:", 5) == 0 ? rd_hard_case_build(name + 5, s, err, errlen)
                                             : rd_procedural_scene(name, s, err, errlen);
    if (!ok) return false;
    if (family >= 0) set_family(s, family);
    return true;
}

