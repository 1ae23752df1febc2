/* default_lighting.h: what a scene that brings no lighting of its own is lit by, and when
 * (issue 29). `probecast render`, `probecast eval` and the daemon all decide here, so that they
 * agree; the daemon reports the result and lets the user's first light or environment replace it.
 *
 * The rule: a scene gets default lighting unless it has a punctual light that emits, an
 * environment that is not black, or emitters powerful enough to light it: their power (the sum
 * over emissive triangles of pi x area x emitted luminance, twice for double-sided materials) at
 * least RD_DEFAULT_LIGHTING_EMITTER_SHARE of the power the key light delivers onto the scene's
 * bounds. The presence of emission is not enough: a model with small glowing details (a 1 cm LED,
 * DamagedHelmet's emissive panels) would otherwise render black.
 *
 * The lighting is the product viewer's (the Khronos glTF Sample Viewer and model-viewer light
 * every model with a neutral environment): a soft uniform sky plus a directional key light from
 * above, behind and left of the camera. Plain CPU code.
 */
#ifndef RD_DEFAULT_LIGHTING_H
#define RD_DEFAULT_LIGHTING_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "renderer/env/environment.h"
#include "renderer/scene/camera.h"
#include "renderer/scene/scene.h"

/* The default environment's radiance and the key light's illuminance (renderer units: a white
 * diffuse surface facing the light reflects intensity / pi). The daemon's values since it first
 * lit scenes by default, kept so that those scenes look as they did. */
#define RD_DEFAULT_SKY_R 0.20f
#define RD_DEFAULT_SKY_G 0.22f
#define RD_DEFAULT_SKY_B 0.26f
#define RD_DEFAULT_KEY_LUX 2.5f

/* Emitters light the scene when their power reaches this share of the key light's power onto
 * the bounds. A quarter is two stops, the usual key-to-fill ratio of studio lighting: emitters
 * weaker than a fill light do not light a scene. On screen (ACES at EV 0) a diffuse surface of
 * albedo 0.8 facing the key light shows at 217/255; with a quarter of that irradiance at 132/255
 * (lit), a tenth 72/255, a hundredth 7/255 (black). The emitted power is an upper bound of what
 * reaches the scene (a product's emitters shine mostly away from it), so the rule leans toward
 * adding light. Emitter-to-key power ratios (test_default_lighting): a 1 cm LED of 50 nits on a 1 m
 * model 0.004; the builtin Cornell box's ceiling lamp alone 0.37, a 1 m lamp in that ceiling 1.5;
 * the 1 cm, 1e5-nit tiny-emitter case 2.1; the emissive panel 3.0; the furnace 5.0.
 * DamagedHelmet is not in the repository: a rough estimate (a few per cent of its emissive map
 * lit, over some 8 m^2 of surface) puts its glowing panels at 0.05 to 0.2. */
#define RD_DEFAULT_LIGHTING_EMITTER_SHARE 0.25

/* What the rule saw, and its verdict. */
typedef struct rd_default_lighting_check {
    bool needed;        /* the scene gets default lighting */
    uint32_t lights;    /* punctual lights that emit (intensity and colour above zero) */
    bool environment;   /* the environment lights the scene (rd_default_lighting_env_lights) */
    double emitted_w;   /* the emitters' power (W: renderer radiance x m^2 x sr) */
    double key_w;       /* the key light's power onto the scene's bounds */
    double threshold_w; /* key_w * RD_DEFAULT_LIGHTING_EMITTER_SHARE */
} rd_default_lighting_check;

/* Whether an environment lights a scene: an image (the mode is enough: the daemon passes it
 * without the image), or a sky (uniform) or sky or ground (gradient) that is not black. */
bool rd_default_lighting_env_lights(const rd_environment *e);
/* The power of the scene's emissive triangles (world space, as rd_scene_update placed them):
 * sum of pi x area x luminance of max(emission, 0) times the emissive texture's mean colour,
 * doubled for double-sided materials. The texture's mean assumes the UVs cover it evenly. */
double rd_default_lighting_emitted_power(const rd_scene *s);
/* The power the key light delivers onto the scene's bounding box, averaged over directions:
 * RD_DEFAULT_KEY_LUX x the box's mean projected area, a quarter of its surface (Cauchy). */
double rd_default_lighting_key_power(const rd_scene *s);
/* Applies the rule to s (world matrices and bounds up to date) under environment env (NULL:
 * none). */
void rd_default_lighting_decide(const rd_scene *s, const rd_environment *env,
                                rd_default_lighting_check *out);

/* The key light for a scene seen from cam: directional, RD_DEFAULT_KEY_LUX, white, shining the
 * way the camera looks from above, behind and left of it (a photographer's 45-degree key), so
 * that the side the camera sees is lit. out->name is a static string (rd_scene_add_light copies
 * it); node -1 (placed in world space). */
void rd_default_lighting_key(const rd_view_camera *cam, rd_light *out);
/* The default environment: a uniform sky of RD_DEFAULT_SKY_*. */
void rd_default_lighting_environment(rd_environment *out);

/* The rule and its lighting in one step, for the offline tools: decides for s under *env and,
 * when needed, adds the key light for cam to s (the last light) and sets *env to the default
 * environment. Returns whether it did; out (optional) receives the check. */
bool rd_default_lighting_apply(rd_scene *s, const rd_view_camera *cam, rd_environment *env,
                               rd_default_lighting_check *out);
/* The check as one clause for a log line: "no lights, no environment, emitters too weak: X W vs
 * Y W" when default lighting is needed, else what lights the scene. */
void rd_default_lighting_describe(const rd_default_lighting_check *c, char *buf, size_t len);

#endif
