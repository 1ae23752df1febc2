/* scene_documents.c: the scene service's API documents (scene, lights, probes) and their
 * publication to the snapshot (see scene_service_internal.h). */
#include "server/scene/scene_service_internal.h"

#include <stdlib.h>

#include "server/api/api_json.h"

#define NODE_DOC_LIMIT 1000 /* nodes listed in GET /v1/scene */

/* ---- documents ------------------------------------------------------------------------------ */

static cJSON *probes_json(const srv_scene_service *svc)
{
    const rd_world *w = &svc->world;
    cJSON *probes = cJSON_CreateObject();
    cJSON_AddStringToObject(probes, "mode",
                            w->gi ? srv_gi_mode_name(svc->st.settings.gi_mode) : "off");
    const pc_ddgi_volume *v = &w->ddgi.vol;
    unsigned counts[3] = {0, 0, 0};
    float spacing[3] = {0, 0, 0}, origin[3] = {0, 0, 0};
    if (w->gi) {
        counts[0] = v->counts.x, counts[1] = v->counts.y, counts[2] = v->counts.z;
        spacing[0] = v->spacing.x, spacing[1] = v->spacing.y, spacing[2] = v->spacing.z;
        origin[0] = v->origin.x, origin[1] = v->origin.y, origin[2] = v->origin.z;
    }
    cJSON *c = cJSON_AddArrayToObject(probes, "counts");
    for (int i = 0; i < 3; i++)
        cJSON_AddItemToArray(c, cJSON_CreateNumber(counts[i]));
    cJSON_AddNumberToObject(probes, "total", (double)counts[0] * counts[1] * counts[2]);
    srv_json_add_floats(probes, "spacing", spacing, 3);
    srv_json_add_floats(probes, "origin", origin, 3);
    cJSON_AddNumberToObject(probes, "rays_per_probe", w->gi ? v->counts.w : 0);
    cJSON_AddBoolToObject(probes, "converged", !srv_scene_service_converging(svc));
    return probes;
}

/* The "nodes" member of the scene document (the first NODE_DOC_LIMIT nodes). */
cJSON *srv_scene_nodes_json(const rd_scene *s)
{
    cJSON *nodes = cJSON_CreateArray();
    for (uint32_t i = 0; i < s->node_count && i < NODE_DOC_LIMIT; i++)
        cJSON_AddItemToArray(nodes, srv_json_node(i, &s->nodes[i]));
    return nodes;
}

