/* skinned_sheet.c: see skinned_sheet.h. */
#include "skinned_sheet.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/scene/deform.h"

void pc_skinned_sheet(rd_mesh *m, uint32_t cols, uint32_t rows)
{
    memset(m, 0, sizeof *m);
    m->tri_count = cols * rows * 2;
    size_t nv = (size_t)m->tri_count * 3, c = 0;
    m->positions = calloc(nv * 3, sizeof(float));
    m->normals = calloc(nv * 3, sizeof(float));
    if (!m->positions || !m->normals) abort();
    for (uint32_t y = 0; y < rows; y++)
        for (uint32_t x = 0; x < cols; x++) {
            const uint32_t q[6][2] = {{x, y}, {x + 1, y},     {x + 1, y + 1},
                                      {x, y}, {x + 1, y + 1}, {x, y + 1}};
            for (int k = 0; k < 6; k++, c++) {
                float px = 2.0f * (float)q[k][0] / (float)cols;
                float py = (float)q[k][1] / (float)rows - 0.5f;
                m->positions[c * 3] = px;
                m->positions[c * 3 + 1] = py;
                m->positions[c * 3 + 2] = 0.1f * sinf(9 * px) * cosf(7 * py);
                m->normals[c * 3 + 2] = 1;
            }
        }
    rd_mesh_deform *d = rd_mesh_deform_create(m, 4, 0, false, false);
    rd_mesh_deform_keep_rest(m);
    for (size_t v = 0; v < nv; v++) {
        float w = (m->positions[v * 3] - 0.7f) / 0.6f;
        w = w < 0 ? 0 : w > 1 ? 1 : w;
        d->joints[v * 4] = 0;
        d->joints[v * 4 + 1] = 1;
        d->weights[v * 4] = 1 - w;
        d->weights[v * 4 + 1] = w;
    }
    d->max_joint = 1;
}
