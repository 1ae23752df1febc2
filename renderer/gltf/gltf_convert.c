/* gltf_convert.c: a parsed glTF document (gltf_document.h) to an rd_scene — the driver that
 * walks materials, meshes, nodes, lights, cameras and animations in a fixed order and hands
 * each part to its C file (gltf_materials.c, gltf_textures.c, gltf_mesh.c, gltf_skin.c,
 * gltf_nodes.c, gltf_lights.c, gltf_animation.c). Every index is checked before it is followed; the
 * first failure ends the conversion with one message. */
#include "renderer/gltf/gltf_document.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const kSupportedExtensions[] = {"KHR_lights_punctual",
                                                   "KHR_materials_emissive_strength"};

bool rd_gltf_extension_supported(const char *name, size_t len)
{
    for (size_t i = 0; i < sizeof kSupportedExtensions / sizeof *kSupportedExtensions; i++)
        if (len == strlen(kSupportedExtensions[i]) &&
            memcmp(name, kSupportedExtensions[i], len) == 0)
            return true;
    return false;
}

static char *name_of(rd_gltf_str s)
{
    return s.len ? (char *)s.s : NULL;
}

static bool has_extension(const rd_gltf_doc_material *m, rd_gltf_str e)
{
    for (size_t i = 0; i < m->extension_count; i++)
        if (m->extensions[i].len == e.len && memcmp(m->extensions[i].s, e.s, e.len) == 0)
            return true;
    return false;
}

/* The conversion's state beyond rd_gltf_conv. */
typedef struct convert {
    rd_gltf_conv c;
    uint64_t max_tris;
    int *parent;   /* glTF parent of each glTF node */
    size_t *order; /* reachable glTF nodes, parents first */
    size_t order_count;
    int32_t *mesh_map; /* glTF mesh -> rd mesh (-1: unused or empty) */
} convert;

#define FAIL(cv, code, ...) rd_gltf_fail((cv)->c.err, (cv)->c.errlen, code, __VA_ARGS__)

static void warnings(convert *cv)
{
    const rd_gltf_document *d = cv->c.doc;
    for (size_t i = 0; i < d->extensions_used_count; i++) {
        rd_gltf_str e = d->extensions_used[i];
        if (e.len == 0 || rd_gltf_extension_supported(e.s, e.len)) continue;
        bool on_material = false; /* then materials() warns, saying how many use it */
        for (size_t m = 0; m < d->material_count; m++)
            on_material = on_material || has_extension(&d->materials[m], e);
        char clean[128];
        rd_gltf_clean(e.s, e.len, 80, clean);
        if (!on_material)
            rd_scene_warn(cv->c.s, "extension %s is not supported and was ignored", clean);
    }
}

static int compare_names(const void *a, const void *b)
{
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}

/* Materials: factors in gltf_materials.c, textures in gltf_textures.c, in the order the checks
 * always ran. */
