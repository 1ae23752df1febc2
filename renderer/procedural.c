#include "procedural.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "xform.h"

/* ---- a growable triangle list turned into one rd_mesh ----------------------------------- */

typedef struct tri_list {
    float *pos; /* 9 per triangle */
    uint32_t *mat;
    uint32_t count, cap;
} tri_list;

static void tl_push(tri_list *t, const float a[3], const float b[3], const float c[3], uint32_t mat)
{
    if (t->count == t->cap) {
        t->cap = t->cap ? t->cap * 2 : 64;
        t->pos = realloc(t->pos, sizeof(float) * 9 * t->cap);
        t->mat = realloc(t->mat, sizeof(uint32_t) * t->cap);
        if (!t->pos || !t->mat) abort();
    }
    float *p = &t->pos[t->count * 9];
    memcpy(p, a, 12), memcpy(p + 3, b, 12), memcpy(p + 6, c, 12);
    t->mat[t->count++] = mat;
}

/* Quad a-b-c-d, counter-clockwise seen from its front. */
static void tl_quad(tri_list *t, const float a[3], const float b[3], const float c[3],
                    const float d[3], uint32_t mat)
{
    tl_push(t, a, b, c, mat);
    tl_push(t, a, c, d, mat);
}

/* Axis-aligned box with outward-facing triangles. */
static void tl_box(tri_list *t, const float lo[3], const float hi[3], uint32_t mat)
{
    float v[8][3];
    for (int i = 0; i < 8; i++) {
        v[i][0] = (i & 1) ? hi[0] : lo[0];
        v[i][1] = (i & 2) ? hi[1] : lo[1];
        v[i][2] = (i & 4) ? hi[2] : lo[2];
    }
    tl_quad(t, v[0], v[4], v[6], v[2], mat); /* -x */
    tl_quad(t, v[1], v[3], v[7], v[5], mat); /* +x */
    tl_quad(t, v[0], v[1], v[5], v[4], mat); /* -y */
    tl_quad(t, v[2], v[6], v[7], v[3], mat); /* +y */
    tl_quad(t, v[0], v[2], v[3], v[1], mat); /* -z */
    tl_quad(t, v[4], v[5], v[7], v[6], mat); /* +z */
}

/* UV sphere with outward-facing triangles: 2 * seg * (rings - 1) triangles. */
static void tl_sphere(tri_list *t, const float c[3], float r, uint32_t rings, uint32_t seg,
                      uint32_t mat)
{
    for (uint32_t i = 0; i < rings; i++) {
        float t0 = (float)M_PI * i / rings, t1 = (float)M_PI * (i + 1) / rings;
        for (uint32_t j = 0; j < seg; j++) {
            float p0 = 2.0f * (float)M_PI * j / seg, p1 = 2.0f * (float)M_PI * (j + 1) / seg;
            float a[3] = {c[0] + r * sinf(t0) * cosf(p0), c[1] + r * cosf(t0), c[2] + r * sinf(t0) * sinf(p0)};
            float b[3] = {c[0] + r * sinf(t1) * cosf(p0), c[1] + r * cosf(t1), c[2] + r * sinf(t1) * sinf(p0)};
            float d[3] = {c[0] + r * sinf(t1) * cosf(p1), c[1] + r * cosf(t1), c[2] + r * sinf(t1) * sinf(p1)};
            float e[3] = {c[0] + r * sinf(t0) * cosf(p1), c[1] + r * cosf(t0), c[2] + r * sinf(t0) * sinf(p1)};
            if (i != 0) tl_push(t, a, e, d, mat);
            if (i != rings - 1) tl_push(t, a, d, b, mat);
        }
    }
}

/* Moves the list into a new mesh (flat normals, zero UVs) placed by a new root node. */
static uint32_t tl_commit(tri_list *t, rd_scene *s, const char *name)
{
    uint32_t m = rd_scene_add_mesh(s, name, t->count);
    rd_mesh *mesh = &s->meshes[m];
    memcpy(mesh->positions, t->pos, sizeof(float) * 9 * t->count);
    memcpy(mesh->material, t->mat, sizeof(uint32_t) * t->count);
    rd_mesh_fill_flat_normals(mesh);
    free(t->pos);
    free(t->mat);
    memset(t, 0, sizeof *t);
    rd_node node = {.name = (char *)name, .parent = -1, .mesh = (int32_t)m,
                    .rotation = {0, 0, 0, 1}, .scale = {1, 1, 1}};
    return rd_scene_add_node(s, &node);
}

