/* mesh_builder.c: see mesh_builder.h. */
#include "renderer/scene/mesh_builder.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void rd_tris_push(rd_tri_list *t, const float a[3], const float b[3], const float c[3],
                  uint32_t mat)
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
void rd_tris_quad(rd_tri_list *t, const float a[3], const float b[3], const float c[3],
                  const float d[3], uint32_t mat)
{
    rd_tris_push(t, a, b, c, mat);
    rd_tris_push(t, a, c, d, mat);
}

/* Axis-aligned box with outward-facing triangles. */
void rd_tris_box(rd_tri_list *t, const float lo[3], const float hi[3], uint32_t mat)
{
    float v[8][3];
    for (int i = 0; i < 8; i++) {
        v[i][0] = (i & 1) ? hi[0] : lo[0];
        v[i][1] = (i & 2) ? hi[1] : lo[1];
        v[i][2] = (i & 4) ? hi[2] : lo[2];
    }
    rd_tris_quad(t, v[0], v[4], v[6], v[2], mat); /* -x */
    rd_tris_quad(t, v[1], v[3], v[7], v[5], mat); /* +x */
    rd_tris_quad(t, v[0], v[1], v[5], v[4], mat); /* -y */
    rd_tris_quad(t, v[2], v[6], v[7], v[3], mat); /* +y */
    rd_tris_quad(t, v[0], v[2], v[3], v[1], mat); /* -z */
    rd_tris_quad(t, v[4], v[5], v[7], v[6], mat); /* +z */
}

/* UV sphere with outward-facing triangles: 2 * seg * (rings - 1) triangles. */
void rd_tris_sphere(rd_tri_list *t, const float c[3], float r, uint32_t rings, uint32_t seg,
                    uint32_t mat)
{
    for (uint32_t i = 0; i < rings; i++) {
        float t0 = (float)M_PI * i / rings, t1 = (float)M_PI * (i + 1) / rings;
        for (uint32_t j = 0; j < seg; j++) {
            float p0 = 2.0f * (float)M_PI * j / seg, p1 = 2.0f * (float)M_PI * (j + 1) / seg;
            float a[3] = {c[0] + r * sinf(t0) * cosf(p0), c[1] + r * cosf(t0),
                          c[2] + r * sinf(t0) * sinf(p0)};
            float b[3] = {c[0] + r * sinf(t1) * cosf(p0), c[1] + r * cosf(t1),
                          c[2] + r * sinf(t1) * sinf(p0)};
            float d[3] = {c[0] + r * sinf(t1) * cosf(p1), c[1] + r * cosf(t1),
                          c[2] + r * sinf(t1) * sinf(p1)};
            float e[3] = {c[0] + r * sinf(t0) * cosf(p1), c[1] + r * cosf(t0),
                          c[2] + r * sinf(t0) * sinf(p1)};
            if (i != 0) rd_tris_push(t, a, e, d, mat);
            if (i != rings - 1) rd_tris_push(t, a, d, b, mat);
        }
    }
}

/* Moves the list into a new mesh (flat normals, zero UVs) placed by a new root node. */
uint32_t rd_tris_commit(rd_tri_list *t, rd_scene *s, const char *name)
{
    uint32_t m = rd_scene_add_mesh(s, name, t->count);
    rd_mesh *mesh = &s->meshes[m];
    memcpy(mesh->positions, t->pos, sizeof(float) * 9 * t->count);
    memcpy(mesh->material, t->mat, sizeof(uint32_t) * t->count);
    rd_mesh_fill_flat_normals(mesh);
    free(t->pos);
    free(t->mat);
    memset(t, 0, sizeof *t);
    rd_node node = {.name = (char *)name,
                    .parent = -1,
                    .mesh = (int32_t)m,
                    .rotation = {0, 0, 0, 1},
                    .scale = {1, 1, 1}};
    return rd_scene_add_node(s, &node);
}

/* Inward-facing box (a closed room seen from inside). */
void rd_tris_room(rd_tri_list *t, const float lo[3], const float hi[3], uint32_t mat)
{
    rd_tris_room_walls(t, lo, hi, mat, 0);
}

void rd_tris_room_walls(rd_tri_list *t, const float lo[3], const float hi[3], uint32_t mat,
                        unsigned omit)
{
    float v[8][3];
    for (int i = 0; i < 8; i++) {
        v[i][0] = (i & 1) ? hi[0] : lo[0];
        v[i][1] = (i & 2) ? hi[1] : lo[1];
        v[i][2] = (i & 4) ? hi[2] : lo[2];
    }
    static const struct {
        unsigned bit, c[4];
    } walls[6] = {
        {RD_WALL_NEG_X, {0, 2, 6, 4}},   /* faces +x */
        {RD_WALL_POS_X, {1, 5, 7, 3}},   /* faces -x */
        {RD_WALL_FLOOR, {0, 4, 5, 1}},   /* faces +y */
        {RD_WALL_CEILING, {2, 3, 7, 6}}, /* faces -y */
        {RD_WALL_NEG_Z, {0, 1, 3, 2}},   /* faces +z */
        {RD_WALL_POS_Z, {4, 6, 7, 5}},   /* faces -z */
    };
    for (int w = 0; w < 6; w++)
        if (!(omit & walls[w].bit))
            rd_tris_quad(t, v[walls[w].c[0]], v[walls[w].c[1]], v[walls[w].c[2]], v[walls[w].c[3]],
                         mat);
}

uint32_t rd_build_material(rd_scene *s, const char *name, float r, float g, float b, float er,
                           float eg, float eb)
{
    rd_material m = rd_material_default();
    m.name = (char *)name;
    m.base_color[0] = r, m.base_color[1] = g, m.base_color[2] = b;
    m.emission[0] = er, m.emission[1] = eg, m.emission[2] = eb;
    return rd_scene_add_material(s, &m);
}

void rd_build_point_light(rd_scene *s, float x, float y, float z, float cd)
{
    rd_light l = {.name = "light",
                  .type = RD_LIGHT_POINT,
                  .color = {1, 1, 1},
                  .intensity = cd,
                  .node = -1,
                  .position = {x, y, z},
                  .direction = {0, -1, 0}};
    rd_scene_add_light(s, &l);
}

void rd_build_sun(rd_scene *s, const float dir[3], const float color[3], float lux)
{
    rd_light l = {.name = "sun", .type = RD_LIGHT_DIRECTIONAL, .intensity = lux, .node = -1};
    memcpy(l.color, color, sizeof l.color);
    memcpy(l.direction, dir, sizeof l.direction);
    rd_scene_add_light(s, &l);
}

void rd_build_camera(rd_scene *s, const float eye[3], const float fwd[3], const float up[3],
                     float yfov_deg)
{
    rd_camera c = {
        .name = "camera", .yfov = yfov_deg * (float)M_PI / 180.0f, .znear = 0.01f, .node = -1};
    memcpy(c.position, eye, 12), memcpy(c.forward, fwd, 12), memcpy(c.up, up, 12);
    rd_scene_add_camera(s, &c);
}
