#include "renderer/builtin/procedural.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/scene/mesh_builder.h"
#include "renderer/builtin/procedural_interior.h"
#include "renderer/scene/xform.h"

/* 10 x 10 m floor at y = 0 facing +y. */
static void floor_plane(rd_tri_list *t, float half, uint32_t mat)
{
    const float a[3] = {-half, 0, -half}, b[3] = {-half, 0, half}, c[3] = {half, 0, half},
                d[3] = {half, 0, -half};
    rd_tris_quad(t, a, b, c, d, mat);
}

static const float DOWN[3] = {0, -1, 0}, NEG_Z[3] = {0, 0, -1}, UP_Y[3] = {0, 1, 0};

static void build_plane_point(rd_scene *s, bool occluder)
{
    rd_tri_list t = {0};
    uint32_t grey = rd_build_material(s, "grey", 0.5f, 0.5f, 0.5f, 0, 0, 0);
    floor_plane(&t, 5.0f, grey);
    if (occluder) {
        const float lo[3] = {-0.25f, 0.9f, -0.25f}, hi[3] = {0.25f, 1.1f, 0.25f};
        rd_tris_box(&t, lo, hi, grey);
    }
    rd_tris_commit(&t, s, "plane");
    rd_build_point_light(s, 0, 2, 0, 100);
    const float eye[3] = {0, 4, 0};
    rd_build_camera(s, eye, DOWN, NEG_Z, 40);
}

static void build_plane_directional(rd_scene *s)
{
    rd_tri_list t = {0};
    floor_plane(&t, 5.0f, rd_build_material(s, "grey", 0.5f, 0.5f, 0.5f, 0, 0, 0));
    rd_tris_commit(&t, s, "plane");
    float a = 60.0f * (float)M_PI / 180.0f;
    const float dir[3] = {sinf(a), -cosf(a), 0}, white[3] = {1, 1, 1};
    rd_build_sun(s, dir, white, 3.0f);
    const float eye[3] = {0, 4, 0};
    rd_build_camera(s, eye, DOWN, NEG_Z, 40);
}

static void build_emissive(rd_scene *s)
{
    rd_tri_list t = {0};
    uint32_t m = rd_build_material(s, "emitter", 0, 0, 0, 2.0f, 1.0f, 0.5f);
    const float a[3] = {-1, -1, 0}, b[3] = {1, -1, 0}, c[3] = {1, 1, 0}, d[3] = {-1, 1, 0};
    rd_tris_quad(&t, a, b, c, d, m);
    rd_tris_commit(&t, s, "emitter");
    const float eye[3] = {0, 0, 3};
    rd_build_camera(s, eye, NEG_Z, UP_Y, 30);
}

/* A glTF-like metallic-roughness material (rd_build_material gives a pure Lambertian). */
static uint32_t glossy_material(rd_scene *s, const char *name, float r, float g, float b,
                                float metallic, float roughness)
{
    uint32_t m = rd_build_material(s, name, r, g, b, 0, 0, 0);
    s->materials[m].metallic = metallic;
    s->materials[m].roughness = roughness;
    s->materials[m].specular = 1;
    return m;
}

/* Cornell-box-like room, 2 m wide, open at +z, with a point light under the ceiling and an
 * emissive ceiling panel. glossy: a gold sphere (metal, roughness 0.15), a near-mirror tall block
 * (metal, roughness 0.05) and a glossy dielectric floor (roughness 0.3) instead of Lambertians. */
