#include "renderer/builtin/procedural_interior.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/scene/mesh_builder.h"
#include "renderer/scene/xform.h"

/* ---- floor plan (metres) ----------------------------------------------------------------- */
#define HALF_X 10.0f  /* outer walls at x = +-HALF_X */
#define HALF_Z 6.0f   /* outer walls at z = +-HALF_Z */
#define CORRIDOR 1.0f /* corridor walls at z = +-CORRIDOR */
#define ROOM_W 5.0f   /* four rooms per side along x */
#define HEIGHT 3.0f   /* floor at y = 0, ceiling at HEIGHT */
#define WALL 0.12f    /* wall thickness (centred on the lines above) */
#define SLAB 0.1f     /* floor and ceiling slab thickness */
#define DOOR_TOP 2.1f
#define WIN_LO 0.9f
#define WIN_HI 2.2f
#define MIN_DETAIL 8u

typedef struct opening {
    float a0, a1, y0, y1; /* along the wall, and height */
} opening;

typedef struct ctx {
    rd_scene *s;
    uint32_t detail; /* segments around a curved object; rings scale with it */
    uint64_t rng;
    /* materials */
    uint32_t wall, floor, ceiling, wood, dark_wood, fabric[3], metal, ceramic[3], book[6], shade,
        sofa;
} ctx;

static float rnd(ctx *c)
{
    c->rng ^= c->rng << 13;
    c->rng ^= c->rng >> 7;
    c->rng ^= c->rng << 17;
    return (float)(c->rng >> 40) * (1.0f / 16777216.0f);
}

static float rnd_range(ctx *c, float a, float b)
{
    return a + (b - a) * rnd(c);
}

static uint32_t material(rd_scene *s, const char *name, float r, float g, float b, float metallic,
                         float roughness, bool double_sided)
{
    uint32_t m = rd_build_material(s, name, r, g, b, 0, 0, 0);
    s->materials[m].metallic = metallic;
    s->materials[m].roughness = roughness;
    s->materials[m].specular = 1;
    s->materials[m].double_sided = double_sided;
    return m;
}

static void box(rd_tri_list *t, float x0, float y0, float z0, float x1, float y1, float z1,
                uint32_t mat)
{
    const float lo[3] = {x0, y0, z0}, hi[3] = {x1, y1, z1};
    rd_tris_box(t, lo, hi, mat);
}

/* Surface of revolution about the vertical axis through c: profile points (r[i], y[i]) from
 * bottom to top, `seg` segments around; faces point outward for a profile that runs up the
 * outside (a closed solid starts and ends on the axis). 2 * seg * (n - 1) triangles, less the
 * degenerate ones at r = 0. */
static void lathe(rd_tri_list *t, const float c[3], const float *r, const float *y, unsigned n,
                  unsigned seg, uint32_t mat)
{
    for (unsigned i = 0; i + 1 < n; i++) {
        for (unsigned j = 0; j < seg; j++) {
            float t0 = 2.0f * (float)M_PI * j / seg, t1 = 2.0f * (float)M_PI * (j + 1) / seg;
            float a[3] = {c[0] + r[i] * cosf(t0), c[1] + y[i], c[2] + r[i] * sinf(t0)};
            float b[3] = {c[0] + r[i + 1] * cosf(t0), c[1] + y[i + 1], c[2] + r[i + 1] * sinf(t0)};
            float d[3] = {c[0] + r[i + 1] * cosf(t1), c[1] + y[i + 1], c[2] + r[i + 1] * sinf(t1)};
            float e[3] = {c[0] + r[i] * cosf(t1), c[1] + y[i], c[2] + r[i] * sinf(t1)};
            if (r[i + 1] > 0) rd_tris_push(t, a, b, d, mat);
            if (r[i] > 0) rd_tris_push(t, a, d, e, mat);
        }
    }
}

static void cylinder(rd_tri_list *t, const float c[3], float radius, float h, unsigned seg,
                     uint32_t mat)
{
    const float r[4] = {0, radius, radius, 0}, y[4] = {0, 0, h, h};
    lathe(t, c, r, y, 4, seg, mat);
}

/* Vessels: closed bottom, open top (their materials are double sided). shape picks the
 * profile: 0 vase (bulb and neck), 1 bowl, 2 cup, 3 jar. */
