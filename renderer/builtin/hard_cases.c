#include "renderer/builtin/hard_cases.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "renderer/scene/mesh_builder.h"
#include "renderer/scene/xform.h"
#include "renderer/builtin/procedural.h"

static const rd_hard_case CASES[] = {
    {"cornell", "DDGI stays within the justified error bound of the path-traced reference"},
    {"furnace", "radiance everywhere is Le/(1-albedo) = 2 (within 3% for DDGI, 2% path traced)"},
    {"two-rooms",
     "the closed, unlit room stays dark: DDGI leaks under 5% of what classic probes leak"},
    {"thick-walls", "probes inside a 0.6 m solid wall are switched off; output finite, no dark "
                    "splotches (error bounded like cornell)"},
    {"scaled-100", "the Cornell box scaled x100 (light intensity x1e4) renders like the original "
                   "(direct light to float precision, GI within its seed noise)"},
    {"scaled-0.01", "the Cornell box scaled x0.01 (light intensity x1e-4) renders like the "
                    "original (direct light to float precision, GI within its seed noise)"},
    {"far-10km", "the Cornell box translated 10 km from the origin renders like the original "
                 "(direct light to float precision, GI within its seed noise)"},
    {"far-10km-baked",
     "the Cornell box scaled x100 with its vertices baked 10 km from the origin (identity nodes, "
     "as geo-referenced data comes) renders like scaled-100 (direct light to float precision, GI "
     "within its seed noise, no speckles)"},
    {"tiny-emitter", "a 1 cm emitter of 1e5 nits is the only light: every output finite (no NaN, "
                     "Inf or half-float overflow) at any sample count; sampling finds it rarely "
                     "(fireflies in the path tracer, DDGI may miss it entirely)"},
    {"no-lights", "no lights, no emission, black sky: every output value is exactly zero "
                  "(probecast eval gives it default lighting unless --default-lighting off)"},
    {"degenerate",
     "zero-area triangles and NaN or zero normals: output finite and the floor still lit"},
    {"mirrored",
     "single-sided plane under a node scaled (-1, 1, 1): renders exactly like plane-point"},
    {"moving", "the sphere moves for several frames; output finite and GI follows (error bounded "
               "after settling)"},
    {"glossy", "the Cornell box with a gold sphere, a near-mirror block and a glossy floor: output "
               "finite; the error shows what indirect specular (reflections) adds"},
    {"many-lights", "the Cornell box lit by four coloured lights (probe hits pick one per shadow "
                    "ray): DDGI stays within the error bound of cornell"},
    {"sun-room", "a closed 6 x 3 x 6 m room lit only by a sun through one window (a bright patch "
                 "on the floor, the rest by bounces): the probe field sleeps within 600 updates "
                 "at the default hysteresis, its mean within 2% of a field updated for longer"},
    {"thin-walls", "a closed 4 x 2.5 x 4 m room of 5 cm walls and roof on a sunlit terrace, lit "
                   "inside only through a door on its shaded side; the camera inside faces the "
                   "sunlit wall: no light through the walls (within 5% of the path tracer, no "
                   "bright seam along the corners)"},
    {"narrow-gap", "an 8 x 3 x 4 m room split by a 1 cm wall with a 25 cm gap at the floor, the "
                   "light on one side, the camera on the other: the dark side gets the light "
                   "through the gap within 5% of the path tracer"},
    {"lamp-room", "a closed 4 x 3 x 4 m room lit by one point light inside an open, flared lamp "
                  "shade (albedo 0.9, double-sided), as builtin:interior's lamps: most light "
                  "reaches the room bounced off the shade's inside, which the probes see only "
                  "from outside; with probe_paths 3 DDGI comes within 12% of the path tracer "
                  "(first hits only: about 30% dark)"},
    {"interior", "builtin:interior, the demo's house (2.35 M triangles, glossy floors, 11 point "
                 "lights in lamp shades and a sun through its windows), from its default camera: "
                 "speed against error for the view's options (reflections, shadow_cull, "
                 "near_field, visibility_rays) on and off; its default grid (8 x 2 x 5 probes) is "
                 "still far from the path tracer (about -40%)"},
};

