/* gltf_skin.c: skins and morph targets of a glTF document (glTF 2.0 sections 3.7.2.2 and 3.7.3):
 * a primitive's JOINTS_n/WEIGHTS_n and morph targets resolved, then read per vertex into the
 * mesh's rd_mesh_deform (scene.h), and the skins the shown nodes use, with their joints and
 * inverse bind matrices. Every accessor is resolved (and so bounds-checked) before it is read;
 * a joint index outside its skin fails the load. */
#include "renderer/gltf/gltf_document.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/scene/deform.h"
#include "renderer/scene/xform.h"

/* Skin and morph target values one file may hold (floats and joint indices, 1 GiB). */
static const uint64_t kMaxDeformValues = 1ull << 28;

/* Resolves attribute `name` (accessor index; -1: absent, a no-op) of where for n vertices. */
static rd_gltf_result attribute(const rd_gltf_document *d, int index, const char *name,
                                const char *where, int type, const int *ctypes, size_t nctypes,
                                size_t n, rd_gltf_accessor *out, char *err, size_t errlen)
{
    memset(out, 0, sizeof *out);
    out->index = -1;
    if (index == -1) return RD_GLTF_OK;
    char what[RD_GLTF_LABEL_MAX + 32];
    snprintf(what, sizeof what, "%s of %s", name, where);
    rd_gltf_result r =
        rd_gltf_resolve_accessor(d, index, what, type, ctypes, nctypes, out, err, errlen);
    if (r == RD_GLTF_OK && out->count != n)
        r = rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                         "%s has %zu elements, but POSITION has %zu vertices", what, out->count, n);
    return r;
}

rd_gltf_result rd_gltf_plan_deform(const rd_gltf_document *d, const rd_gltf_doc_primitive *gp,
                                   const char *where, rd_gltf_primitive *pr, char *err,
                                   size_t errlen)
{
    static const int jt[] = {RD_GLTF_UNSIGNED_BYTE, RD_GLTF_UNSIGNED_SHORT};
    static const int wt[] = {RD_GLTF_FLOAT, RD_GLTF_UNSIGNED_BYTE, RD_GLTF_UNSIGNED_SHORT};
    static const int tt[] = {RD_GLTF_FLOAT, RD_GLTF_BYTE, RD_GLTF_SHORT};
    size_t n = pr->pos.count;
    rd_gltf_result r = RD_GLTF_OK;
    for (int k = 0; k < 2 && r == RD_GLTF_OK; k++) {
        bool j = gp->joints[k] != -1, w = gp->weights[k] != -1;
        if (!j && !w) break; /* a second set only after the first */
        if (j != w)
            return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID, "%s has %s_%d without %s_%d",
                                where, j ? "JOINTS" : "WEIGHTS", k, j ? "WEIGHTS" : "JOINTS", k);
        char jn[16], wn[16];
        snprintf(jn, sizeof jn, "JOINTS_%d", k);
        snprintf(wn, sizeof wn, "WEIGHTS_%d", k);
        r = attribute(d, gp->joints[k], jn, where, RD_GLTF_TYPE_VEC4 | RD_GLTF_INTEGERS, jt, 2, n,
                      &pr->joints[k], err, errlen);
        if (r == RD_GLTF_OK)
            r = attribute(d, gp->weights[k], wn, where, RD_GLTF_TYPE_VEC4, wt, 3, n,
                          &pr->weights[k], err, errlen);
        pr->joint_sets = (uint32_t)k + 1;
    }
    if (r != RD_GLTF_OK || gp->target_count == 0) return r;
    if (gp->target_count > RD_ANIM_MAX_COMPONENTS)
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_TOO_LARGE,
                            "%s has %zu morph targets, more than the %u supported", where,
                            gp->target_count, RD_ANIM_MAX_COMPONENTS);
    pr->targets = rd_gltf_alloc(gp->target_count, sizeof *pr->targets);
    pr->target_count = gp->target_count;
    for (size_t t = 0; t < gp->target_count; t++) { /* absent ones first: dispose sees -1 */
        pr->targets[t].pos.index = pr->targets[t].nrm.index = pr->targets[t].tan.index = -1;
    }
    for (size_t t = 0; t < gp->target_count && r == RD_GLTF_OK; t++) {
        const rd_gltf_doc_target *g = &gp->targets[t];
        rd_gltf_target *o = &pr->targets[t];
        char tw[RD_GLTF_LABEL_MAX];
        snprintf(tw, sizeof tw, "%s target %zu", where, t);
        r = attribute(d, g->pos, "POSITION", tw, RD_GLTF_TYPE_VEC3, tt, 3, n, &o->pos, err, errlen);
        if (r == RD_GLTF_OK)
            r = attribute(d, g->nrm, "NORMAL", tw, RD_GLTF_TYPE_VEC3, tt, 3, n, &o->nrm, err,
                          errlen);
        if (r == RD_GLTF_OK)
            r = attribute(d, g->tan, "TANGENT", tw, RD_GLTF_TYPE_VEC3, tt, 3, n, &o->tan, err,
                          errlen);
    }
    return r;
}

