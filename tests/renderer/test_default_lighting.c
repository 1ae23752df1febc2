/* The default-lighting rule (renderer/scene/default_lighting.h) on the CPU: which scenes get it
 * (no lights, a tiny emissive detail) and which do not (a punctual light, an environment, a
 * large emissive ceiling), the emitted power it compares (area, texture, sides, scale), and the
 * lighting it adds. Prints the builtin scenes' emitter-to-key power ratios. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/builtin/procedural.h"
#include "renderer/scene/default_lighting.h"
#include "renderer/scene/mesh_builder.h"
#include "test_util.h"

#define PI 3.14159265358979323846

/* A 1 m white box standing on the origin. */
static void add_model(rd_scene *s)
{
    rd_tri_list t = {0};
    uint32_t white = rd_build_material(s, "white", 0.8f, 0.8f, 0.8f, 0, 0, 0);
    const float lo[3] = {-0.5f, 0, -0.5f}, hi[3] = {0.5f, 1, 0.5f};
    rd_tris_box(&t, lo, hi, white);
    rd_tris_commit(&t, s, "model");
}

/* A square emitter of side `side` facing +z at z = 0.501 (in front of the model's face), centred
 * at height 0.5, emitting `nits` (grey). Returns its material. */
static uint32_t add_emitter(rd_scene *s, float side, float nits)
{
    rd_tri_list t = {0};
    uint32_t m = rd_build_material(s, "glow", 0, 0, 0, nits, nits, nits);
    float h = side / 2;
    const float a[3] = {-h, 0.5f - h, 0.501f}, b[3] = {h, 0.5f - h, 0.501f},
                c[3] = {h, 0.5f + h, 0.501f}, d[3] = {-h, 0.5f + h, 0.501f};
    rd_tris_quad(&t, a, b, c, d, m);
    rd_tris_commit(&t, s, "emitter");
    return m;
}

static void update(rd_scene *s)
{
    char err[128];
    CHECKF(rd_scene_update(s, err, sizeof err), "%s", err);
}

/* No lights, no environment, no emission: default lighting, a key light from the camera's side
 * and the default sky. */
static void test_no_lights(void)
{
    rd_scene s;
    rd_scene_init(&s);
    add_model(&s);
    update(&s);
    rd_view_camera cam;
    char err[128];
    CHECK(rd_camera_for_scene(&s, -1, &cam, err, sizeof err));
    rd_environment env = {.mode = RD_ENV_UNIFORM};
    rd_default_lighting_check c;
    CHECK(rd_default_lighting_apply(&s, &cam, &env, &c));
    CHECK(c.needed && c.lights == 0 && !c.environment && c.emitted_w == 0);
    /* the key light onto the 1 m box: 2.5 lux x a quarter of its 6 m^2 */
    CHECKF(test_close_rel(c.key_w, RD_DEFAULT_KEY_LUX * 6.0 / 4, 1e-6), "key %g W", c.key_w);
    CHECK(c.threshold_w == c.key_w * RD_DEFAULT_LIGHTING_EMITTER_SHARE);
    CHECK(s.light_count == 1);
    const rd_light *key = &s.lights[0];
    CHECK(key->type == RD_LIGHT_DIRECTIONAL && key->intensity == RD_DEFAULT_KEY_LUX &&
          key->node == -1 && strcmp(key->name, "default key light") == 0);
    /* it shines the way the camera looks, down, and toward the camera's right */
    float right[3] = {-cam.forward[2], 0, cam.forward[0]}; /* forward x up, unnormalised */
    float along = key->direction[0] * cam.forward[0] + key->direction[1] * cam.forward[1] +
                  key->direction[2] * cam.forward[2];
    float rightward = key->direction[0] * right[0] + key->direction[2] * right[2];
    CHECK(along > 0.3f && key->direction[1] < -0.3f && rightward > 0);
    CHECK(env.mode == RD_ENV_UNIFORM && env.sky[0] == RD_DEFAULT_SKY_R &&
          env.sky[1] == RD_DEFAULT_SKY_G && env.sky[2] == RD_DEFAULT_SKY_B);
    char why[160];
    const char *expect = "no lights, no environment, emitters too weak: 0 W vs ";
    rd_default_lighting_describe(&c, why, sizeof why);
    CHECKF(strncmp(why, expect, strlen(expect)) == 0, "%s", why);
    /* once lit, the rule is satisfied: applying it again adds nothing */
    CHECK(!rd_default_lighting_apply(&s, &cam, &env, &c) && s.light_count == 1);
    rd_scene_destroy(&s);

    /* an empty scene gets it too (nothing emits) */
    rd_scene_init(&s);
    update(&s);
    rd_default_lighting_decide(&s, NULL, &c);
    CHECK(c.needed);
    rd_scene_destroy(&s);
}