static rd_gltf_result materials(convert *cv)
{
    const rd_gltf_document *d = cv->c.doc;
    rd_gltf_conv *c = &cv->c;
    size_t blend = 0, unsupported_n = 0, unsupported_cap = 0;
    char **unsupported = NULL; /* cleaned names of unsupported material extensions, one a use */
    rd_gltf_result r = RD_GLTF_OK;
    for (size_t i = 0; i < d->material_count && r == RD_GLTF_OK; i++) {
        const rd_gltf_doc_material *g = &d->materials[i];
        rd_material mt;
        memset(&mt, 0, sizeof mt);
        mt.name = (char *)g->name;
        r = rd_gltf_material_colors(c->s, i, &g->factors, &mt, c->err, c->errlen);
        if (r == RD_GLTF_OK)
            r = rd_gltf_conv_texture(c, g->base_color, i, "base colour", &mt.base_color_texture);
        if (r == RD_GLTF_OK)
            r = rd_gltf_conv_texture(c, g->emissive, i, "emissive", &mt.emissive_texture);
        if (r == RD_GLTF_OK) r = rd_gltf_material_pbr(i, &g->factors, &mt, c->err, c->errlen);
        if (r == RD_GLTF_OK)
            r = rd_gltf_conv_texture(c, g->metallic_roughness, i, "metallic-roughness",
                                     &mt.metallic_roughness_texture);
        if (r == RD_GLTF_OK)
            r = rd_gltf_conv_texture(c, g->normal, i, "normal", &mt.normal_texture);
        if (r == RD_GLTF_OK)
            r = rd_gltf_conv_texture(c, g->occlusion, i, "occlusion", &mt.occlusion_texture);
        if (r != RD_GLTF_OK) break;
        if (mt.alpha_mode == RD_ALPHA_BLEND) blend++;
        for (size_t e = 0; e < g->extension_count; e++) {
            rd_gltf_str x = g->extensions[e];
            if (rd_gltf_extension_supported(x.s, x.len)) continue;
            if (unsupported_n == unsupported_cap) {
                unsupported_cap = unsupported_cap ? unsupported_cap * 2 : 8;
                char **grown = realloc(unsupported, unsupported_cap * sizeof *grown);
                if (!grown) {
                    fprintf(stderr, "probecast: out of memory (%zu names)\n", unsupported_cap);
                    abort();
                }
                unsupported = grown;
            }
            unsupported[unsupported_n] = rd_gltf_alloc(128, 1);
            rd_gltf_clean(x.s, x.len, 80, unsupported[unsupported_n++]);
        }
        rd_scene_add_material(c->s, &mt); /* index 1 + i: materials[0] is the default */
    }
    if (r == RD_GLTF_OK) {
        rd_gltf_material_warnings(c->s, blend);
        if (unsupported_n) qsort(unsupported, unsupported_n, sizeof *unsupported, compare_names);
        for (size_t i = 0, j; i < unsupported_n; i = j) {
            for (j = i + 1; j < unsupported_n && strcmp(unsupported[i], unsupported[j]) == 0;)
                j++;
            rd_scene_warn(c->s,
                          "material extension %s (on %zu material(s)) is not supported; those "
                          "materials are drawn with the core metallic-roughness model",
                          unsupported[i], j - i);
        }
    }
    for (size_t i = 0; i < unsupported_n; i++)
        free(unsupported[i]);
    free(unsupported);
    return r;
}

/* ---- meshes ------------------------------------------------------------------------------- */

typedef struct plan {
    rd_gltf_primitive *prims; /* the triangle primitives, accessors resolved */
    size_t count;
    uint64_t tris;
} plan;

static void primitive_dispose(rd_gltf_primitive *p)
{
    rd_gltf_accessor_dispose(&p->pos);
    rd_gltf_accessor_dispose(&p->nrm);
    rd_gltf_accessor_dispose(&p->uv);
    rd_gltf_accessor_dispose(&p->tan);
    rd_gltf_accessor_dispose(&p->idx);
    rd_gltf_primitive_deform_dispose(p);
}