const rd_hard_case *rd_hard_cases(unsigned *count)
{
    *count = sizeof CASES / sizeof CASES[0];
    return CASES;
}

static const float NEG_Z[3] = {0, 0, -1}, UP_Y[3] = {0, 1, 0};

/* Scales and translates the whole scene (roots, lights, cameras); point-light intensity
 * scales with s^2 so that irradiance, and so the image, stays the same. */
static void transform_scene(rd_scene *s, float scale, const float move[3])
{
    for (uint32_t i = 0; i < s->node_count; i++) {
        rd_node *n = &s->nodes[i];
        if (n->parent >= 0) continue;
        for (int k = 0; k < 3; k++) {
            n->translation[k] = n->translation[k] * scale + move[k];
            n->scale[k] *= scale;
        }
    }
    for (uint32_t i = 0; i < s->light_count; i++) {
        rd_light *l = &s->lights[i];
        for (int k = 0; k < 3; k++)
            l->position[k] = l->position[k] * scale + move[k];
        if (l->type != RD_LIGHT_DIRECTIONAL) l->intensity *= scale * scale;
        if (l->range > 0) l->range *= scale;
    }
    for (uint32_t i = 0; i < s->camera_count; i++)
        for (int k = 0; k < 3; k++)
            s->cameras[i].position[k] = s->cameras[i].position[k] * scale + move[k];
}

/* Moves every node's placement into its mesh's vertices (computed in double, rounded once) and
 * leaves the nodes at identity: coordinates as a geo-referenced file stores them. Each mesh
 * here has exactly one node; normals keep the inverse transpose (tangents are absent). */
static void bake_node_transforms(rd_scene *s)
{
    for (uint32_t i = 0; i < s->node_count; i++) {
        rd_node *n = &s->nodes[i];
        if (n->mesh < 0) continue;
        rd_mesh *m = &s->meshes[n->mesh];
        const float *w = n->world;
        for (uint32_t v = 0; v < m->tri_count * 3; v++) {
            float *p = &m->positions[v * 3], *nrm = &m->normals[v * 3];
            double q[3];
            for (int k = 0; k < 3; k++)
                q[k] = (double)w[k] * p[0] + (double)w[4 + k] * p[1] + (double)w[8 + k] * p[2] +
                       (double)w[12 + k];
            for (int k = 0; k < 3; k++)
                p[k] = (float)q[k];
            float out[3];
            rd_mat4_transform_normal(w, nrm, out);
            float len = sqrtf(out[0] * out[0] + out[1] * out[1] + out[2] * out[2]);
            for (int k = 0; len > 0 && k < 3; k++)
                nrm[k] = out[k] / len;
        }
        n->has_matrix = false;
        memset(n->translation, 0, sizeof n->translation);
        n->rotation[0] = n->rotation[1] = n->rotation[2] = 0, n->rotation[3] = 1;
        n->scale[0] = n->scale[1] = n->scale[2] = 1;
    }
}

static void build_thick_walls(rd_scene *s)
{
    rd_tri_list t = {0};
    uint32_t white = rd_build_material(s, "white", 0.7f, 0.7f, 0.7f, 0, 0, 0);
    const float lo[3] = {-2, 0, -1}, hi[3] = {2, 2, 1};
    rd_tris_room(&t, lo, hi, white);
    /* a solid 0.6 m wall with a doorway-sized gap at the front */
    const float w_lo[3] = {-0.3f, 0, -1}, w_hi[3] = {0.3f, 2, 0.3f};
    rd_tris_box(&t, w_lo, w_hi, white);
    rd_tris_commit(&t, s, "room");
    rd_build_point_light(s, -1.2f, 1.6f, 0.0f, 15.0f);
    const float eye[3] = {1.8f, 1.2f, 0.8f}, fwd[3] = {-0.9f, -0.15f, -0.4f};
    rd_build_camera(s, eye, fwd, UP_Y, 70);
}