/* A 1 cm emitter of 50 nits (a bright LED) on the 1 m model does not light it: default lighting.
 * The verdict does not change with the scene's scale (both powers go with area). */
static void test_tiny_emitter(void)
{
    for (int scaled = 0; scaled < 2; scaled++) {
        rd_scene s;
        rd_scene_init(&s);
        add_model(&s);
        add_emitter(&s, 0.01f, 50);
        if (scaled)
            for (uint32_t i = 0; i < s.node_count; i++)
                s.nodes[i].scale[0] = s.nodes[i].scale[1] = s.nodes[i].scale[2] = 100;
        update(&s);
        rd_default_lighting_check c;
        rd_default_lighting_decide(&s, NULL, &c);
        double area = scaled ? 1.0 : 1e-4;
        CHECKF(test_close_rel(c.emitted_w, PI * area * 50, 1e-4), "emitted %g W", c.emitted_w);
        CHECKF(c.needed && c.emitted_w < 0.1 * c.threshold_w, "%g W vs %g W", c.emitted_w,
               c.threshold_w);
        char why[160];
        rd_default_lighting_describe(&c, why, sizeof why);
        CHECKF(strstr(why, "emitters too weak") != NULL, "%s", why);
        rd_scene_destroy(&s);
    }
}

/* A closed 2 m Cornell-style room lit only by a 1 m square panel in its ceiling (the builtin
 * Cornell lamp's radiance) lights itself. */
static void test_emissive_ceiling(void)
{
    rd_scene s;
    rd_scene_init(&s);
    rd_tri_list t = {0};
    uint32_t white = rd_build_material(&s, "white", 0.73f, 0.73f, 0.73f, 0, 0, 0);
    uint32_t lamp = rd_build_material(&s, "lamp", 0.78f, 0.78f, 0.78f, 8.0f, 7.0f, 5.5f);
    const float lo[3] = {-1, 0, -1}, hi[3] = {1, 2, 1};
    rd_tris_room(&t, lo, hi, white);
    const float l0[3] = {-0.5f, 1.999f, -0.5f}, l1[3] = {0.5f, 1.999f, -0.5f},
                l2[3] = {0.5f, 1.999f, 0.5f}, l3[3] = {-0.5f, 1.999f, 0.5f};
    rd_tris_quad(&t, l0, l1, l2, l3, lamp); /* faces down */
    rd_tris_commit(&t, &s, "room");
    update(&s);
    rd_default_lighting_check c;
    rd_environment black = {.mode = RD_ENV_UNIFORM};
    rd_default_lighting_decide(&s, &black, &c);
    double y = 0.2126 * 8 + 0.7152 * 7 + 0.0722 * 5.5;
    CHECKF(test_close_rel(c.emitted_w, PI * 1.0 * y, 1e-4), "emitted %g W", c.emitted_w);
    CHECKF(!c.needed && c.emitted_w > 2 * c.threshold_w, "%g W vs %g W", c.emitted_w,
           c.threshold_w);
    char why[160];
    rd_default_lighting_describe(&c, why, sizeof why);
    CHECKF(strncmp(why, "the emitters light the scene", 28) == 0, "%s", why);
    rd_scene_destroy(&s);
}

/* A punctual light, or an environment, lights the scene; a light of zero intensity does not. */
static void test_light_or_environment(void)
{
    rd_scene s;
    rd_scene_init(&s);
    add_model(&s);
    rd_build_point_light(&s, 0, 2, 1, 0);
    update(&s);
    rd_default_lighting_check c;
    rd_default_lighting_decide(&s, NULL, &c);
    CHECK(c.needed && c.lights == 0); /* switched off */
    s.lights[0].intensity = 5;
    rd_default_lighting_decide(&s, NULL, &c);
    CHECK(!c.needed && c.lights == 1);
    rd_scene_remove_light(&s, 0);

    rd_environment e = {.mode = RD_ENV_UNIFORM};
    rd_default_lighting_decide(&s, &e, &c);
    CHECK(c.needed && !c.environment);
    e.sky[2] = 0.1f; /* a blue sky */
    rd_default_lighting_decide(&s, &e, &c);
    CHECK(!c.needed && c.environment);
    memset(&e, 0, sizeof e);
    e.mode = RD_ENV_GRADIENT;
    e.ground[0] = 0.2f; /* black zenith, lit ground */
    rd_default_lighting_decide(&s, &e, &c);
    CHECK(!c.needed);
    e.mode = RD_ENV_UNIFORM; /* the ground is not shown in uniform mode */
    rd_default_lighting_decide(&s, &e, &c);
    CHECK(c.needed);
    e.mode = RD_ENV_IMAGE; /* an image environment (the daemon passes the mode alone) */
    rd_default_lighting_decide(&s, &e, &c);
    CHECK(!c.needed);
    rd_scene_destroy(&s);
}