static void build_cornell(rd_scene *s, bool glossy)
{
    rd_tri_list t = {0};
    uint32_t white = rd_build_material(s, "white", 0.73f, 0.73f, 0.73f, 0, 0, 0);
    uint32_t red = rd_build_material(s, "red", 0.63f, 0.065f, 0.05f, 0, 0, 0);
    uint32_t green = rd_build_material(s, "green", 0.14f, 0.45f, 0.091f, 0, 0, 0);
    uint32_t lamp = rd_build_material(s, "lamp", 0.78f, 0.78f, 0.78f, 8.0f, 7.0f, 5.5f);
    uint32_t floor =
        glossy ? glossy_material(s, "glossy floor", 0.73f, 0.73f, 0.73f, 0, 0.3f) : white;
    uint32_t mirror = glossy ? glossy_material(s, "mirror", 0.95f, 0.95f, 0.95f, 1, 0.05f) : white;
    uint32_t gold = glossy ? glossy_material(s, "gold", 1.0f, 0.78f, 0.34f, 1, 0.15f) : white;
    float v[8][3];
    for (int i = 0; i < 8; i++) {
        v[i][0] = (i & 1) ? 1 : -1;
        v[i][1] = (i & 2) ? 2 : 0;
        v[i][2] = (i & 4) ? 1 : -1;
    }
    rd_tris_quad(&t, v[0], v[4], v[5], v[1], floor); /* floor, faces +y */
    rd_tris_quad(&t, v[2], v[3], v[7], v[6], white); /* ceiling, faces -y */
    rd_tris_quad(&t, v[0], v[1], v[3], v[2], white); /* back wall, faces +z */
    rd_tris_quad(&t, v[0], v[2], v[6], v[4], red);   /* left wall, faces +x */
    rd_tris_quad(&t, v[1], v[5], v[7], v[3], green); /* right wall, faces -x */
    const float l0[3] = {-0.25f, 1.999f, -0.25f}, l1[3] = {0.25f, 1.999f, -0.25f},
                l2[3] = {0.25f, 1.999f, 0.25f}, l3[3] = {-0.25f, 1.999f, 0.25f};
    rd_tris_quad(&t, l0, l1, l2, l3, lamp); /* emitter facing down */
    rd_tris_commit(&t, s, "room");

    rd_tri_list b = {0};
    const float tall_lo[3] = {-0.65f, 0, -0.55f}, tall_hi[3] = {-0.05f, 1.2f, 0.05f};
    rd_tris_box(&b, tall_lo, tall_hi, mirror);
    rd_tris_commit(&b, s, "tall-block");
    rd_tri_list c = {0};
    const float short_lo[3] = {0.1f, 0, 0.0f}, short_hi[3] = {0.7f, 0.6f, 0.6f};
    rd_tris_box(&c, short_lo, short_hi, white);
    uint32_t node = rd_tris_commit(&c, s, "short-block");
    s->nodes[node].rotation[1] = sinf(-0.15f), s->nodes[node].rotation[3] = cosf(-0.15f);
    rd_tri_list d = {0};
    const float centre[3] = {0.4f, 0.85f, 0.3f};
    rd_tris_sphere(&d, centre, 0.25f, 24, 48, gold);
    rd_tris_commit(&d, s, "sphere");

    rd_build_point_light(s, 0, 1.8f, 0.2f, 3.0f);
    const float eye[3] = {0, 1, 3.9f};
    rd_build_camera(s, eye, NEG_Z, UP_Y, 40);
}

/* Closed furnace: a 2 m cube seen from inside, every surface albedo 0.5 emitting 1 nit, no
 * lights. Radiance everywhere converges to Le / (1 - albedo) = 2. */
static void build_furnace(rd_scene *s)
{
    rd_tri_list t = {0};
    uint32_t m = rd_build_material(s, "furnace", 0.5f, 0.5f, 0.5f, 1.0f, 1.0f, 1.0f);
    const float lo[3] = {-1, -1, -1}, hi[3] = {1, 1, 1};
    rd_tris_room(&t, lo, hi, m);
    rd_tris_commit(&t, s, "furnace");
    const float eye[3] = {0, 0, 0.5f};
    rd_build_camera(s, eye, NEG_Z, UP_Y, 60);
}

/* Two closed 2 x 2 x 2 m rooms sharing a 4 cm wall at x = 0. Room A (x < 0) holds a 20 cd
 * point light; room B (x > 0) has no light and the camera, looking at the shared wall. With
 * direct light only room B is black; its light can only come from leaks through the wall. */
static void build_two_rooms(rd_scene *s)
{
    rd_tri_list t = {0};
    uint32_t white = rd_build_material(s, "white", 0.8f, 0.8f, 0.8f, 0, 0, 0);
    const float a_lo[3] = {-2.02f, 0, -1}, a_hi[3] = {-0.02f, 2, 1};
    const float b_lo[3] = {0.02f, 0, -1}, b_hi[3] = {2.02f, 2, 1};
    rd_tris_room(&t, a_lo, a_hi, white);
    rd_tris_room(&t, b_lo, b_hi, white);
    rd_tris_commit(&t, s, "rooms");
    rd_build_point_light(s, -1.0f, 1.5f, 0.0f, 20.0f);
    const float eye[3] = {1.9f, 1.0f, 0.0f}, fwd[3] = {-1, 0, 0};
    rd_build_camera(s, eye, fwd, UP_Y, 70);
    /* camera 1: inside the lit room, looking at its far wall */
    const float eye_a[3] = {-0.1f, 1.0f, 0.0f}, fwd_a[3] = {-1, 0, 0};
    rd_build_camera(s, eye_a, fwd_a, UP_Y, 70);
}

/* A closed 2 x 2 x 2 m white room (albedo 0.8) lit by a 20 cd point light below its ceiling:
 * four fifths of the light that reaches the eye has bounced (indirect / direct = 0.8 / 0.2 for
 * a closed room), so a truncated or slow multi-bounce solution shows as a dark image. */
static void build_white_room(rd_scene *s)
{
    rd_tri_list t = {0};
    uint32_t white = rd_build_material(s, "white", 0.8f, 0.8f, 0.8f, 0, 0, 0);
    const float lo[3] = {-1, 0, -1}, hi[3] = {1, 2, 1};
    rd_tris_room(&t, lo, hi, white);
    rd_tris_commit(&t, s, "room");
    rd_build_point_light(s, 0.3f, 1.6f, 0.2f, 20.0f);
    const float eye[3] = {0, 1.0f, 0.95f};
    rd_build_camera(s, eye, NEG_Z, UP_Y, 70);
}