static void build_tiny_emitter(rd_scene *s)
{
    char err[8];
    rd_scene_destroy(s);
    rd_procedural_scene("cornell", s, err, sizeof err);
    for (uint32_t i = 0; i < s->light_count; i++)
        s->lights[i].intensity = 0; /* lights off */
    for (uint32_t i = 0; i < s->material_count; i++)
        if (s->materials[i].name && strcmp(s->materials[i].name, "lamp") == 0)
            s->materials[i].emission[0] = s->materials[i].emission[1] =
                s->materials[i].emission[2] = 0;
    rd_tri_list t = {0};
    uint32_t hot = rd_build_material(s, "hot", 0, 0, 0, 1e5f, 1e5f, 1e5f);
    const float a[3] = {-0.005f, 1.5f, -0.005f}, b[3] = {0.005f, 1.5f, -0.005f},
                c[3] = {0.005f, 1.5f, 0.005f}, d[3] = {-0.005f, 1.5f, 0.005f};
    rd_tris_quad(&t, a, d, c, b, hot); /* faces down */
    rd_tris_commit(&t, s, "tiny-emitter");
}

/* A closed room x, z in [-3, 3], y in [0, 3] (single-sided walls facing inward) with a 1.5 x
 * 1.2 m window in the -z wall and a 20 lux sun shining in through it onto the floor; black sky.
 * The probe rays that find the sunlit patch are few and bright: single probes stay noisy
 * however long they update (issue 28). tests/renderer/test_gpu_converge_sun.c writes it
 * out as glTF. */
static void build_sun_room(rd_scene *s)
{
    rd_tri_list t = {0};
    uint32_t white = rd_build_material(s, "white", 0.7f, 0.7f, 0.7f, 0, 0, 0);
    const float lo[3] = {-3, 0, -3}, hi[3] = {3, 3, 3};
    rd_tris_room_walls(&t, lo, hi, white, RD_WALL_NEG_Z); /* the -z wall below */
    /* the -z wall (faces +z) around the window x in [-0.75, 0.75], y in [1, 2.2] */
    static const float part[4][4] = {
        {-3, -0.75f, 0, 3}, {0.75f, 3, 0, 3}, {-0.75f, 0.75f, 0, 1}, {-0.75f, 0.75f, 2.2f, 3}};
    for (int i = 0; i < 4; i++) {
        const float *r = part[i];
        const float a[3] = {r[0], r[2], -3}, b[3] = {r[1], r[2], -3}, c[3] = {r[1], r[3], -3},
                    d[3] = {r[0], r[3], -3};
        rd_tris_quad(&t, a, b, c, d, white);
    }
    rd_tris_commit(&t, s, "room");
    const float dir[3] = {0.3f, -0.5f, 1.0f}, sun[3] = {1, 0.95f, 0.9f};
    rd_build_sun(s, dir, sun, 20);
    const float eye[3] = {2.5f, 1.6f, 2.6f}, fwd[3] = {-0.55f, -0.35f, -0.75f};
    rd_build_camera(s, eye, fwd, UP_Y, 70);
}

/* The lamp room (tests/bench/lamp_room_gltf.py writes the same room as glTF): the shade is
 * procedural_interior.c's profile, r(u) = 0.22 - 0.1 u - 0.03 sin(pi u), y(u) = 1.3 + 0.3 u,
 * around the light, open at both ends. */