static void vessel(ctx *cx, rd_tri_list *t, const float c[3], float radius, float h, int shape,
                   uint32_t mat)
{
    unsigned rings = cx->detail / 2 + 2, seg = cx->detail;
    float *r = malloc((rings + 1) * sizeof(float)), *y = malloc((rings + 1) * sizeof(float));
    if (!r || !y) abort();
    r[0] = 0, y[0] = 0;
    for (unsigned i = 0; i < rings; i++) {
        float u = (float)i / (float)(rings - 1);
        float k;
        switch (shape) {
        case 0:
            k = 0.55f + 0.45f * sinf((float)M_PI * fminf(u * 1.4f, 1.0f)) + 0.25f * u * u;
            break;
        case 1:
            k = sinf(0.15f + 1.42f * u);
            break;
        case 2:
            k = 0.85f + 0.15f * u;
            break;
        default:
            k = 1.0f - 0.3f * u * u * u * u;
            break;
        }
        r[i + 1] = radius * k;
        y[i + 1] = h * u;
    }
    lathe(t, c, r, y, rings + 1, seg, mat);
    free(r);
    free(y);
}

/* ---- walls --------------------------------------------------------------------------------- */

/* A wall of thickness WALL centred on the line {axis = c}, running from a0 to a1 along the
 * other horizontal axis (along == 0: x, the wall lies at z = c; along == 2: z, at x = c), from
 * floor to ceiling, as boxes around the openings (sorted by a0, inside a0..a1). */
static void wall(rd_tri_list *t, int along, float c, float a0, float a1, const opening *ops,
                 unsigned n, uint32_t mat)
{
    float w0 = c - WALL / 2, w1 = c + WALL / 2;
#define SEG(p0, p1, y0, y1)                                                                        \
    do {                                                                                           \
        if ((p1) > (p0) && (y1) > (y0)) {                                                          \
            if (along == 0)                                                                        \
                box(t, p0, y0, w0, p1, y1, w1, mat);                                               \
            else                                                                                   \
                box(t, w0, y0, p0, w1, y1, p1, mat);                                               \
        }                                                                                          \
    } while (0)
    float at = a0;
    for (unsigned i = 0; i < n; i++) {
        SEG(at, ops[i].a0, 0.0f, HEIGHT);
        SEG(ops[i].a0, ops[i].a1, 0.0f, ops[i].y0);
        SEG(ops[i].a0, ops[i].a1, ops[i].y1, HEIGHT);
        at = ops[i].a1;
    }
    SEG(at, a1, 0.0f, HEIGHT);
#undef SEG
}

static float room_x0(unsigned k)
{
    return -HALF_X + ROOM_W * (float)k;
}

void rd_interior_room_bounds(unsigned i, float lo[3], float hi[3])
{
    unsigned k = i % 4;
    bool north = i >= 4;
    lo[0] = room_x0(k) + WALL / 2, hi[0] = room_x0(k) + ROOM_W - WALL / 2;
    lo[1] = 0, hi[1] = HEIGHT;
    lo[2] = north ? CORRIDOR + WALL / 2 : -HALF_Z + WALL / 2;
    hi[2] = north ? HALF_Z - WALL / 2 : -CORRIDOR - WALL / 2;
}

static void building(ctx *cx)
{
    rd_tri_list t = {0};
    const float e = WALL / 2;
    box(&t, -HALF_X - e, -SLAB, -HALF_Z - e, HALF_X + e, 0, HALF_Z + e, cx->floor);
    box(&t, -HALF_X - e, HEIGHT, -HALF_Z - e, HALF_X + e, HEIGHT + SLAB, HALF_Z + e, cx->ceiling);
    opening win[8], door[4];
    for (unsigned k = 0; k < 4; k++) {
        float xc = room_x0(k) + ROOM_W / 2;
        win[2 * k] = (opening){xc - 1.75f, xc - 0.65f, WIN_LO, WIN_HI};
        win[2 * k + 1] = (opening){xc + 0.65f, xc + 1.75f, WIN_LO, WIN_HI};
        door[k] = (opening){xc + 0.8f, xc + 1.7f, 0, DOOR_TOP};
    }
    for (int side = -1; side <= 1; side += 2) {
        wall(&t, 0, side * HALF_Z, -HALF_X - e, HALF_X + e, win, 8, cx->wall); /* outer */
        wall(&t, 0, side * CORRIDOR, -HALF_X, HALF_X, door, 4, cx->wall);      /* corridor */
        const opening end = {-0.5f, 0.5f, WIN_LO, WIN_HI};                     /* corridor end */
        wall(&t, 2, side * HALF_X, -HALF_Z, HALF_Z, &end, 1, cx->wall);
        for (unsigned k = 1; k < 4; k++) { /* partitions between rooms */
            float z0 = side < 0 ? -HALF_Z : CORRIDOR, z1 = side < 0 ? -CORRIDOR : HALF_Z;
            wall(&t, 2, room_x0(k), z0, z1, NULL, 0, cx->wall);
        }
    }
    rd_tris_commit(&t, cx->s, "building");
}