/* Resolves a primitive's accessors and counts its triangles without reading vertex data. */
static rd_gltf_result plan_primitive(convert *cv, const rd_gltf_doc_primitive *gp,
                                     const char *where, rd_gltf_primitive *pr)
{
    static const int f[] = {RD_GLTF_FLOAT};
    static const int uv[] = {RD_GLTF_FLOAT, RD_GLTF_UNSIGNED_BYTE, RD_GLTF_UNSIGNED_SHORT};
    static const int idx[] = {RD_GLTF_UNSIGNED_BYTE, RD_GLTF_UNSIGNED_SHORT, RD_GLTF_UNSIGNED_INT};
    const rd_gltf_document *d = cv->c.doc;
    char *err = cv->c.err, what[RD_GLTF_LABEL_MAX];
    size_t errlen = cv->c.errlen;
    rd_gltf_result r;
    if (pr->mode > RD_GLTF_MODE_TRIANGLE_FAN)
        return FAIL(cv, RD_GLTF_ERR_INVALID, "%s has an invalid mode %d", where, pr->mode);
    if (!gp->has_pos) return FAIL(cv, RD_GLTF_ERR_INVALID, "%s has no POSITION attribute", where);
    snprintf(what, sizeof what, "POSITION of %s", where);
    r = rd_gltf_resolve_accessor(d, gp->pos, what, RD_GLTF_TYPE_VEC3, f, 1, &pr->pos, err, errlen);
    if (r == RD_GLTF_OK && gp->has_nrm) {
        snprintf(what, sizeof what, "NORMAL of %s", where);
        r = rd_gltf_resolve_accessor(d, gp->nrm, what, RD_GLTF_TYPE_VEC3, f, 1, &pr->nrm, err,
                                     errlen);
        pr->has_nrm = true;
    }
    if (r == RD_GLTF_OK && gp->has_uv) {
        snprintf(what, sizeof what, "TEXCOORD_0 of %s", where);
        r = rd_gltf_resolve_accessor(d, gp->uv, what, RD_GLTF_TYPE_VEC2, uv, 3, &pr->uv, err,
                                     errlen);
        pr->has_uv = true;
    }
    if (r == RD_GLTF_OK && gp->has_tan) {
        snprintf(what, sizeof what, "TANGENT of %s", where);
        r = rd_gltf_resolve_accessor(d, gp->tan, what, RD_GLTF_TYPE_VEC4, f, 1, &pr->tan, err,
                                     errlen);
        pr->has_tan = true;
    }
    if (r != RD_GLTF_OK) return r;
    if ((pr->has_nrm && pr->nrm.count != pr->pos.count) ||
        (pr->has_uv && pr->uv.count != pr->pos.count) ||
        (pr->has_tan && pr->tan.count != pr->pos.count))
        return FAIL(cv, RD_GLTF_ERR_INVALID, "the attributes of %s have different vertex counts",
                    where);
    size_t n = pr->pos.count;
    if (gp->indices >= 0) {
        snprintf(what, sizeof what, "indices of %s", where);
        r = rd_gltf_resolve_accessor(d, gp->indices, what, RD_GLTF_TYPE_SCALAR, idx, 3, &pr->idx,
                                     err, errlen);
        if (r != RD_GLTF_OK) return r;
        pr->has_idx = true;
        n = pr->idx.count;
    }
    if (pr->mode == RD_GLTF_MODE_TRIANGLES) {
        pr->tris = n / 3;
        if (n % 3 != 0)
            rd_scene_warn(cv->c.s,
                          "%s has %zu vertices, not a multiple of 3; the last %zu are ignored",
                          where, n, n % 3);
    } else {
        pr->tris = n >= 3 ? n - 2 : 0;
    }
    if (gp->material >= 0 && (size_t)gp->material >= d->material_count)
        return FAIL(cv, RD_GLTF_ERR_INVALID,
                    "%s refers to material %d, but there are only %zu materials", where,
                    gp->material, d->material_count);
    pr->material = gp->material >= 0 ? (uint32_t)gp->material + 1 : 0;
    return rd_gltf_plan_deform(d, gp, where, pr, err, errlen);
}

/* Validates mesh `mesh`'s primitives into out (its triangle primitives only). */
static rd_gltf_result plan_mesh(convert *cv, size_t mesh, plan *out)
{
    const rd_gltf_doc_mesh *gm = &cv->c.doc->meshes[mesh];
    out->prims = rd_gltf_alloc(gm->primitive_count, sizeof *out->prims);
    for (size_t p = 0; p < gm->primitive_count; p++) {
        const rd_gltf_doc_primitive *gp = &gm->primitives[p];
        char where[64];
        snprintf(where, sizeof where, "mesh %zu primitive %zu", mesh, p);
        rd_gltf_primitive pr;
        memset(&pr, 0, sizeof pr);
        pr.mode = gp->mode < 0 ? RD_GLTF_MODE_TRIANGLES : gp->mode;
        if (pr.mode >= 0 && pr.mode <= RD_GLTF_MODE_LINE_STRIP) {
            rd_scene_warn(cv->c.s,
                          "%s draws points or lines (mode %d), which are not supported; it "
                          "is skipped",
                          where, pr.mode);
            continue;
        }
        rd_gltf_result r = plan_primitive(cv, gp, where, &pr);
        if (r != RD_GLTF_OK || pr.tris == 0) {
            primitive_dispose(&pr);
            if (r != RD_GLTF_OK) return r;
            continue;
        }
        out->prims[out->count++] = pr;
        out->tris += pr.tris;
    }
    return RD_GLTF_OK;
}