static void build_lamp_room(rd_scene *s)
{
    rd_tri_list t = {0};
    uint32_t white = rd_build_material(s, "white", 0.7f, 0.7f, 0.7f, 0, 0, 0);
    uint32_t shade = rd_build_material(s, "lamp shade", 0.9f, 0.85f, 0.7f, 0, 0, 0);
    s->materials[shade].double_sided = true;
    const float lo[3] = {-2, 0, -2}, hi[3] = {2, 3, 2};
    rd_tris_room_walls(&t, lo, hi, white, RD_WALL_NEG_Z); /* the -z wall below */
    const float a[3] = {lo[0], lo[1], lo[2]}, b[3] = {hi[0], lo[1], lo[2]},
                c[3] = {hi[0], hi[1], lo[2]}, d[3] = {lo[0], hi[1], lo[2]};
    rd_tris_quad(&t, a, b, c, d, white); /* -z wall, faces +z */
    rd_tris_commit(&t, s, "room");
    const float light[3] = {1.2f, 1.45f, 1.2f};
    enum { SEG = 32, RINGS = 10 };
    const float pi = 3.14159265f;
    for (int i = 0; i + 1 < RINGS; i++)
        for (int j = 0; j < SEG; j++) {
            float p[4][3];
            for (int k = 0; k < 4; k++) {
                float u = (float)(i + (k == 2 || k == 3)) / (RINGS - 1);
                float a = 2 * pi * (float)(j + (k == 1 || k == 2)) / SEG;
                float r = 0.22f - 0.1f * u - 0.03f * sinf(pi * u);
                p[k][0] = light[0] + r * cosf(a);
                p[k][1] = 1.3f + 0.3f * u;
                p[k][2] = light[2] + r * sinf(a);
            }
            rd_tris_quad(&t, p[0], p[1], p[2], p[3], shade);
        }
    rd_tris_commit(&t, s, "shade");
    rd_build_point_light(s, light[0], light[1], light[2], 8);
    const float eye[3] = {-1.8f, 1.7f, -1.8f}, fwd[3] = {1, -0.1f, 1};
    rd_build_camera(s, eye, fwd, UP_Y, 70);
}

/* Solid slab walls (outward-facing boxes, 5 cm) of a 4 x 2.5 x 4 m room on a 20 x 20 m terrace;
 * a 1 x 2 m door in the -x wall, the sun on the +x side and the roof: inside, only light that
 * came in through the door (issue 28: probes outside a wall thinner than their spacing leaked
 * the sunlit side into the room). */
static void build_thin_walls(rd_scene *s)
{
    rd_tri_list t = {0};
    uint32_t white = rd_build_material(s, "white", 0.7f, 0.7f, 0.7f, 0, 0, 0);
    uint32_t stone = rd_build_material(s, "terrace", 0.5f, 0.5f, 0.5f, 0, 0, 0);
    static const float slabs[][6] = {
        /* the -x wall around the door z in [-0.5, 0.5], y in [0, 2] */
        {-2 - 0.05f, 0, -2 - 0.05f, -2, 2.5f, -0.5f},
        {-2 - 0.05f, 0, 0.5f, -2, 2.5f, 2 + 0.05f},
        {-2 - 0.05f, 2, -0.5f, -2, 2.5f, 0.5f},
        {2, 0, -2 - 0.05f, 2 + 0.05f, 2.5f, 2 + 0.05f}, /* +x wall, sunlit outside */
        {-2, 0, -2 - 0.05f, 2, 2.5f, -2},               /* -z wall */
        {-2, 0, 2, 2, 2.5f, 2 + 0.05f},                 /* +z wall */
        {-2 - 0.05f, 2.5f, -2 - 0.05f, 2 + 0.05f, 2.5f + 0.05f, 2 + 0.05f}, /* roof */
    };
    for (size_t i = 0; i < sizeof slabs / sizeof slabs[0]; i++)
        rd_tris_box(&t, slabs[i], slabs[i] + 3, white);
    const float ground_lo[3] = {-10, -0.1f, -10}, ground_hi[3] = {10, 0, 10};
    rd_tris_box(&t, ground_lo, ground_hi, stone);
    rd_tris_commit(&t, s, "terrace");
    const float dir[3] = {-1.0f, -1.2f, 0.3f}, sun[3] = {1, 0.95f, 0.9f};
    rd_build_sun(s, dir, sun, 50);
    const float eye[3] = {-1.5f, 1.4f, 1.5f}, fwd[3] = {1.0f, -0.2f, -0.7f};
    rd_build_camera(s, eye, fwd, UP_Y, 70);
}