cJSON *srv_scene_json(const srv_scene_service *svc)
{
    const rd_scene *s = &svc->st.scene;
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "source", svc->st.source);
    cJSON_AddStringToObject(j, "file_name", svc->st.file_name);
    cJSON_AddNumberToObject(j, "generation", (double)svc->st.generation);
    cJSON_AddNumberToObject(j, "triangles", (double)s->tri_total);
    cJSON_AddNumberToObject(j, "mesh_count", s->mesh_count);
    cJSON_AddNumberToObject(j, "instance_count", s->instance_count);
    cJSON_AddNumberToObject(j, "material_count", s->material_count);
    cJSON_AddNumberToObject(j, "texture_count", s->texture_count);
    cJSON_AddNumberToObject(j, "node_count", s->node_count);
    cJSON_AddNumberToObject(j, "light_count", s->light_count);
    cJSON *bounds = cJSON_AddObjectToObject(j, "bounds");
    srv_json_add_floats(bounds, "min", s->bounds_min, 3);
    srv_json_add_floats(bounds, "max", s->bounds_max, 3);
    cJSON_AddItemToObject(j, "nodes", srv_scene_nodes_json(s));
    cJSON_AddBoolToObject(j, "nodes_truncated", s->node_count > NODE_DOC_LIMIT);
    /* what deforms: skins (their joint counts) and meshes with morph targets (their counts) */
    cJSON *skins = cJSON_AddArrayToObject(j, "skins");
    for (uint32_t i = 0; i < s->skin_count && i < NODE_DOC_LIMIT; i++) {
        cJSON *k = cJSON_CreateObject();
        cJSON_AddNumberToObject(k, "id", i);
        cJSON_AddStringToObject(k, "name", s->skins[i].name ? s->skins[i].name : "");
        cJSON_AddNumberToObject(k, "joint_count", s->skins[i].joint_count);
        cJSON_AddItemToArray(skins, k);
    }
    cJSON *morphs = cJSON_AddArrayToObject(j, "morph_meshes");
    for (uint32_t m = 0, listed = 0; m < s->mesh_count && listed < NODE_DOC_LIMIT; m++) {
        const rd_mesh_deform *d = s->meshes[m].deform;
        if (!d || !d->target_count) continue;
        cJSON *k = cJSON_CreateObject();
        cJSON_AddNumberToObject(k, "mesh", m);
        cJSON_AddStringToObject(k, "name", s->meshes[m].name ? s->meshes[m].name : "");
        cJSON_AddNumberToObject(k, "target_count", d->target_count);
        cJSON_AddItemToArray(morphs, k);
        listed++;
    }
    cJSON *lights = cJSON_AddArrayToObject(j, "lights");
    for (uint32_t i = 0; i < s->light_count; i++)
        cJSON_AddItemToArray(lights, srv_json_light(svc->st.light_ids[i], &s->lights[i]));
    cJSON *bvh = cJSON_AddObjectToObject(j, "bvh");
    cJSON_AddNumberToObject(bvh, "triangles", (double)svc->gs.tri_count);
    cJSON_AddNumberToObject(bvh, "blas_nodes", (double)svc->gs.blas_node_count);
    cJSON_AddNumberToObject(bvh, "tlas_nodes", svc->gs.tlas_node_count);
    cJSON_AddNumberToObject(bvh, "max_blas_depth", svc->gs.max_blas_depth);
    cJSON_AddNumberToObject(bvh, "blas_build_ms", svc->gs.blas_build_ms);
    cJSON_AddNumberToObject(bvh, "tlas_build_ms", svc->gs.tlas_build_ms);
    cJSON_AddNumberToObject(bvh, "upload_ms", svc->gs.upload_ms);
    cJSON_AddItemToObject(j, "probes", probes_json(svc));
    if (svc->world.env_width) {
        cJSON *im = cJSON_AddObjectToObject(j, "environment_image");
        cJSON_AddNumberToObject(im, "width", svc->world.env_width);
        cJSON_AddNumberToObject(im, "height", svc->world.env_height);
    } else {
        cJSON_AddNullToObject(j, "environment_image");
    }
    if (svc->st.default_lighting) {
        cJSON *dl = cJSON_AddObjectToObject(j, "default_lighting");
        cJSON_AddNumberToObject(dl, "light", svc->st.default_light_id);
        rd_environment env;
        srv_state_environment(&svc->st, &env);
        srv_json_add_floats(dl, "sky", env.sky, 3);
        char why[160];
        rd_default_lighting_describe(&svc->st.lighting, why, sizeof why);
        cJSON_AddStringToObject(dl, "reason", why);
    } else {
        cJSON_AddFalseToObject(j, "default_lighting");
    }
    cJSON *w = cJSON_AddArrayToObject(j, "warnings");
    for (uint32_t i = 0; i < s->warning_count; i++)
        cJSON_AddItemToArray(w, cJSON_CreateString(s->warnings[i]));
    return j;
}

static cJSON *lights_json(const srv_scene_service *svc)
{
    cJSON *a = cJSON_CreateArray();
    for (uint32_t i = 0; i < svc->st.scene.light_count; i++)
        cJSON_AddItemToArray(a, srv_json_light(svc->st.light_ids[i], &svc->st.scene.lights[i]));
    cJSON *j = cJSON_CreateObject();
    cJSON_AddItemToObject(j, "lights", a);
    return j;
}

void srv_scene_publish_lights(srv_scene_service *svc, bool quiet)
{
    srv_snapshot_publish(svc->snap, SRV_DOC_LIGHTS, lights_json(svc), quiet);
}

/* Everything, after a new scene (or at start). */
void srv_scene_publish_scene(srv_scene_service *svc)
{
    const rd_scene *s = &svc->st.scene;
    cJSON **nodes = calloc(s->node_count ? s->node_count : 1, sizeof *nodes);
    if (!nodes) abort();
    for (uint32_t i = 0; i < s->node_count; i++)
        nodes[i] = srv_json_node(i, &s->nodes[i]);
    srv_snapshot_set_nodes(svc->snap, nodes, s->node_count);
    free(nodes);
    svc->was_converged = !srv_scene_service_converging(svc);
    srv_snapshot_publish(svc->snap, SRV_DOC_SCENE, srv_scene_json(svc), false);
    srv_scene_publish_lights(svc, false);
    srv_snapshot_publish(svc->snap, SRV_DOC_SETTINGS, srv_json_settings(&svc->st.settings), false);
}

/* The probe part of the scene document, when the field's state changed (no event). */
void srv_scene_publish_probes(srv_scene_service *svc)
{
    srv_snapshot_patch_scene(svc->snap, "probes", probes_json(svc));
    svc->was_converged = !srv_scene_service_converging(svc);
}

/* ---- GI ------------------------------------------------------------------------------------- */
