/* skinned_sheet.h: a bumpy sheet of cols x rows quads along +X in [0, 2], skinned to two joints
 * (the second turning about +Z at x = 1, the weights ramping over x in [0.7, 1.3]): enough
 * triangles for a BVH of several levels, and a large bend for refit quality. Shared by
 * test_gpu_deform and probecast_deformbench. */
#ifndef PC_SKINNED_SHEET_H
#define PC_SKINNED_SHEET_H

#include <stdint.h>

#include "renderer/scene/scene.h"

/* Fills m (unindexed triangles, normals +Z, a deformation with 4 influences a vertex and its
 * rest shape kept); out of memory aborts. Free with rd_mesh_deform_free and free(). */
void pc_skinned_sheet(rd_mesh *m, uint32_t cols, uint32_t rows);

#endif