/* The emissive texture's mean (sRGB decoded) and double-sidedness scale the power. */
static void test_power_texture_and_sides(void)
{
    rd_scene s;
    rd_scene_init(&s);
    add_model(&s);
    uint32_t m = add_emitter(&s, 0.1f, 2);
    update(&s);
    double plain = rd_default_lighting_emitted_power(&s);
    CHECKF(test_close_rel(plain, PI * 0.01 * 2, 1e-4), "plain %g W", plain);
    s.materials[m].double_sided = true;
    CHECK(test_close_rel(rd_default_lighting_emitted_power(&s), 2 * plain, 1e-9));
    s.materials[m].double_sided = false;
    /* a 2 x 2 texture: one white texel, one at sRGB 128 (0.2158 linear), two black */
    rd_texture tex = {.width = 2, .height = 2, .rgba = malloc(16)};
    if (!tex.rgba) abort();
    const uint8_t px[16] = {255, 255, 255, 255, 128, 128, 128, 255, 0, 0, 0, 255, 0, 0, 0, 255};
    memcpy(tex.rgba, px, sizeof px);
    s.materials[m].emissive_texture = (int32_t)rd_scene_add_texture(&s, &tex);
    double mean = (1.0 + pow((128 / 255.0 + 0.055) / 1.055, 2.4)) / 4;
    double textured = rd_default_lighting_emitted_power(&s);
    CHECKF(test_close_rel(textured, plain * mean, 1e-6), "textured %g W, expected %g W", textured,
           plain * mean);
    /* negative and non-finite emission emits nothing (as the shaders clamp it) */
    s.materials[m].emission[0] = -5, s.materials[m].emission[1] = NAN;
    s.materials[m].emission[2] = 0;
    CHECK(rd_default_lighting_emitted_power(&s) == 0);
    rd_scene_destroy(&s);
}

/* The builtin scenes that emit: their power against the threshold (the numbers behind
 * RD_DEFAULT_LIGHTING_EMITTER_SHARE), and their verdicts. */
static void test_builtin_scenes(void)
{
    static const struct {
        const char *name;
        bool unlit; /* its lights removed: the emitters alone */
        bool needed;
    } scenes[] = {{"cornell", false, false},       {"cornell", true, false},
                  {"emissive", false, false},      {"furnace", false, false},
                  {"hard:no-lights", false, true}, {"hard:tiny-emitter", false, false},
                  {"plane-point", false, false}};
    printf("%-18s %10s %10s %8s %s\n", "scene", "emitted W", "key W", "ratio", "default lighting");
    for (size_t i = 0; i < sizeof scenes / sizeof scenes[0]; i++) {
        rd_scene s;
        char err[128];
        if (!rd_procedural_build(scenes[i].name, &s, err, sizeof err)) {
            CHECKF(0, "%s: %s", scenes[i].name, err);
            continue;
        }
        while (scenes[i].unlit && s.light_count)
            rd_scene_remove_light(&s, 0);
        rd_default_lighting_check c;
        rd_default_lighting_decide(&s, NULL, &c);
        char label[64];
        snprintf(label, sizeof label, "%s%s", scenes[i].name, scenes[i].unlit ? " unlit" : "");
        printf("%-18s %10.4g %10.4g %8.3g %s\n", label, c.emitted_w, c.key_w,
               c.key_w > 0 ? c.emitted_w / c.key_w : 0.0, c.needed ? "yes" : "no");
        CHECKF(c.needed == scenes[i].needed, "%s: needed %d", scenes[i].name, c.needed);
        rd_scene_destroy(&s);
    }
}

int main(void)
{
    test_no_lights();
    test_tiny_emitter();
    test_emissive_ceiling();
    test_light_or_environment();
    test_power_texture_and_sides();
    test_builtin_scenes();
    return test_finish();
}