void rd_gltf_primitive_deform_dispose(rd_gltf_primitive *pr)
{
    for (int k = 0; k < 2; k++) {
        rd_gltf_accessor_dispose(&pr->joints[k]);
        rd_gltf_accessor_dispose(&pr->weights[k]);
    }
    for (size_t t = 0; t < pr->target_count; t++) {
        rd_gltf_accessor_dispose(&pr->targets[t].pos);
        rd_gltf_accessor_dispose(&pr->targets[t].nrm);
        rd_gltf_accessor_dispose(&pr->targets[t].tan);
    }
    free(pr->targets);
    pr->targets = NULL;
    pr->target_count = 0;
}

/* Vertex vi of pr's joints and weights into out's vertex vo: weights checked (finite, >= 0),
 * normalised to sum to one (counted in c when they did not, beyond their type's precision). */
static rd_gltf_result read_skin(rd_gltf_conv *c, size_t mesh, size_t p, const rd_gltf_primitive *pr,
                                size_t vi, rd_mesh_deform *d, size_t vo)
{
    uint32_t nin = d->influences;
    uint16_t *jo = &d->joints[vo * nin];
    float *wo = &d->weights[vo * nin];
    double sum = 0, tol = 0;
    for (uint32_t s = 0; s < pr->joint_sets; s++) {
        uint32_t j[4];
        float w[4];
        rd_gltf_read_uints(&pr->joints[s], vi, j);
        rd_gltf_read_floats(&pr->weights[s], vi, w);
        int ct = pr->weights[s].ctype;
        tol += ct == RD_GLTF_FLOAT ? 1e-3 : ct == RD_GLTF_UNSIGNED_BYTE ? 4.0 / 255 : 4.0 / 65535;
        for (int k = 0; k < 4; k++) {
            if (!isfinite(w[k]) || w[k] < 0)
                return rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                                    "WEIGHTS_%u of mesh %zu primitive %zu has a negative or "
                                    "non-finite weight (vertex %zu)",
                                    s, mesh, p, vi);
            wo[s * 4 + k] = w[k];
            jo[s * 4 + k] = w[k] > 0 ? (uint16_t)j[k] : 0; /* unused joints point at joint 0 */
            if (w[k] > 0 && j[k] > d->max_joint) d->max_joint = j[k];
            sum += w[k];
        }
    }
    if (fabs(sum - 1.0) > tol) c->weights_normalised++; /* per triangle corner */
    if (sum > 0 && sum != 1.0)
        for (uint32_t k = 0; k < nin; k++)
            wo[k] = (float)(wo[k] / sum);
    return RD_GLTF_OK;
}

/* Target deltas of vertex vi into their arrays at vertex vo (finite, or the load fails). */
static rd_gltf_result read_targets(rd_gltf_conv *c, size_t mesh, size_t p,
                                   const rd_gltf_primitive *pr, size_t vi, rd_mesh_deform *d,
                                   size_t vo)
{
    for (size_t t = 0; t < pr->target_count; t++) {
        const rd_gltf_accessor *a[3] = {&pr->targets[t].pos, &pr->targets[t].nrm,
                                        &pr->targets[t].tan};
        float *dst[3] = {d->target_positions, d->target_normals, d->target_tangents};
        for (int k = 0; k < 3; k++) {
            if (a[k]->index < 0 || !dst[k]) continue;
            float *v = &dst[k][(t * d->vertex_count + vo) * 3];
            rd_gltf_read_floats(a[k], vi, v);
            if (!rd_vec3_isfinite(v))
                return rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                                    "morph target %zu of mesh %zu primitive %zu has a delta that "
                                    "is NaN or infinite (vertex %zu)",
                                    t, mesh, p, vi);
        }
    }
    return RD_GLTF_OK;
}