static rd_gltf_result meshes(convert *cv, plan *plans)
{
    const rd_gltf_document *d = cv->c.doc;
    uint8_t *used = rd_gltf_alloc(d->mesh_count, 1);
    rd_gltf_result r = RD_GLTF_OK;
    for (size_t i = 0; i < cv->order_count && r == RD_GLTF_OK; i++) {
        size_t gi = cv->order[i];
        int mesh = d->nodes[gi].mesh;
        if (mesh < -1 || (mesh >= 0 && (size_t)mesh >= d->mesh_count))
            r = FAIL(cv, RD_GLTF_ERR_INVALID,
                     "node %zu refers to mesh %d, but there are only %zu meshes", gi, mesh,
                     d->mesh_count);
        else if (mesh >= 0)
            used[mesh] = 1;
    }
    uint64_t total = 0;
    for (size_t i = 0; i < d->mesh_count && r == RD_GLTF_OK; i++) {
        if (!used[i]) continue;
        r = plan_mesh(cv, i, &plans[i]);
        if (r != RD_GLTF_OK) break;
        if (plans[i].tris > UINT32_MAX)
            r = FAIL(cv, RD_GLTF_ERR_TOO_LARGE,
                     "mesh %zu has %llu triangles, more than a mesh can hold", i,
                     (unsigned long long)plans[i].tris);
        else if ((total += plans[i].tris) > cv->max_tris)
            r = FAIL(cv, RD_GLTF_ERR_TOO_LARGE,
                     "the scene has more than %llu triangles (the limit), counting meshes up to "
                     "mesh %zu",
                     (unsigned long long)cv->max_tris, i);
    }
    free(used);
    cv->c.tris_left = r == RD_GLTF_OK ? cv->max_tris - total : 0;
    for (size_t i = 0; i < d->mesh_count && r == RD_GLTF_OK; i++) {
        if (plans[i].tris == 0) continue; /* unused, or nothing but points and lines */
        uint32_t idx =
            rd_scene_add_mesh(cv->c.s, name_of(d->meshes[i].name), (uint32_t)plans[i].tris);
        r = rd_gltf_fill_mesh(i, plans[i].prims, plans[i].count, &cv->c.s->meshes[idx], cv->c.err,
                              cv->c.errlen);
        if (r == RD_GLTF_OK)
            r = rd_gltf_fill_deform(&cv->c, i, plans[i].prims, plans[i].count,
                                    &cv->c.s->meshes[idx]);
        cv->mesh_map[i] = (int32_t)idx;
    }
    return r;
}

/* ---- nodes, lights and cameras ------------------------------------------------------------ */

static rd_gltf_result nodes(convert *cv)
{
    const rd_gltf_document *d = cv->c.doc;
    for (size_t i = 0; i < cv->order_count; i++) {
        size_t gi = cv->order[i];
        const rd_gltf_doc_node *gn = &d->nodes[gi];
        rd_node n;
        memset(&n, 0, sizeof n);
        n.name = name_of(gn->name);
        n.parent = cv->parent[gi] >= 0 ? cv->c.node_map[cv->parent[gi]] : -1;
        n.mesh = gn->mesh >= 0 ? cv->mesh_map[gn->mesh] : -1;
        rd_gltf_result r = rd_gltf_node_transform(gi, &gn->transform, &n, cv->c.err, cv->c.errlen);
        if (r != RD_GLTF_OK) return r;
        cv->c.node_map[gi] = (int32_t)rd_scene_add_node(cv->c.s, &n);
    }
    return RD_GLTF_OK;
}

static rd_gltf_result camera(convert *cv, size_t gi, uint8_t *ortho_warned)
{
    const rd_gltf_document *d = cv->c.doc;
    const rd_gltf_doc_node *gn = &d->nodes[gi];
    if (gn->camera < 0 || (size_t)gn->camera >= d->camera_count)
        return FAIL(cv, RD_GLTF_ERR_INVALID,
                    "node %zu refers to camera %d, but there are only %zu cameras", gi, gn->camera,
                    d->camera_count);
    size_t ci = (size_t)gn->camera;
    const rd_gltf_doc_camera *gc = &d->cameras[ci];
    if (gc->type.len != 11 || memcmp(gc->type.s, "perspective", 11) != 0) {
        char name[RD_GLTF_LABEL_MAX], type[128];
        rd_gltf_label("camera", ci, gc->name, name);
        rd_gltf_clean(gc->type.s, gc->type.len, 16, type);
        if (!ortho_warned[ci])
            rd_scene_warn(cv->c.s, "%s is %s, which is not supported; it is ignored", name, type);
        ortho_warned[ci] = 1;
        return RD_GLTF_OK;
    }
    rd_camera c;
    memset(&c, 0, sizeof c);
    c.name = name_of(gc->name);
    rd_gltf_result r =
        rd_gltf_perspective(ci, gc->yfov, gc->znear, gc->aspect, &c, cv->c.err, cv->c.errlen);
    if (r != RD_GLTF_OK) return r;
    c.node = cv->c.node_map[gi];
    rd_scene_add_camera(cv->c.s, &c);
    return RD_GLTF_OK;
}