/* Benchmark scene: floor, back wall and a grid of spheres with >= min_tris triangles. */
static void build_spheres(rd_scene *s, uint64_t min_tris)
{
    uint32_t white = rd_build_material(s, "white", 0.7f, 0.7f, 0.7f, 0, 0, 0);
    uint32_t warm = rd_build_material(s, "warm", 0.8f, 0.5f, 0.3f, 0, 0, 0);
    rd_tri_list t = {0};
    floor_plane(&t, 12.0f, white);
    const float a[3] = {-12, 0, -12}, b[3] = {12, 0, -12}, c[3] = {12, 8, -12},
                d[3] = {-12, 8, -12};
    rd_tris_quad(&t, a, b, c, d, white);
    rd_tris_commit(&t, s, "room");
    const uint32_t grid = 8, rings = 64, seg = 128; /* one sphere: 2*128*63 = 16128 tris */
    uint64_t per_sphere = 2ull * seg * (rings - 1);
    uint64_t spheres = (min_tris + per_sphere - 1) / per_sphere;
    if (spheres < 1) spheres = 1;
    uint32_t layers = (uint32_t)((spheres + grid * grid - 1) / (grid * grid));
    uint64_t placed = 0;
    for (uint32_t l = 0; l < layers && placed < spheres; l++) {
        rd_tri_list sp = {0};
        for (uint32_t i = 0; i < grid * grid && placed < spheres; i++, placed++) {
            float centre[3] = {-10.5f + 3.0f * (i % grid), 1.0f + 2.2f * l,
                               -10.5f + 3.0f * (i / grid)};
            rd_tris_sphere(&sp, centre, 1.0f, rings, seg, (i + l) % 2 ? warm : white);
        }
        rd_tris_commit(&sp, s, "spheres");
    }
    rd_build_point_light(s, 0, 9.0f, 4.0f, 400.0f);
    const float sun_dir[3] = {0.3f, -0.8f, -0.5f}, sun_color[3] = {1, 0.95f, 0.9f};
    rd_build_sun(s, sun_dir, sun_color, 2.0f);
    float fwd[3];
    const float dir[3] = {0, -0.45f, -1};
    rd_vec3_normalize(fwd, dir, NULL);
    const float eye[3] = {0, 9, 16};
    rd_build_camera(s, eye, fwd, UP_Y, 50);
}

const char *rd_procedural_names(void)
{
    return "cornell, cornell-glossy, plane-point, plane-directional, emissive, shadow, furnace, "
           "two-rooms, "
           "white-room, "
           "spheres[:TRIANGLES], interior[:MILLIONS], hard:CASE (the stability suite: probecast "
           "eval --list); each as NAME+gltf or NAME+metal with glTF materials";
}

bool rd_procedural_scene(const char *name, rd_scene *s, char *err, size_t errlen)
{
    rd_scene_init(s);
    const char *colon = strchr(name, ':');
    size_t len = colon ? (size_t)(colon - name) : strlen(name);
#define IS(n) (len == strlen(n) && strncmp(name, n, len) == 0)
    if (colon && !IS("spheres") && !IS("interior")) {
        snprintf(err, errlen, "builtin scene '%.*s' takes no argument", (int)len, name);
        return false;
    }
    if (IS("cornell"))
        build_cornell(s, false);
    else if (IS("cornell-glossy"))
        build_cornell(s, true);
    else if (IS("plane-point"))
        build_plane_point(s, false);
    else if (IS("shadow"))
        build_plane_point(s, true);
    else if (IS("plane-directional"))
        build_plane_directional(s);
    else if (IS("emissive"))
        build_emissive(s);
    else if (IS("furnace"))
        build_furnace(s);
    else if (IS("two-rooms"))
        build_two_rooms(s);
    else if (IS("white-room"))
        build_white_room(s);
    else if (IS("spheres")) {
        uint64_t n = 1000000;
        if (colon) {
            char *end = NULL;
            n = strtoull(colon + 1, &end, 10);
            if (!end || *end || n == 0 || n > 200000000ull) {
                snprintf(err, errlen, "spheres: '%s' is not a triangle count in 1..200000000",
                         colon + 1);
                return false;
            }
        }
        build_spheres(s, n);
    } else if (IS("interior")) {
        double m = RD_INTERIOR_DEFAULT_MILLIONS;
        if (colon) {
            char *end = NULL;
            m = strtod(colon + 1, &end);
            if (!end || end == colon + 1 || *end) {
                snprintf(err, errlen, "interior: '%s' is not a number of million triangles",
                         colon + 1);
                rd_scene_destroy(s);
                return false;
            }
        }
        if (!rd_interior_build(s, m, err, errlen)) {
            rd_scene_destroy(s);
            return false;
        }
    } else {
        snprintf(err, errlen, "unknown builtin scene '%.*s' (known: %s)", (int)len, name,
                 rd_procedural_names());
        return false;
    }
#undef IS
    if (!rd_scene_update(s, err, errlen)) {
        rd_scene_destroy(s);
        return false;
    }
    return true;
}
