/* mesh_builder.h: small helpers that generate scenes by code (procedural scenes, hard cases,
 * tests): a growable triangle list with quads, boxes, rooms and spheres, committed as one
 * mesh placed by a new root node, plus one-line materials, lights and cameras. */
#ifndef RD_MESH_BUILDER_H
#define RD_MESH_BUILDER_H

#include <stdint.h>

#include "renderer/scene/scene.h"

typedef struct rd_tri_list {
    float *pos; /* 9 per triangle */
    uint32_t *mat;
    uint32_t count, cap;
} rd_tri_list;

void rd_tris_push(rd_tri_list *t, const float a[3], const float b[3], const float c[3],
                  uint32_t mat);
/* Quad a-b-c-d, counter-clockwise seen from its front. */
void rd_tris_quad(rd_tri_list *t, const float a[3], const float b[3], const float c[3],
                  const float d[3], uint32_t mat);
/* Axis-aligned box with outward-facing triangles. */
void rd_tris_box(rd_tri_list *t, const float lo[3], const float hi[3], uint32_t mat);
/* Axis-aligned box with inward-facing triangles (a closed room seen from inside). */
void rd_tris_room(rd_tri_list *t, const float lo[3], const float hi[3], uint32_t mat);
/* The walls of rd_tris_room, in its order, but those whose bits are set in omit (a room whose
 * wall has an opening, built by the caller). */
enum {
    RD_WALL_NEG_X = 1,
    RD_WALL_POS_X = 2,
    RD_WALL_FLOOR = 4,
    RD_WALL_CEILING = 8,
    RD_WALL_NEG_Z = 16,
    RD_WALL_POS_Z = 32
};
void rd_tris_room_walls(rd_tri_list *t, const float lo[3], const float hi[3], uint32_t mat,
                        unsigned omit);
/* UV sphere with outward-facing triangles: 2 * seg * (rings - 1) triangles. */
void rd_tris_sphere(rd_tri_list *t, const float c[3], float r, uint32_t rings, uint32_t seg,
                    uint32_t mat);
/* Moves the list into a new mesh (flat normals, zero UVs) placed by a new root node at the
 * origin; returns the node index. The list is left empty. */
uint32_t rd_tris_commit(rd_tri_list *t, rd_scene *s, const char *name);

uint32_t rd_build_material(rd_scene *s, const char *name, float r, float g, float b, float er,
                           float eg, float eb);
void rd_build_point_light(rd_scene *s, float x, float y, float z, float cd);
/* A directional light named "sun" shining toward dir (any length) with illuminance lux. */
void rd_build_sun(rd_scene *s, const float dir[3], const float color[3], float lux);
void rd_build_camera(rd_scene *s, const float eye[3], const float fwd[3], const float up[3],
                     float yfov_deg);

#endif