static rd_gltf_result light(convert *cv, size_t gi)
{
    const rd_gltf_document *d = cv->c.doc;
    const rd_gltf_doc_node *gn = &d->nodes[gi];
    if (!gn->light_is_int || gn->light < 0 || (size_t)gn->light >= d->light_count)
        return FAIL(cv, RD_GLTF_ERR_INVALID,
                    "node %zu refers to a KHR_lights_punctual light that does not exist (there "
                    "are %zu lights)",
                    gi, d->light_count);
    size_t index = (size_t)gn->light;
    rd_light l;
    memset(&l, 0, sizeof l);
    l.name = (char *)d->lights[index].name;
    bool ignored;
    rd_gltf_result r = rd_gltf_light(cv->c.s, index, &d->lights[index].params, &l, &ignored,
                                     cv->c.err, cv->c.errlen);
    if (r != RD_GLTF_OK || ignored) return r;
    l.node = cv->c.node_map[gi];
    rd_scene_add_light(cv->c.s, &l);
    return RD_GLTF_OK;
}

static rd_gltf_result lights_and_cameras(convert *cv)
{
    uint8_t *ortho_warned = rd_gltf_alloc(cv->c.doc->camera_count, 1);
    rd_gltf_result r = RD_GLTF_OK;
    for (size_t i = 0; i < cv->order_count && r == RD_GLTF_OK; i++) {
        const rd_gltf_doc_node *gn = &cv->c.doc->nodes[cv->order[i]];
        if (gn->camera >= 0 || gn->camera < -1) r = camera(cv, cv->order[i], ortho_warned);
        if (r == RD_GLTF_OK && gn->has_light) r = light(cv, cv->order[i]);
    }
    free(ortho_warned);
    return r;
}

rd_gltf_result rd_gltf_convert(const rd_gltf_document *doc, rd_gltf_files *files,
                               uint64_t *decoded_bytes, uint64_t max_triangles, rd_scene *s,
                               char *err, size_t errlen)
{
    convert cv;
    memset(&cv, 0, sizeof cv);
    cv.c = (rd_gltf_conv){doc, files, decoded_bytes, s, NULL, NULL, 0, err, errlen, 0, 0, 0};
    cv.max_tris = max_triangles;
    size_t nodes_n = doc->node_count;
    cv.parent = rd_gltf_alloc(nodes_n, sizeof *cv.parent);
    cv.order = rd_gltf_alloc(nodes_n, sizeof *cv.order);
    cv.c.node_map = rd_gltf_alloc(nodes_n, sizeof *cv.c.node_map);
    cv.c.tex_map = rd_gltf_alloc(doc->texture_count, sizeof *cv.c.tex_map);
    cv.mesh_map = rd_gltf_alloc(doc->mesh_count, sizeof *cv.mesh_map);
    plan *plans = rd_gltf_alloc(doc->mesh_count, sizeof *plans);
    for (size_t i = 0; i < nodes_n; i++)
        cv.parent[i] = -1, cv.c.node_map[i] = -1;
    for (size_t i = 0; i < doc->texture_count; i++)
        cv.c.tex_map[i] = -1;
    for (size_t i = 0; i < doc->mesh_count; i++)
        cv.mesh_map[i] = -1;

    warnings(&cv);
    rd_gltf_result r =
        rd_gltf_hierarchy(nodes_n, doc->children, doc->scene_count, doc->scenes, doc->default_scene,
                          cv.parent, cv.order, &cv.order_count, err, errlen);
    if (r == RD_GLTF_OK) r = materials(&cv);
    if (r == RD_GLTF_OK) r = meshes(&cv, plans);
    if (r == RD_GLTF_OK) r = nodes(&cv);
    if (r == RD_GLTF_OK) r = rd_gltf_conv_skins(&cv.c, cv.mesh_map);
    if (r == RD_GLTF_OK) r = lights_and_cameras(&cv);
    if (r == RD_GLTF_OK) r = rd_gltf_conv_animations(&cv.c);
    char uerr[256];
    if (r == RD_GLTF_OK && !rd_scene_update(s, uerr, sizeof uerr))
        r = FAIL(&cv, RD_GLTF_ERR_INVALID, "%s", uerr);

    for (size_t i = 0; i < doc->mesh_count; i++) {
        for (size_t p = 0; p < plans[i].count; p++)
            primitive_dispose(&plans[i].prims[p]);
        free(plans[i].prims);
    }
    free(plans);
    free(cv.parent);
    free(cv.order);
    free(cv.c.node_map);
    free(cv.c.tex_map);
    free(cv.mesh_map);
    return r;
}