/* A closed 8 x 3 x 4 m room split at x = 0 by a 1 cm wall that stops 25 cm above the floor; a
 * point light on the -x side, the camera on the +x side, lit only through the gap. */
static void build_narrow_gap(rd_scene *s)
{
    rd_tri_list t = {0};
    uint32_t white = rd_build_material(s, "white", 0.7f, 0.7f, 0.7f, 0, 0, 0);
    const float lo[3] = {-4, 0, -2}, hi[3] = {4, 3, 2};
    rd_tris_room(&t, lo, hi, white);
    const float p_lo[3] = {-0.005f, 0.25f, -2}, p_hi[3] = {0.005f, 3, 2};
    rd_tris_box(&t, p_lo, p_hi, white);
    rd_tris_commit(&t, s, "room");
    rd_build_point_light(s, -2.0f, 1.2f, 0.0f, 40.0f);
    const float eye[3] = {3.7f, 1.6f, 1.7f}, fwd[3] = {-1.0f, -0.45f, -0.45f};
    rd_build_camera(s, eye, fwd, UP_Y, 70);
}

static void build_no_lights(rd_scene *s)
{
    rd_tri_list t = {0};
    uint32_t white = rd_build_material(s, "white", 0.8f, 0.8f, 0.8f, 0, 0, 0);
    const float lo[3] = {-1, 0, -1}, hi[3] = {1, 2, 1};
    rd_tris_room(&t, lo, hi, white);
    const float b_lo[3] = {-0.3f, 0, -0.3f}, b_hi[3] = {0.3f, 0.8f, 0.3f};
    rd_tris_box(&t, b_lo, b_hi, white);
    rd_tris_commit(&t, s, "room");
    const float eye[3] = {0, 1, 0.9f};
    rd_build_camera(s, eye, NEG_Z, UP_Y, 70);
}

static void build_degenerate(rd_scene *s)
{
    char err[8];
    rd_scene_destroy(s);
    rd_procedural_scene("plane-point", s, err, sizeof err);
    rd_tri_list t = {0};
    uint32_t grey = rd_build_material(s, "grey2", 0.5f, 0.5f, 0.5f, 0, 0, 0);
    for (int i = 0; i < 50; i++) {
        float x = -2 + 0.08f * i;
        const float p[3] = {x, 0.5f, 0}, q[3] = {x + 0.1f, 0.5f, 0}, r[3] = {x + 0.2f, 0.5f, 0};
        rd_tris_push(&t, p, q, r, grey); /* collinear: zero area */
        rd_tris_push(&t, p, p, p, grey); /* a point */
    }
    const float a[3] = {1, 0.3f, 1}, b[3] = {1.5f, 0.3f, 1}, c[3] = {1.5f, 0.3f, 0.5f};
    rd_tris_push(&t, a, b, c, grey);
    uint32_t node = rd_tris_commit(&t, s, "degenerate");
    rd_mesh *m = &s->meshes[s->nodes[node].mesh];
    for (uint32_t i = 0; i < m->tri_count * 9; i++)
        m->normals[i] = (i % 2) ? NAN : 0.0f; /* NaN and zero normals */
}

/* The Cornell box's light dimmed and three coloured point lights added around the room, one
 * of them low in a corner: probe hits reach several lights with very different weights, which
 * direct_radiance_sampled picks from. */
static void add_many_lights(rd_scene *s)
{
    for (uint32_t i = 0; i < s->light_count; i++)
        s->lights[i].intensity *= 0.5f;
    const float pos[3][3] = {{-0.7f, 1.2f, 0.5f}, {0.75f, 0.35f, -0.6f}, {0.2f, 1.6f, -0.7f}};
    const float col[3][3] = {{1.0f, 0.45f, 0.2f}, {0.25f, 0.5f, 1.0f}, {0.6f, 1.0f, 0.5f}};
    const float cd[3] = {0.8f, 0.4f, 1.2f};
    for (int k = 0; k < 3; k++) {
        rd_build_point_light(s, pos[k][0], pos[k][1], pos[k][2], cd[k]);
        memcpy(s->lights[s->light_count - 1].color, col[k], sizeof col[k]);
    }
}