/* ---- furniture (object space: standing on y = 0, centred on x = z = 0, front toward +z) --- */

typedef struct placed {
    uint32_t mesh, root;
    bool used;
} placed;

static placed commit(rd_tri_list *t, rd_scene *s, const char *name)
{
    uint32_t node = rd_tris_commit(t, s, name);
    return (placed){(uint32_t)s->nodes[node].mesh, node, false};
}

/* Places an instance of p at (x, 0, z) turned by yaw about +y (the first use moves the node
 * that rd_tris_commit made; later ones add nodes sharing the mesh). */
static void place(rd_scene *s, placed *p, float x, float z, float yaw)
{
    rd_node n = {.name = s->nodes[p->root].name,
                 .parent = -1,
                 .mesh = (int32_t)p->mesh,
                 .translation = {x, 0, z},
                 .rotation = {0, sinf(yaw / 2), 0, cosf(yaw / 2)},
                 .scale = {1, 1, 1}};
    if (!p->used) {
        rd_node *r = &s->nodes[p->root];
        memcpy(r->translation, n.translation, sizeof n.translation);
        memcpy(r->rotation, n.rotation, sizeof n.rotation);
        p->used = true;
    } else {
        rd_scene_add_node(s, &n);
    }
}

static unsigned small_seg(const ctx *cx)
{
    return cx->detail / 4 < 6 ? 6 : cx->detail / 4;
}

static placed make_chair(ctx *cx, uint32_t fabric)
{
    rd_tri_list t = {0};
    for (int i = 0; i < 4; i++) {
        const float c[3] = {i & 1 ? 0.19f : -0.19f, 0, i & 2 ? 0.19f : -0.19f};
        cylinder(&t, c, 0.02f, 0.44f, small_seg(cx), cx->wood);
    }
    box(&t, -0.23f, 0.44f, -0.23f, 0.23f, 0.49f, 0.23f, fabric);
    box(&t, -0.23f, 0.49f, -0.23f, -0.19f, 0.95f, -0.19f, cx->wood);
    box(&t, 0.19f, 0.49f, -0.23f, 0.23f, 0.95f, -0.19f, cx->wood);
    for (int k = 0; k < 3; k++)
        box(&t, -0.19f, 0.62f + 0.11f * k, -0.225f, 0.19f, 0.68f + 0.11f * k, -0.195f, cx->wood);
    return commit(&t, cx->s, "chair");
}

static placed make_table_set(ctx *cx)
{
    rd_tri_list t = {0};
    for (int i = 0; i < 4; i++) {
        const float c[3] = {i & 1 ? 0.72f : -0.72f, 0, i & 2 ? 0.38f : -0.38f};
        cylinder(&t, c, 0.035f, 0.72f, small_seg(cx), cx->dark_wood);
    }
    box(&t, -0.8f, 0.72f, -0.45f, 0.8f, 0.77f, 0.45f, cx->dark_wood);
    for (int k = 0; k < 4; k++) { /* a place setting at each chair: plate and cup */
        float x = k & 1 ? 0.4f : -0.4f, z = k & 2 ? 0.25f : -0.25f;
        const float p[3] = {x, 0.77f, z};
        vessel(cx, &t, p, 0.12f, 0.02f, 1, cx->ceramic[0]);
        const float q[3] = {x + 0.14f, 0.77f, z * 0.5f};
        vessel(cx, &t, q, 0.04f, 0.09f, 2, cx->ceramic[k % 3]);
    }
    const float b[3] = {0, 0.77f, 0};
    vessel(cx, &t, b, 0.16f, 0.09f, 1, cx->ceramic[2]);
    for (int k = 0; k < 5; k++) { /* fruit in the bowl */
        const float f[3] = {0.06f * cosf(1.3f * k), 0.83f + 0.02f * (k % 2),
                            0.06f * sinf(1.3f * k)};
        rd_tris_sphere(&t, f, 0.04f, cx->detail / 4 + 3, cx->detail / 2, cx->fabric[k % 3]);
    }
    return commit(&t, cx->s, "table set");
}

