/* builtin.h: builtin scenes by name, the entry of every caller (render, eval, serve's
 * --scene builtin:NAME, the tests): NAME is a procedural scene (procedural.h), "hard:CASE" a case
 * of the stability suite (hard_cases.h), and either may end in +gltf or +metal to get glTF
 * materials instead of its Lambertian ones: the default dielectric (metallic 0, roughness 1,
 * specular 1) or a half-metallic variant (metallic 0.5, roughness 0.5), base colours and
 * emission kept. */
#ifndef RD_BUILTIN_H
#define RD_BUILTIN_H

#include <stdbool.h>
#include <stddef.h>

#include "renderer/scene/scene.h"

/* Builds the scene named by spec into s (initialised here). Returns false with a message for
 * an unknown name, case, family or bad argument. */
bool rd_procedural_build(const char *spec, rd_scene *s, char *err, size_t errlen);

#endif