/* Counts the values a deformation of nv vertices holds against the file's limit (the message
 * names glTF mesh `mesh`). */
static rd_gltf_result charge(rd_gltf_conv *c, uint64_t nv, uint32_t influences, size_t targets,
                             bool tn, bool tt, size_t mesh)
{
    uint64_t values = nv * (influences * 2 + targets * 3 * (1 + tn + tt) + 10);
    c->deform_floats += values;
    if (values > kMaxDeformValues || c->deform_floats > kMaxDeformValues)
        return rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_TOO_LARGE,
                            "the skins and morph targets hold more than %llu values (the limit), "
                            "counting mesh %zu",
                            (unsigned long long)kMaxDeformValues, mesh);
    return RD_GLTF_OK;
}

rd_gltf_result rd_gltf_fill_deform(rd_gltf_conv *c, size_t mesh, const rd_gltf_primitive *prims,
                                   size_t n, rd_mesh *out)
{
    const rd_gltf_doc_mesh *gm = &c->doc->meshes[mesh];
    uint32_t sets = 0;
    size_t targets = n ? prims[0].target_count : 0;
    bool tn = false, tt = false;
    for (size_t p = 0; p < n; p++) {
        if (prims[p].joint_sets > sets) sets = prims[p].joint_sets;
        if (prims[p].target_count != targets)
            return rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                                "the primitives of mesh %zu have different numbers of morph "
                                "targets (%zu and %zu)",
                                mesh, targets, prims[p].target_count);
        for (size_t t = 0; t < prims[p].target_count; t++) {
            tn = tn || prims[p].targets[t].nrm.index >= 0;
            tt = tt || prims[p].targets[t].tan.index >= 0;
        }
    }
    if (gm->weight_count && gm->weight_count != targets)
        return rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                            "mesh %zu has %zu weights for %zu morph targets", mesh,
                            gm->weight_count, targets);
    if (sets == 0 && targets == 0) return RD_GLTF_OK;
    rd_gltf_result r = charge(c, (uint64_t)out->tri_count * 3, sets * 4, targets, tn, tt, mesh);
    if (r != RD_GLTF_OK) return r;
    rd_mesh_deform *d = rd_mesh_deform_create(out, sets * 4, (uint32_t)targets, tn, tt);
    for (size_t t = 0; t < gm->weight_count; t++)
        if (!rd_gltf_to_float(gm->weights[t], &d->default_weights[t]))
            return rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                                "mesh %zu has a weight that is not finite", mesh);
    size_t vo = 0;
    for (size_t p = 0; p < n; p++) {
        const rd_gltf_primitive *pr = &prims[p];
        for (uint64_t t = 0; t < pr->tris; t++) {
            for (int k = 0; k < 3; k++, vo++) {
                size_t vi = rd_gltf_corner_vertex(pr, t, k);
                if (vi >= pr->pos.count) continue; /* rd_gltf_fill_mesh refused it already */
                rd_gltf_result r = RD_GLTF_OK;
                if (pr->joint_sets) r = read_skin(c, mesh, p, pr, vi, d, vo);
                if (r == RD_GLTF_OK) r = read_targets(c, mesh, p, pr, vi, d, vo);
                if (r != RD_GLTF_OK) return r;
            }
        }
    }
    rd_mesh_deform_keep_rest(out);
    return RD_GLTF_OK;
}