/* A 1.2 m wide, 2 m tall bookcase, back at z = 0, filled from a seeded random stream. */
static placed make_shelf(ctx *cx, uint64_t seed)
{
    rd_tri_list t = {0};
    cx->rng = seed;
    const float w = 0.6f, d = 0.34f, h = 2.0f;
    box(&t, -w, 0, 0, -w + 0.03f, h, d, cx->wood);
    box(&t, w - 0.03f, 0, 0, w, h, d, cx->wood);
    box(&t, -w, 0, 0, w, h, 0.015f, cx->wood);
    for (int k = 0; k < 5; k++)
        box(&t, -w + 0.03f, 0.05f + 0.48f * k, 0.015f, w - 0.03f, 0.08f + 0.48f * k, d, cx->wood);
    for (int k = 0; k < 4; k++) { /* items on the four lower boards */
        float y = 0.08f + 0.48f * k, x = -w + 0.04f;
        while (x < w - 0.1f) {
            float pick = rnd(cx);
            if (pick < 0.8f) { /* a run of books */
                unsigned n = 3 + (unsigned)(rnd(cx) * 10);
                for (unsigned b = 0; b < n && x < w - 0.06f; b++) {
                    float bw = rnd_range(cx, 0.018f, 0.05f), bh = rnd_range(cx, 0.18f, 0.36f);
                    float bd = rnd_range(cx, 0.15f, 0.25f);
                    box(&t, x, y, d - bd - 0.01f, x + bw, y + bh, d - 0.01f,
                        cx->book[(unsigned)(rnd(cx) * 6) % 6]);
                    x += bw + 0.002f;
                }
            } else { /* a vessel or a ball */
                float rad = rnd_range(cx, 0.04f, 0.08f);
                if (x + 2 * rad > w - 0.04f) break;
                const float c[3] = {x + rad, y, 0.18f};
                int shape = (int)(rnd(cx) * 5);
                if (shape == 4) {
                    const float sc[3] = {c[0], y + rad, c[2]};
                    rd_tris_sphere(&t, sc, rad, cx->detail / 2 + 2, cx->detail, cx->ceramic[1]);
                } else {
                    vessel(cx, &t, c, rad, rnd_range(cx, 0.1f, 0.3f), shape,
                           cx->ceramic[(unsigned)shape % 3]);
                }
                x += 2 * rad + 0.01f;
            }
        }
    }
    return commit(&t, cx->s, "shelf");
}

static placed make_sofa(ctx *cx)
{
    rd_tri_list t = {0};
    box(&t, -0.95f, 0.05f, -0.45f, 0.95f, 0.42f, 0.45f, cx->sofa);
    box(&t, -0.95f, 0.42f, -0.45f, 0.95f, 0.85f, -0.25f, cx->sofa);
    box(&t, -1.1f, 0.05f, -0.45f, -0.95f, 0.62f, 0.45f, cx->sofa);
    box(&t, 0.95f, 0.05f, -0.45f, 1.1f, 0.62f, 0.45f, cx->sofa);
    for (int k = 0; k < 3; k++) /* seat cushions */
        box(&t, -0.93f + 0.62f * k, 0.42f, -0.24f, -0.33f + 0.62f * k, 0.52f, 0.43f, cx->fabric[1]);
    for (int i = 0; i < 4; i++) {
        const float c[3] = {i & 1 ? 1.0f : -1.0f, 0, i & 2 ? 0.38f : -0.38f};
        cylinder(&t, c, 0.025f, 0.05f, small_seg(cx), cx->metal);
    }
    return commit(&t, cx->s, "sofa");
}

#define LAMP_LIGHT_Y 1.45f /* the lamp's light, inside the open shade */

