/* deform.c: morph targets and skins applied on the CPU (see deform.h). */
#include "renderer/scene/deform.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/scene/xform.h"

static void *zalloc(size_t n, size_t size)
{
    void *p = calloc(n ? n : 1, size ? size : 1);
    if (!p) {
        fprintf(stderr, "probecast: out of memory (%zu x %zu bytes of deformation)\n", n, size);
        abort();
    }
    return p;
}

rd_mesh_deform *rd_mesh_deform_create(rd_mesh *m, uint32_t influences, uint32_t target_count,
                                      bool target_normals, bool target_tangents)
{
    rd_mesh_deform_free(m->deform);
    rd_mesh_deform *d = zalloc(1, sizeof *d);
    size_t nv = (size_t)m->tri_count * 3;
    d->vertex_count = (uint32_t)nv;
    d->rest_positions = zalloc(nv * 3, sizeof(float));
    d->rest_normals = zalloc(nv * 3, sizeof(float));
    if (m->tangents) d->rest_tangents = zalloc(nv * 4, sizeof(float));
    d->influences = influences;
    if (influences) {
        d->joints = zalloc(nv * influences, sizeof *d->joints);
        d->weights = zalloc(nv * influences, sizeof *d->weights);
    }
    d->target_count = target_count;
    if (target_count) {
        d->target_positions = zalloc(nv * 3 * target_count, sizeof(float));
        if (target_normals) d->target_normals = zalloc(nv * 3 * target_count, sizeof(float));
        if (target_tangents && m->tangents)
            d->target_tangents = zalloc(nv * 3 * target_count, sizeof(float));
        d->default_weights = zalloc(target_count, sizeof(float));
    }
    m->deform = d;
    return d;
}

void rd_mesh_deform_keep_rest(rd_mesh *m)
{
    rd_mesh_deform *d = m->deform;
    if (!d) return;
    size_t nv = d->vertex_count;
    memcpy(d->rest_positions, m->positions, nv * 3 * sizeof(float));
    memcpy(d->rest_normals, m->normals, nv * 3 * sizeof(float));
    if (d->rest_tangents && m->tangents)
        memcpy(d->rest_tangents, m->tangents, nv * 4 * sizeof(float));
}

void rd_mesh_deform_free(rd_mesh_deform *d)
{
    if (!d) return;
    free(d->rest_positions);
    free(d->rest_normals);
    free(d->rest_tangents);
    free(d->joints);
    free(d->weights);
    free(d->target_positions);
    free(d->target_normals);
    free(d->target_tangents);
    free(d->default_weights);
    free(d->posed);
    free(d);
}

void rd_skin_joint_matrices(const rd_scene *s, const rd_skin *k, uint32_t node, float *out)
{
    float to_mesh[16];
    if (node >= s->node_count || !rd_mat4_inverse(to_mesh, s->nodes[node].world))
        rd_mat4_identity(to_mesh);
    for (uint32_t j = 0; j < k->joint_count; j++) {
        float m[16];
        if (k->joints[j] < s->node_count)
            rd_mat4_mul(m, s->nodes[k->joints[j]].world, &k->inverse_bind[16 * j]);
        else
            memcpy(m, &k->inverse_bind[16 * j], sizeof m);
        rd_mat4_mul(&out[16 * j], to_mesh, m);
    }
}

/* The weighted sum of vertex v's joint matrices into m; false when no influence counts. */
static bool skin_matrix(const rd_mesh_deform *d, size_t v, const float *joint_mats,
                        uint32_t joint_count, float m[16])
{
    memset(m, 0, 16 * sizeof(float));
    bool any = false;
    for (uint32_t k = 0; k < d->influences; k++) {
        float w = d->weights[v * d->influences + k];
        uint32_t j = d->joints[v * d->influences + k];
        if (!(w != 0.0f) || j >= joint_count) continue;
        const float *jm = &joint_mats[16 * (size_t)j];
        for (int e = 0; e < 16; e++)
            m[e] += w * jm[e];
        any = true;
    }
    return any;
}

