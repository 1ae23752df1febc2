/* procedural_interior.h: builtin:interior[:M], a furnished one-storey building for benchmarks
 * (a realistic interior next to the spheres: thin walls, small objects, many instances).
 *
 * Floor plan: a corridor along x with four rooms on each side (RD_INTERIOR_ROOMS in all);
 * every room has a door to the corridor and two windows in the outer wall, the corridor has a
 * window at each end. Rooms hold a table set with dishes, chairs, shelves full of books and
 * vases, a sofa and a floor lamp (instanced meshes; the shelves and table sets come in
 * variants). Lights: a point light in each lamp and a low sun through the south windows.
 * Deterministic: the same M gives the same scene.
 */
#ifndef RD_PROCEDURAL_INTERIOR_H
#define RD_PROCEDURAL_INTERIOR_H

#include <stdbool.h>
#include <stddef.h>

#include "renderer/scene/scene.h"

#define RD_INTERIOR_ROOMS 8
#define RD_INTERIOR_DEFAULT_MILLIONS 2.5

/* Builds the interior with about `millions` million triangles over all instances (curved
 * objects are tessellated to reach it; at least about 0.05 million) into s (initialised by the
 * caller; rd_scene_update is left to the caller). Returns false with a message when millions
 * is out of 0 < M <= 100. */
bool rd_interior_build(rd_scene *s, double millions, char *err, size_t errlen);

/* Inner bounds (the air between walls, floor and ceiling) of room i < RD_INTERIOR_ROOMS:
 * rooms 0-3 lie south of the corridor (z < 0), 4-7 north, west to east. */
void rd_interior_room_bounds(unsigned i, float lo[3], float hi[3]);

#endif