static uint32_t material(rd_scene *s, const char *name, float r, float g, float b, float er,
                         float eg, float eb)
{
    rd_material m = {.name = (char *)name, .base_color = {r, g, b, 1}, .emission = {er, eg, eb},
                     .base_color_texture = -1, .emissive_texture = -1, .alpha_cutoff = 0.5f};
    return rd_scene_add_material(s, &m);
}

static void point_light(rd_scene *s, float x, float y, float z, float cd)
{
    rd_light l = {.name = "light", .type = RD_LIGHT_POINT, .color = {1, 1, 1}, .intensity = cd,
                  .node = -1, .position = {x, y, z}, .direction = {0, -1, 0}};
    rd_scene_add_light(s, &l);
}

static void camera(rd_scene *s, const float eye[3], const float fwd[3], const float up[3],
                   float yfov_deg)
{
    rd_camera c = {.name = "camera", .yfov = yfov_deg * (float)M_PI / 180.0f, .znear = 0.01f,
                   .node = -1};
    memcpy(c.position, eye, 12), memcpy(c.forward, fwd, 12), memcpy(c.up, up, 12);
    rd_scene_add_camera(s, &c);
}

/* 10 x 10 m floor at y = 0 facing +y. */
static void floor_plane(tri_list *t, float half, uint32_t mat)
{
    const float a[3] = {-half, 0, -half}, b[3] = {-half, 0, half}, c[3] = {half, 0, half},
                d[3] = {half, 0, -half};
    tl_quad(t, a, b, c, d, mat);
}

static const float DOWN[3] = {0, -1, 0}, NEG_Z[3] = {0, 0, -1}, UP_Y[3] = {0, 1, 0};

static void build_plane_point(rd_scene *s, bool occluder)
{
    tri_list t = {0};
    uint32_t grey = material(s, "grey", 0.5f, 0.5f, 0.5f, 0, 0, 0);
    floor_plane(&t, 5.0f, grey);
    if (occluder) {
        const float lo[3] = {-0.25f, 0.9f, -0.25f}, hi[3] = {0.25f, 1.1f, 0.25f};
        tl_box(&t, lo, hi, grey);
    }
    tl_commit(&t, s, "plane");
    point_light(s, 0, 2, 0, 100);
    const float eye[3] = {0, 4, 0};
    camera(s, eye, DOWN, NEG_Z, 40);
}

static void build_plane_directional(rd_scene *s)
{
    tri_list t = {0};
    floor_plane(&t, 5.0f, material(s, "grey", 0.5f, 0.5f, 0.5f, 0, 0, 0));
    tl_commit(&t, s, "plane");
    float a = 60.0f * (float)M_PI / 180.0f;
    rd_light l = {.name = "sun", .type = RD_LIGHT_DIRECTIONAL, .color = {1, 1, 1},
                  .intensity = 3.0f, .node = -1, .direction = {sinf(a), -cosf(a), 0}};
    rd_scene_add_light(s, &l);
    const float eye[3] = {0, 4, 0};
    camera(s, eye, DOWN, NEG_Z, 40);
}

static void build_emissive(rd_scene *s)
{
    tri_list t = {0};
    uint32_t m = material(s, "emitter", 0, 0, 0, 2.0f, 1.0f, 0.5f);
    const float a[3] = {-1, -1, 0}, b[3] = {1, -1, 0}, c[3] = {1, 1, 0}, d[3] = {-1, 1, 0};
    tl_quad(&t, a, b, c, d, m);
    tl_commit(&t, s, "emitter");
    const float eye[3] = {0, 0, 3};
    camera(s, eye, NEG_Z, UP_Y, 30);
}

/* Cornell-box-like room, 2 m wide, open at +z, with a point light under the ceiling and an
 * emissive ceiling panel. */