/* Adds glTF skin k to the scene (first use), its index in skin_map[k]. */
static rd_gltf_result add_skin(rd_gltf_conv *c, size_t k, int32_t *skin_map)
{
    if (skin_map[k] >= 0) return RD_GLTF_OK;
    const rd_gltf_doc_skin *g = &c->doc->skins[k];
    char name[RD_GLTF_LABEL_MAX];
    rd_gltf_label("skin", k, g->name, name);
    if (g->joint_count == 0 || g->joint_count > 65536)
        return rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                            "%s has %zu joints (1 to 65536 are allowed)", name, g->joint_count);
    rd_skin sk = {.name = g->name.len ? (char *)g->name.s : NULL,
                  .joint_count = (uint32_t)g->joint_count};
    sk.joints = rd_gltf_alloc(g->joint_count, sizeof *sk.joints);
    sk.inverse_bind = rd_gltf_alloc(g->joint_count * 16, sizeof(float));
    rd_gltf_result r = RD_GLTF_OK;
    for (size_t j = 0; j < g->joint_count && r == RD_GLTF_OK; j++) {
        int node = g->joints[j];
        if (node < 0 || (size_t)node >= c->doc->node_count)
            r = rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                             "%s joint %zu is node %d, but there are only %zu nodes", name, j, node,
                             c->doc->node_count);
        else if (c->node_map[node] < 0)
            r = rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                             "%s joint %zu is node %d, which is not in the scene shown", name, j,
                             node);
        else
            sk.joints[j] = (uint32_t)c->node_map[node];
        rd_mat4_identity(&sk.inverse_bind[16 * j]);
    }
    if (r == RD_GLTF_OK && g->inverse_bind != -1) {
        static const int f[] = {RD_GLTF_FLOAT};
        char what[RD_GLTF_LABEL_MAX + 32];
        snprintf(what, sizeof what, "inverseBindMatrices of %s", name);
        rd_gltf_accessor a;
        r = rd_gltf_resolve_accessor(c->doc, g->inverse_bind, what, RD_GLTF_TYPE_MAT4, f, 1, &a,
                                     c->err, c->errlen);
        if (r == RD_GLTF_OK && a.count < g->joint_count)
            r = rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                             "%s has %zu inverse bind matrices for %zu joints", name, a.count,
                             g->joint_count);
        for (size_t j = 0; r == RD_GLTF_OK && j < g->joint_count; j++) {
            float *m = &sk.inverse_bind[16 * j];
            rd_gltf_read_floats(&a, j, m);
            for (int e = 0; e < 16; e++)
                if (!isfinite(m[e]))
                    r = rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                                     "%s has an inverse bind matrix that is not finite (joint %zu)",
                                     name, j);
        }
        rd_gltf_accessor_dispose(&a);
    }
    if (r == RD_GLTF_OK) skin_map[k] = (int32_t)rd_scene_add_skin(c->s, &sk);
    free(sk.joints);
    free(sk.inverse_bind);
    return r;
}

/* Gives rd node `node` (glTF node gi, drawing glTF mesh gm) a copy of deforming mesh rm, which
 * another node already poses: skins and weights belong to nodes, so each posed shape is a mesh
 * of its own. The copies count against the file's triangle and deformation limits. */
static rd_gltf_result own_copy(rd_gltf_conv *c, size_t gi, int gm, uint32_t rm, uint32_t node)
{
    rd_scene *s = c->s;
    const rd_mesh_deform *d = s->meshes[rm].deform;
    uint32_t tris = s->meshes[rm].tri_count;
    if (tris > c->tris_left)
        return rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_TOO_LARGE,
                            "node %zu deforms mesh %d, which other nodes deform too; its copy "
                            "takes the scene past its triangle limit",
                            gi, gm);
    c->tris_left -= tris;
    rd_gltf_result r = charge(c, d->vertex_count, d->influences, d->target_count,
                              d->target_normals != NULL, d->target_tangents != NULL, (size_t)gm);
    if (r != RD_GLTF_OK) return r;
    uint32_t nm = rd_scene_add_mesh(s, s->meshes[rm].name, tris); /* may move s->meshes */
    const rd_mesh *src = &s->meshes[rm];
    rd_mesh *dst = &s->meshes[nm];
    size_t nv = d->vertex_count, nt = d->target_count;
    memcpy(dst->positions, src->positions, nv * 3 * sizeof(float));
    memcpy(dst->normals, src->normals, nv * 3 * sizeof(float));
    memcpy(dst->uvs, src->uvs, nv * 2 * sizeof(float));
    memcpy(dst->material, src->material, tris * sizeof(uint32_t));
    if (src->tangents) {
        dst->tangents = rd_gltf_alloc(nv * 4, sizeof(float));
        memcpy(dst->tangents, src->tangents, nv * 4 * sizeof(float));
    }
    rd_mesh_deform *o = rd_mesh_deform_create(
        dst, d->influences, d->target_count, d->target_normals != NULL, d->target_tangents != NULL);
    memcpy(o->rest_positions, d->rest_positions, nv * 3 * sizeof(float));
    memcpy(o->rest_normals, d->rest_normals, nv * 3 * sizeof(float));
    if (d->rest_tangents) memcpy(o->rest_tangents, d->rest_tangents, nv * 4 * sizeof(float));
    if (d->influences) {
        memcpy(o->joints, d->joints, nv * d->influences * sizeof *o->joints);
        memcpy(o->weights, d->weights, nv * d->influences * sizeof *o->weights);
    }
    o->max_joint = d->max_joint;
    float *const from[3] = {d->target_positions, d->target_normals, d->target_tangents};
    float *const to[3] = {o->target_positions, o->target_normals, o->target_tangents};
    for (int k = 0; k < 3; k++)
        if (from[k] && to[k]) memcpy(to[k], from[k], nv * 3 * nt * sizeof(float));
    if (nt) memcpy(o->default_weights, d->default_weights, nt * sizeof(float));
    s->nodes[node].mesh = (int32_t)nm;
    return RD_GLTF_OK;
}