static void build_mirrored(rd_scene *s)
{
    char err[8];
    rd_scene_destroy(s);
    rd_procedural_scene("plane-point", s, err, sizeof err);
    s->nodes[0].scale[0] = -1; /* glTF: the winding flips with the determinant */
}

static void pose_moving(rd_scene *s, unsigned frame)
{
    for (uint32_t i = 0; i < s->node_count; i++)
        if (s->nodes[i].name && strcmp(s->nodes[i].name, "sphere") == 0) {
            s->nodes[i].translation[0] = -0.15f * (float)frame;
            s->nodes[i].translation[1] = 0.0f;
        }
}

bool rd_hard_case_pose(const char *name, rd_scene *s, unsigned frame)
{
    if (strcmp(name, "moving") != 0) return false;
    pose_moving(s, frame);
    char err[128];
    rd_scene_update(s, err, sizeof err);
    return true;
}

bool rd_hard_case_build(const char *name, rd_scene *s, char *err, size_t errlen)
{
    const char *base = NULL;
    if (strcmp(name, "cornell") == 0 || strcmp(name, "furnace") == 0 ||
        strcmp(name, "two-rooms") == 0 || strcmp(name, "interior") == 0)
        base = name;
    else if (strcmp(name, "glossy") == 0)
        base = "cornell-glossy";
    else if (strcmp(name, "scaled-100") == 0 || strcmp(name, "scaled-0.01") == 0 ||
             strcmp(name, "far-10km") == 0 || strcmp(name, "far-10km-baked") == 0 ||
             strcmp(name, "moving") == 0 || strcmp(name, "many-lights") == 0)
        base = "cornell";
    if (base) {
        if (!rd_procedural_scene(base, s, err, errlen)) return false;
    } else {
        rd_scene_init(s);
    }
    const float zero[3] = {0, 0, 0}, far[3] = {10000, 0, 10000};
    if (strcmp(name, "scaled-100") == 0)
        transform_scene(s, 100, zero);
    else if (strcmp(name, "scaled-0.01") == 0)
        transform_scene(s, 0.01f, zero);
    else if (strcmp(name, "far-10km") == 0)
        transform_scene(s, 1, far);
    else if (strcmp(name, "far-10km-baked") == 0) {
        transform_scene(s, 100, far);
        if (!rd_scene_update(s, err, errlen)) { /* the node matrices to bake */
            rd_scene_destroy(s);
            return false;
        }
        bake_node_transforms(s);
    } else if (strcmp(name, "thick-walls") == 0)
        build_thick_walls(s);
    else if (strcmp(name, "tiny-emitter") == 0)
        build_tiny_emitter(s);
    else if (strcmp(name, "no-lights") == 0)
        build_no_lights(s);
    else if (strcmp(name, "sun-room") == 0)
        build_sun_room(s);
    else if (strcmp(name, "thin-walls") == 0)
        build_thin_walls(s);
    else if (strcmp(name, "narrow-gap") == 0)
        build_narrow_gap(s);
    else if (strcmp(name, "lamp-room") == 0)
        build_lamp_room(s);
    else if (strcmp(name, "degenerate") == 0)
        build_degenerate(s);
    else if (strcmp(name, "mirrored") == 0)
        build_mirrored(s);
    else if (strcmp(name, "many-lights") == 0)
        add_many_lights(s);
    else if (!base) {
        rd_scene_destroy(s);
        snprintf(err, errlen, "unknown hard case '%s'", name);
        return false;
    }
    if (!rd_scene_update(s, err, errlen)) {
        rd_scene_destroy(s);
        return false;
    }
    return true;
}