static placed make_lamp(ctx *cx)
{
    rd_tri_list t = {0};
    const float o[3] = {0, 0, 0};
    const float br[4] = {0, 0.18f, 0.16f, 0}, by[4] = {0, 0, 0.03f, 0.03f};
    lathe(&t, o, br, by, 4, cx->detail, cx->metal);
    cylinder(&t, o, 0.015f, 1.35f, small_seg(cx), cx->metal);
    unsigned rings = cx->detail + 2;
    float *r = malloc(rings * sizeof(float)), *y = malloc(rings * sizeof(float));
    if (!r || !y) abort();
    for (unsigned i = 0; i < rings; i++) { /* a flared, slightly curved open shade */
        float u = (float)i / (float)(rings - 1);
        r[i] = 0.22f - 0.1f * u - 0.03f * sinf((float)M_PI * u);
        y[i] = 1.3f + 0.3f * u;
    }
    lathe(&t, o, r, y, rings, cx->detail * 2, cx->shade);
    free(r);
    free(y);
    return commit(&t, cx->s, "lamp");
}

/* ---- the whole scene ------------------------------------------------------------------------ */

static void build(rd_scene *s, uint32_t detail)
{
    ctx cx = {.s = s, .detail = detail, .rng = 0x9E3779B97F4A7C15ull};
    cx.wall = material(s, "plaster", 0.78f, 0.76f, 0.72f, 0, 0.9f, false);
    cx.floor = material(s, "oak floor", 0.42f, 0.28f, 0.16f, 0, 0.45f, false);
    cx.ceiling = material(s, "ceiling", 0.85f, 0.85f, 0.85f, 0, 1.0f, false);
    cx.wood = material(s, "pine", 0.62f, 0.45f, 0.28f, 0, 0.6f, false);
    cx.dark_wood = material(s, "walnut", 0.25f, 0.14f, 0.08f, 0, 0.35f, false);
    cx.fabric[0] = material(s, "red fabric", 0.55f, 0.1f, 0.08f, 0, 1.0f, false);
    cx.fabric[1] = material(s, "blue fabric", 0.12f, 0.2f, 0.45f, 0, 1.0f, false);
    cx.fabric[2] = material(s, "green fabric", 0.2f, 0.4f, 0.15f, 0, 1.0f, false);
    cx.metal = material(s, "brass", 0.9f, 0.7f, 0.35f, 1, 0.3f, false);
    cx.ceramic[0] = material(s, "white ceramic", 0.9f, 0.9f, 0.88f, 0, 0.15f, true);
    cx.ceramic[1] = material(s, "teal ceramic", 0.1f, 0.45f, 0.5f, 0, 0.2f, true);
    cx.ceramic[2] = material(s, "ochre ceramic", 0.75f, 0.5f, 0.15f, 0, 0.25f, true);
    static const float book_rgb[6][3] = {{0.5f, 0.08f, 0.06f}, {0.08f, 0.15f, 0.4f},
                                         {0.1f, 0.3f, 0.12f},  {0.7f, 0.6f, 0.4f},
                                         {0.15f, 0.12f, 0.1f}, {0.6f, 0.3f, 0.05f}};
    for (int i = 0; i < 6; i++)
        cx.book[i] =
            material(s, "book", book_rgb[i][0], book_rgb[i][1], book_rgb[i][2], 0, 0.7f, false);
    cx.shade = rd_build_material(s, "lamp shade", 0.9f, 0.85f, 0.7f, 1.5f, 1.2f, 0.8f);
    s->materials[cx.shade].double_sided = true;
    cx.sofa = material(s, "sofa", 0.35f, 0.3f, 0.26f, 0, 1.0f, false);

    building(&cx);
    placed chair[3] = {make_chair(&cx, cx.fabric[0]), make_chair(&cx, cx.fabric[1]),
                       make_chair(&cx, cx.fabric[2])};
    placed table[2] = {make_table_set(&cx), make_table_set(&cx)};
    placed shelf[4];
    for (unsigned v = 0; v < 4; v++)
        shelf[v] = make_shelf(&cx, 0x5DEECE66Dull * (v + 1) + 11);
    placed sofa = make_sofa(&cx), lamp = make_lamp(&cx);

    for (unsigned i = 0; i < RD_INTERIOR_ROOMS; i++) {
        float lo[3], hi[3];
        rd_interior_room_bounds(i, lo, hi);
        bool north = i >= 4;
        float cx0 = (lo[0] + hi[0]) / 2, cz = (lo[2] + hi[2]) / 2;
        float tx = cx0 - 0.6f, tz = cz + (north ? 0.3f : -0.3f);
        place(s, &table[i % 2], tx, tz, 0);
        for (int k = 0; k < 4; k++) { /* two chairs along each long side, facing the table */
            float x = tx + (k & 1 ? 0.4f : -0.4f), z = tz + (k & 2 ? 0.65f : -0.65f);
            place(s, &chair[(i + (unsigned)k) % 3], x, z, k & 2 ? (float)M_PI : 0.0f);
        }
        /* bookcases against the partition walls (their backs at z = 0 face the wall) */
        place(s, &shelf[i % 4], lo[0] + 0.02f, cz, (float)M_PI / 2);
        place(s, &shelf[(i + 1) % 4], hi[0] - 0.02f, cz - 0.9f, -(float)M_PI / 2);
        place(s, &shelf[(i + 2) % 4], hi[0] - 0.02f, cz + 0.9f, -(float)M_PI / 2);
        /* sofa against the outer wall, lamp in the corner next to it */
        float wall_z = north ? hi[2] - 0.5f : lo[2] + 0.5f;
        place(s, &sofa, cx0 + 0.2f, wall_z, north ? (float)M_PI : 0.0f);
        float lx = hi[0] - 0.35f, lz = north ? hi[2] - 0.35f : lo[2] + 0.35f;
        place(s, &lamp, lx, lz, 0);
        rd_build_point_light(s, lx, LAMP_LIGHT_Y, lz, 8.0f);
    }
    for (int k = -1; k <= 1; k += 2) /* corridor ceiling lights */
        rd_build_point_light(s, 5.0f * k, HEIGHT - 0.25f, 0, 8.0f);
    float sun[3];
    const float sun_dir[3] = {0.25f, -0.45f, 0.85f}; /* low, through the south windows */
    const float sun_color[3] = {1, 0.93f, 0.82f};
    rd_vec3_normalize(sun, sun_dir, NULL);
    rd_build_sun(s, sun, sun_color, 15.0f);

    /* camera 0: a south room seen from its window corner, the door to the corridor in view;
     * camera 1: down the corridor */
    const float up[3] = {0, 1, 0};
    float fwd[3];
    const float eye[3] = {-4.6f, 1.65f, -5.6f}, look[3] = {4.2f, -0.8f, 4.3f};
    rd_vec3_normalize(fwd, look, NULL);
    rd_build_camera(s, eye, fwd, up, 65);
    const float eye1[3] = {-9.6f, 1.6f, 0.0f}, fwd1[3] = {1, 0, 0};
    rd_build_camera(s, eye1, fwd1, up, 60);
}