void rd_mesh_deform_apply(rd_mesh *mesh, const float *weights, uint32_t weight_count,
                          const float *joint_mats, uint32_t joint_count)
{
    const rd_mesh_deform *d = mesh->deform;
    if (!d) return;
    size_t nv = d->vertex_count;
    uint32_t nt = d->target_count;
    const float *w = weight_count == nt && weights ? weights : d->default_weights;
    bool skinned = joint_mats && d->influences > 0;
    for (size_t v = 0; v < nv; v++) {
        float p[3], n[3], t[4] = {0, 0, 0, 0};
        memcpy(p, &d->rest_positions[v * 3], sizeof p);
        memcpy(n, &d->rest_normals[v * 3], sizeof n);
        if (d->rest_tangents) memcpy(t, &d->rest_tangents[v * 4], sizeof t);
        for (uint32_t ti = 0; ti < nt; ti++) {
            float wt = w[ti];
            if (wt == 0.0f) continue;
            size_t at = ((size_t)ti * nv + v) * 3;
            for (int k = 0; k < 3; k++) {
                p[k] += wt * d->target_positions[at + k];
                if (d->target_normals) n[k] += wt * d->target_normals[at + k];
                if (d->target_tangents) t[k] += wt * d->target_tangents[at + k];
            }
        }
        float m[16];
        if (skinned && skin_matrix(d, v, joint_mats, joint_count, m)) {
            m[15] = 1.0f;
            rd_mat4_transform_point(m, p, p);
            rd_mat4_transform_normal(m, n, n);
            rd_mat4_transform_dir(m, t, t);
        }
        float *op = &mesh->positions[v * 3], *on = &mesh->normals[v * 3];
        if (rd_vec3_isfinite(p))
            memcpy(op, p, sizeof p);
        else
            memcpy(op, &d->rest_positions[v * 3], sizeof p);
        if (!rd_vec3_normalize(on, n, NULL)) memcpy(on, &d->rest_normals[v * 3], sizeof n);
        if (d->rest_tangents && mesh->tangents) {
            float *ot = &mesh->tangents[v * 4];
            if (rd_vec3_normalize(ot, t, NULL))
                ot[3] = t[3];
            else
                memcpy(ot, &d->rest_tangents[v * 4], 4 * sizeof(float));
        }
    }
}

void rd_scene_deform(rd_scene *s)
{
    float *inputs = NULL;
    size_t cap = 0;
    for (uint32_t i = 0; i < s->instance_count; i++) {
        uint32_t node = s->instances[i].node, mi = s->instances[i].mesh;
        if (node >= s->node_count || mi >= s->mesh_count) continue;
        rd_mesh *m = &s->meshes[mi];
        rd_mesh_deform *d = m->deform;
        if (!d) continue;
        const rd_node *n = &s->nodes[node];
        const rd_skin *k =
            n->skin && n->skin <= s->skin_count && d->influences ? &s->skins[n->skin - 1] : NULL;
        uint32_t jc = k ? k->joint_count : 0, nt = d->target_count;
        size_t count = (size_t)jc * 16 + nt;
        if (count > cap) {
            free(inputs);
            cap = count;
            inputs = zalloc(cap, sizeof *inputs);
        }
        if (k) rd_skin_joint_matrices(s, k, node, inputs);
        const float *w = n->weight_count == nt && n->weights ? n->weights : d->default_weights;
        if (nt) memcpy(&inputs[(size_t)jc * 16], w, nt * sizeof(float));
        if (d->posed && d->posed_count == count &&
            (count == 0 || memcmp(d->posed, inputs, count * sizeof *inputs) == 0))
            continue;
        rd_mesh_deform_apply(m, w, nt, k ? inputs : NULL, jc);
        free(d->posed);
        d->posed = zalloc(count, sizeof *inputs);
        if (count) memcpy(d->posed, inputs, count * sizeof *inputs);
        d->posed_count = count;
        d->revision++;
    }
    free(inputs);
}