static void build_cornell(rd_scene *s)
{
    tri_list t = {0};
    uint32_t white = material(s, "white", 0.73f, 0.73f, 0.73f, 0, 0, 0);
    uint32_t red = material(s, "red", 0.63f, 0.065f, 0.05f, 0, 0, 0);
    uint32_t green = material(s, "green", 0.14f, 0.45f, 0.091f, 0, 0, 0);
    uint32_t lamp = material(s, "lamp", 0.78f, 0.78f, 0.78f, 8.0f, 7.0f, 5.5f);
    float v[8][3];
    for (int i = 0; i < 8; i++) {
        v[i][0] = (i & 1) ? 1 : -1;
        v[i][1] = (i & 2) ? 2 : 0;
        v[i][2] = (i & 4) ? 1 : -1;
    }
    tl_quad(&t, v[0], v[4], v[5], v[1], white); /* floor, faces +y */
    tl_quad(&t, v[2], v[3], v[7], v[6], white); /* ceiling, faces -y */
    tl_quad(&t, v[0], v[1], v[3], v[2], white); /* back wall, faces +z */
    tl_quad(&t, v[0], v[2], v[6], v[4], red);   /* left wall, faces +x */
    tl_quad(&t, v[1], v[5], v[7], v[3], green); /* right wall, faces -x */
    const float l0[3] = {-0.25f, 1.999f, -0.25f}, l1[3] = {0.25f, 1.999f, -0.25f},
                l2[3] = {0.25f, 1.999f, 0.25f}, l3[3] = {-0.25f, 1.999f, 0.25f};
    tl_quad(&t, l0, l1, l2, l3, lamp); /* emitter facing down */
    tl_commit(&t, s, "room");

    tri_list b = {0};
    const float tall_lo[3] = {-0.65f, 0, -0.55f}, tall_hi[3] = {-0.05f, 1.2f, 0.05f};
    tl_box(&b, tall_lo, tall_hi, white);
    tl_commit(&b, s, "tall-block");
    tri_list c = {0};
    const float short_lo[3] = {0.1f, 0, 0.0f}, short_hi[3] = {0.7f, 0.6f, 0.6f};
    tl_box(&c, short_lo, short_hi, white);
    uint32_t node = tl_commit(&c, s, "short-block");
    s->nodes[node].rotation[1] = sinf(-0.15f), s->nodes[node].rotation[3] = cosf(-0.15f);
    tri_list d = {0};
    const float centre[3] = {0.4f, 0.85f, 0.3f};
    tl_sphere(&d, centre, 0.25f, 24, 48, white);
    tl_commit(&d, s, "sphere");

    point_light(s, 0, 1.8f, 0.2f, 3.0f);
    const float eye[3] = {0, 1, 3.9f};
    camera(s, eye, NEG_Z, UP_Y, 40);
}

/* Inward-facing box (a closed room seen from inside). */
static void tl_room(tri_list *t, const float lo[3], const float hi[3], uint32_t mat)
{
    float v[8][3];
    for (int i = 0; i < 8; i++) {
        v[i][0] = (i & 1) ? hi[0] : lo[0];
        v[i][1] = (i & 2) ? hi[1] : lo[1];
        v[i][2] = (i & 4) ? hi[2] : lo[2];
    }
    tl_quad(t, v[0], v[2], v[6], v[4], mat); /* -x wall, faces +x */
    tl_quad(t, v[1], v[5], v[7], v[3], mat); /* +x wall, faces -x */
    tl_quad(t, v[0], v[4], v[5], v[1], mat); /* floor, faces +y */
    tl_quad(t, v[2], v[3], v[7], v[6], mat); /* ceiling, faces -y */
    tl_quad(t, v[0], v[1], v[3], v[2], mat); /* -z wall, faces +z */
    tl_quad(t, v[4], v[6], v[7], v[5], mat); /* +z wall, faces -z */
}

/* Closed furnace: a 2 m cube seen from inside, every surface albedo 0.5 emitting 1 nit, no
 * lights. Radiance everywhere converges to Le / (1 - albedo) = 2. */
static void build_furnace(rd_scene *s)
{
    tri_list t = {0};
    uint32_t m = material(s, "furnace", 0.5f, 0.5f, 0.5f, 1.0f, 1.0f, 1.0f);
    const float lo[3] = {-1, -1, -1}, hi[3] = {1, 1, 1};
    tl_room(&t, lo, hi, m);
    tl_commit(&t, s, "furnace");
    const float eye[3] = {0, 0, 0.5f};
    camera(s, eye, NEG_Z, UP_Y, 60);
}

/* Two closed 2 x 2 x 2 m rooms sharing a 4 cm wall at x = 0. Room A (x < 0) holds a 20 cd
 * point light; room B (x > 0) has no light and the camera, looking at the shared wall. With
 * direct light only room B is black; its light can only come from leaks through the wall. */