/* glTF node gi's skin and morph weights onto its rd node; posed[rm]: some node already poses
 * rd mesh rm (a second one gets a copy of its own). */
static rd_gltf_result node_deform(rd_gltf_conv *c, size_t gi, const int32_t *mesh_map,
                                  int32_t *skin_map, uint8_t *posed)
{
    const rd_gltf_doc_node *gn = &c->doc->nodes[gi];
    rd_node *n = &c->s->nodes[c->node_map[gi]];
    int32_t rm = gn->mesh >= 0 && (size_t)gn->mesh < c->doc->mesh_count ? mesh_map[gn->mesh] : -1;
    rd_mesh_deform *d = rm >= 0 ? c->s->meshes[rm].deform : NULL;
    uint32_t nt = d ? d->target_count : 0;
    if (gn->weight_count && rm >= 0 && gn->weight_count != nt)
        return rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                            "node %zu has %zu morph weights, but its mesh has %u morph targets", gi,
                            gn->weight_count, nt);
    if (nt) {
        n->weights = rd_gltf_alloc(nt, sizeof(float));
        n->weight_count = nt;
        for (uint32_t t = 0; t < nt; t++)
            if (!gn->weight_count)
                n->weights[t] = d->default_weights[t];
            else if (!rd_gltf_to_float(gn->weights[t], &n->weights[t]))
                return rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                                    "node %zu has a morph weight that is not finite", gi);
    }
    if (gn->skin != -1) {
        if (gn->skin < 0 || (size_t)gn->skin >= c->doc->skin_count)
            return rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                                "node %zu refers to skin %d, but there are only %zu skins", gi,
                                gn->skin, c->doc->skin_count);
        rd_gltf_result r = add_skin(c, (size_t)gn->skin, skin_map);
        if (r != RD_GLTF_OK) return r;
        const rd_skin *k = &c->s->skins[skin_map[gn->skin]];
        if (d && d->influences && d->max_joint >= k->joint_count)
            return rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                                "mesh %d has a vertex bound to joint %u, but skin %d (of node "
                                "%zu) has only %u joints",
                                gn->mesh, d->max_joint, gn->skin, gi, k->joint_count);
        if (d && d->influences) n->skin = (uint32_t)skin_map[gn->skin] + 1;
    }
    if (!d || (!n->skin && !nt)) return RD_GLTF_OK;
    if (!posed[rm]) {
        posed[rm] = 1;
        return RD_GLTF_OK;
    }
    return own_copy(c, gi, gn->mesh, (uint32_t)rm, (uint32_t)c->node_map[gi]);
}

rd_gltf_result rd_gltf_conv_skins(rd_gltf_conv *c, const int32_t *mesh_map)
{
    const rd_gltf_document *d = c->doc;
    int32_t *skin_map = rd_gltf_alloc(d->skin_count, sizeof *skin_map);
    uint8_t *posed = rd_gltf_alloc(c->s->mesh_count, 1);
    for (size_t k = 0; k < d->skin_count; k++)
        skin_map[k] = -1;
    rd_gltf_result r = RD_GLTF_OK;
    for (size_t gi = 0; gi < d->node_count && r == RD_GLTF_OK; gi++)
        if (c->node_map[gi] >= 0) r = node_deform(c, gi, mesh_map, skin_map, posed);
    if (r == RD_GLTF_OK && c->weights_normalised)
        rd_scene_warn(
            c->s,
            "%llu skinned triangle corners have joint weights that do not sum to one; they "
            "are normalised",
            (unsigned long long)c->weights_normalised);
    free(skin_map);
    free(posed);
    return r;
}