static uint64_t tris_over_instances(const rd_scene *s)
{
    uint64_t n = 0;
    for (uint32_t i = 0; i < s->node_count; i++)
        if (s->nodes[i].mesh >= 0) n += s->meshes[s->nodes[i].mesh].tri_count;
    return n;
}

static uint64_t count_at(uint32_t detail)
{
    rd_scene tmp;
    rd_scene_init(&tmp);
    build(&tmp, detail);
    uint64_t n = tris_over_instances(&tmp);
    rd_scene_destroy(&tmp);
    return n;
}

bool rd_interior_build(rd_scene *s, double millions, char *err, size_t errlen)
{
    if (!(millions > 0 && millions <= 100)) {
        snprintf(err, errlen, "interior: %g million triangles is outside 0 < M <= 100", millions);
        return false;
    }
    /* Curved objects carry nearly all triangles, about quadratic in the detail: fit
     * flat + a * detail^2 from two small builds and solve for the target. */
    double n8 = (double)count_at(MIN_DETAIL), n32 = (double)count_at(4 * MIN_DETAIL);
    double a = (n32 - n8) / (16.0 * MIN_DETAIL * MIN_DETAIL - MIN_DETAIL * MIN_DETAIL);
    double flat = n8 - a * MIN_DETAIL * MIN_DETAIL, target = millions * 1e6;
    double d = target > n8 ? sqrt((target - flat) / a) : MIN_DETAIL;
    build(s, d > 4096 ? 4096u : (uint32_t)lround(d));
    return true;
}