static void build_two_rooms(rd_scene *s)
{
    tri_list t = {0};
    uint32_t white = material(s, "white", 0.8f, 0.8f, 0.8f, 0, 0, 0);
    const float a_lo[3] = {-2.02f, 0, -1}, a_hi[3] = {-0.02f, 2, 1};
    const float b_lo[3] = {0.02f, 0, -1}, b_hi[3] = {2.02f, 2, 1};
    tl_room(&t, a_lo, a_hi, white);
    tl_room(&t, b_lo, b_hi, white);
    tl_commit(&t, s, "rooms");
    point_light(s, -1.0f, 1.5f, 0.0f, 20.0f);
    const float eye[3] = {1.9f, 1.0f, 0.0f}, fwd[3] = {-1, 0, 0};
    camera(s, eye, fwd, UP_Y, 70);
}

/* Benchmark scene: floor, back wall and a grid of spheres with >= min_tris triangles. */
static void build_spheres(rd_scene *s, uint64_t min_tris)
{
    uint32_t white = material(s, "white", 0.7f, 0.7f, 0.7f, 0, 0, 0);
    uint32_t warm = material(s, "warm", 0.8f, 0.5f, 0.3f, 0, 0, 0);
    tri_list t = {0};
    floor_plane(&t, 12.0f, white);
    const float a[3] = {-12, 0, -12}, b[3] = {12, 0, -12}, c[3] = {12, 8, -12}, d[3] = {-12, 8, -12};
    tl_quad(&t, a, b, c, d, white);
    tl_commit(&t, s, "room");
    const uint32_t grid = 8, rings = 64, seg = 128; /* one sphere: 2*128*63 = 16128 tris */
    uint64_t per_sphere = 2ull * seg * (rings - 1);
    uint64_t spheres = (min_tris + per_sphere - 1) / per_sphere;
    if (spheres < 1) spheres = 1;
    uint32_t layers = (uint32_t)((spheres + grid * grid - 1) / (grid * grid));
    uint64_t placed = 0;
    for (uint32_t l = 0; l < layers && placed < spheres; l++) {
        tri_list sp = {0};
        for (uint32_t i = 0; i < grid * grid && placed < spheres; i++, placed++) {
            float centre[3] = {-10.5f + 3.0f * (i % grid), 1.0f + 2.2f * l,
                               -10.5f + 3.0f * (i / grid)};
            tl_sphere(&sp, centre, 1.0f, rings, seg, (i + l) % 2 ? warm : white);
        }
        tl_commit(&sp, s, "spheres");
    }
    point_light(s, 0, 9.0f, 4.0f, 400.0f);
    rd_light sun = {.name = "sun", .type = RD_LIGHT_DIRECTIONAL, .color = {1, 0.95f, 0.9f},
                    .intensity = 2.0f, .node = -1, .direction = {0.3f, -0.8f, -0.5f}};
    rd_scene_add_light(s, &sun);
    float fwd[3];
    const float dir[3] = {0, -0.45f, -1};
    rd_vec3_normalize(fwd, dir, NULL);
    const float eye[3] = {0, 9, 16};
    camera(s, eye, fwd, UP_Y, 50);
}

const char *rd_procedural_names(void)
{
    return "cornell, plane-point, plane-directional, emissive, shadow, furnace, two-rooms, "
           "spheres[:TRIANGLES]";
}

bool rd_procedural_build(const char *name, rd_scene *s, char *err, size_t errlen)
{
    rd_scene_init(s);
    const char *colon = strchr(name, ':');
    size_t len = colon ? (size_t)(colon - name) : strlen(name);
#define IS(n) (len == strlen(n) && strncmp(name, n, len) == 0)
    if (colon && !IS("spheres")) {
        snprintf(err, errlen, "builtin scene '%.*s' takes no argument", (int)len, name);
        return false;
    }
    if (IS("cornell")) build_cornell(s);
    else if (IS("plane-point")) build_plane_point(s, false);
    else if (IS("shadow")) build_plane_point(s, true);
    else if (IS("plane-directional")) build_plane_directional(s);
    else if (IS("emissive")) build_emissive(s);
    else if (IS("furnace")) build_furnace(s);
    else if (IS("two-rooms")) build_two_rooms(s);
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
