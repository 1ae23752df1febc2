/* gltf_mesh.c: a glTF mesh's triangle primitives to rd_mesh arrays (see gltf_import.h). */
#include "renderer/gltf/gltf_import.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/scene/xform.h"

size_t rd_gltf_corner_vertex(const rd_gltf_primitive *pr, uint64_t t, int k)
{
    size_t v[3];
    if (pr->mode == RD_GLTF_MODE_TRIANGLES) {
        v[0] = (size_t)t * 3, v[1] = (size_t)t * 3 + 1, v[2] = (size_t)t * 3 + 2;
    } else if (pr->mode == RD_GLTF_MODE_TRIANGLE_STRIP) {
        size_t odd = (size_t)(t % 2);
        v[0] = (size_t)t, v[1] = (size_t)t + 1 + odd, v[2] = (size_t)t + 2 - odd;
    } else { /* fan */
        v[0] = (size_t)t + 1, v[1] = (size_t)t + 2, v[2] = 0;
    }
    return pr->has_idx ? rd_gltf_read_index(&pr->idx, v[k]) : v[k];
}

rd_gltf_result rd_gltf_fill_mesh(size_t mesh, const rd_gltf_primitive *prims, size_t n,
                                 rd_mesh *out, char *err, size_t errlen)
{
    size_t t_out = 0;
    bool any_tan = false;
    for (size_t p = 0; p < n; p++)
        any_tan = any_tan || prims[p].has_tan;
    if (any_tan) { /* zeros where a primitive has none: the renderer derives them */
        out->tangents = calloc((size_t)out->tri_count * 12, sizeof(float));
        if (!out->tangents) {
            fprintf(stderr, "probecast: out of memory (tangents of %u triangles)\n",
                    out->tri_count);
            abort();
        }
    }
    for (size_t p = 0; p < n; p++) {
        const rd_gltf_primitive *pr = &prims[p];
        for (uint64_t t = 0; t < pr->tris; t++, t_out++) {
            for (int k = 0; k < 3; k++) {
                size_t vi = rd_gltf_corner_vertex(pr, t, k);
                if (pr->has_idx && vi >= pr->pos.count)
                    return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                                        "an index of mesh %zu primitive %zu (triangle %llu) is "
                                        "%zu, out of range for %zu vertices",
                                        mesh, p, (unsigned long long)t, vi, pr->pos.count);
                float *pos = &out->positions[t_out * 9 + (size_t)k * 3];
                rd_gltf_read_floats(&pr->pos, vi, pos);
                if (!rd_vec3_isfinite(pos))
                    return rd_gltf_fail(
                        err, errlen, RD_GLTF_ERR_INVALID,
                        "POSITION of mesh %zu primitive %zu contains NaN or infinity (vertex "
                        "%zu)",
                        mesh, p, vi);
                float *nrm = &out->normals[t_out * 9 + (size_t)k * 3];
                if (pr->has_nrm) {
                    float nv[3];
                    rd_gltf_read_floats(&pr->nrm, vi, nv);
                    if (!rd_vec3_normalize(nrm, nv, NULL))
                        rd_vec3_set(nrm, 0, 0, 0); /* filled with the flat normal below */
                }
                if (pr->has_tan) {
                    float *tg = &out->tangents[t_out * 12 + (size_t)k * 4];
                    rd_gltf_read_floats(&pr->tan, vi, tg);
                    if (!rd_vec3_isfinite(tg) || !isfinite(tg[3]))
                        memset(tg, 0, 4 * sizeof(float)); /* derived from the UVs instead */
                }
                float *uv = &out->uvs[t_out * 6 + (size_t)k * 2];
                if (pr->has_uv) {
                    rd_gltf_read_floats(&pr->uv, vi, uv);
                    for (int c = 0; c < 2; c++)
                        if (!isfinite(uv[c])) uv[c] = 0.0f;
                }
            }
            out->material[t_out] = pr->material;
        }
    }
    rd_mesh_fill_flat_normals(out);
    return RD_GLTF_OK;
}
