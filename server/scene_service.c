/* scene_service.c: the world's state, GPU resources and API semantics (see scene_service.h). */
#include "scene_service.h"
#include "clock.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "api_json.h"
#include "log.h"
#include "renderer/animation_clip.h"

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
static cJSON *nodes_json(const rd_scene *s)
{
    cJSON *nodes = cJSON_CreateArray();
    for (uint32_t i = 0; i < s->node_count && i < NODE_DOC_LIMIT; i++)
        cJSON_AddItemToArray(nodes, srv_json_node(i, &s->nodes[i]));
    return nodes;
}

static cJSON *scene_json(const srv_scene_service *svc)
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
    cJSON_AddItemToObject(j, "nodes", nodes_json(s));
    cJSON_AddBoolToObject(j, "nodes_truncated", s->node_count > NODE_DOC_LIMIT);
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
    if (svc->world.image.width) {
        cJSON *im = cJSON_AddObjectToObject(j, "environment_image");
        cJSON_AddNumberToObject(im, "width", svc->world.image.width);
        cJSON_AddNumberToObject(im, "height", svc->world.image.height);
    } else {
        cJSON_AddNullToObject(j, "environment_image");
    }
    if (svc->st.default_lighting) {
        cJSON *dl = cJSON_AddObjectToObject(j, "default_lighting");
        cJSON_AddNumberToObject(dl, "light", svc->st.default_light_id);
        rd_environment env;
        srv_state_environment(&svc->st, &env);
        srv_json_add_floats(dl, "sky", env.sky, 3);
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

static void publish_lights(srv_scene_service *svc, bool quiet)
{
    srv_snapshot_publish(svc->snap, SRV_DOC_LIGHTS, lights_json(svc), quiet);
}

/* Everything, after a new scene (or at start). */
static void publish_scene(srv_scene_service *svc)
{
    const rd_scene *s = &svc->st.scene;
    cJSON **nodes = calloc(s->node_count ? s->node_count : 1, sizeof *nodes);
    if (!nodes) abort();
    for (uint32_t i = 0; i < s->node_count; i++)
        nodes[i] = srv_json_node(i, &s->nodes[i]);
    srv_snapshot_set_nodes(svc->snap, nodes, s->node_count);
    free(nodes);
    svc->was_converged = !srv_scene_service_converging(svc);
    srv_snapshot_publish(svc->snap, SRV_DOC_SCENE, scene_json(svc), false);
    publish_lights(svc, false);
    srv_snapshot_publish(svc->snap, SRV_DOC_SETTINGS, srv_json_settings(&svc->st.settings), false);
}

/* The probe part of the scene document, when the field's state changed (no event). */
static void publish_probes(srv_scene_service *svc)
{
    srv_snapshot_patch_scene(svc->snap, "probes", probes_json(svc));
    svc->was_converged = !srv_scene_service_converging(svc);
}

/* ---- GI ------------------------------------------------------------------------------------- */

static rd_vk_result configure_gi(srv_scene_service *svc, char *err, size_t errlen)
{
    rd_ddgi_settings gi;
    srv_settings_to_gi(&svc->st.settings, &gi);
    if (svc->st.settings.gi_mode == SRV_GI_PATHTRACE) gi.mode = PC_GI_OFF;
    rd_vk_result vr = rd_world_configure_gi(&svc->world, svc->st.scene.bounds_min,
                                            svc->st.scene.bounds_max, &gi, err, errlen);
    svc->gi_updates = 0;
    svc->pt_target =
        svc->st.settings.gi_mode == SRV_GI_PATHTRACE ? (svc->vk->is_cpu ? 64 : 4096) : 0;
    return vr;
}

bool srv_scene_service_converging(const srv_scene_service *svc)
{
    return !rd_world_converged(&svc->world);
}

/* The demo light circles (animation.h). */
static bool demo_runs(const srv_scene_service *svc, unsigned viewers)
{
    return svc->st.settings.animate && viewers > 0 && svc->st.scene.light_count > 0;
}

bool srv_scene_service_animating(const srv_scene_service *svc, unsigned viewers)
{
    return demo_runs(svc, viewers) || (viewers > 0 && srv_playback_running(&svc->playback));
}

/* ---- changes -------------------------------------------------------------------------------- */

static bool upload_lights(srv_scene_service *svc, srv_cmd *c)
{
    char err[256];
    if (rd_gpu_scene_update_lights(svc->vk, &svc->gs, &svc->st.scene, err, sizeof err) !=
        RD_VK_OK) {
        if (c) srv_cmd_fail(c, 500, SRV_ERR_GPU, err);
        return false;
    }
    return true;
}

/* The lighting changed: every probe may see it (a light's reach is not tracked), so all wake
 * with their hysteresis lowered by `age` (PC_DDGI_WAKE_AGE_*). */
static void lighting_changed(srv_scene_service *svc, float age)
{
    rd_world_wake_all(&svc->world, age);
    svc->gi_updates = 0;
    if (svc->was_converged) publish_probes(svc);
}

/* node or one of its descendants places a light */
static bool node_carries_light(const rd_scene *s, uint32_t node)
{
    for (uint32_t i = 0; i < s->light_count; i++) {
        int32_t n = s->lights[i].node;
        unsigned depth = 0;
        while (n >= 0 && (uint32_t)n != node && depth++ < s->node_count)
            n = s->nodes[n].parent;
        if (n >= 0 && (uint32_t)n == node) return true;
    }
    return false;
}

/* Grows lo..hi by the world box of mesh placed with world matrix m. */
static void grow_by_mesh(const srv_scene_service *svc, uint32_t mesh, const float m[16],
                         float lo[3], float hi[3])
{
    float a[3], b[3];
    rd_gpu_scene_mesh_world_bounds(&svc->gs, mesh, m, a, b);
    for (int k = 0; k < 3; k++) {
        lo[k] = fminf(lo[k], a[k]);
        hi[k] = fmaxf(hi[k], b[k]);
    }
}

static void empty_box(float lo[3], float hi[3])
{
    for (int k = 0; k < 3; k++)
        lo[k] = INFINITY, hi[k] = -INFINITY;
}

/* World bounds of the instances that node moves (itself and its descendants); false when it
 * places no mesh. */
static bool node_bounds(const srv_scene_service *svc, uint32_t node, float lo[3], float hi[3])
{
    const rd_scene *s = &svc->st.scene;
    bool any = false;
    empty_box(lo, hi);
    for (uint32_t i = 0; i < s->instance_count; i++) {
        int32_t n = (int32_t)s->instances[i].node;
        unsigned depth = 0;
        while (n >= 0 && (uint32_t)n != node && depth++ < s->node_count)
            n = s->nodes[n].parent;
        if (n < 0 || (uint32_t)n != node) continue;
        grow_by_mesh(svc, s->instances[i].mesh, s->nodes[s->instances[i].node].world, lo, hi);
        any = true;
    }
    return any;
}

/* The world's environment: the settings', or the default one (scene_state.h). */
static void apply_sky(srv_scene_service *svc)
{
    rd_environment e;
    srv_state_environment(&svc->st, &e);
    rd_world_set_environment(&svc->world, &e);
}

/* Default lighting ended (the user added a light, or took the key light over): the default
 * environment goes too; GET /v1/scene says so. */
static void default_lighting_ended(srv_scene_service *svc)
{
    apply_sky(svc);
    lighting_changed(svc, PC_DDGI_WAKE_AGE_LIGHT);
    publish_scene(svc);
}

/* After a light was added, changed or removed: upload, reconverge, tell everyone. */
static bool lights_changed(srv_scene_service *svc, srv_cmd *c)
{
    if (!upload_lights(svc, c)) return false;
    lighting_changed(svc, PC_DDGI_WAKE_AGE_LIGHT);
    publish_lights(svc, false);
    return true;
}

/* ---- the scene's animations (glTF) ------------------------------------------------------- */

/* Some light hangs on a node an animation moves. */
static bool animated_lights(const srv_scene_service *svc)
{
    const rd_scene *s = &svc->st.scene;
    for (uint32_t i = 0; i < s->light_count; i++)
        if (s->lights[i].node >= 0 && (uint32_t)s->lights[i].node < s->node_count &&
            svc->animated[s->lights[i].node])
            return true;
    return false;
}

/* Instance i's world matrix differs from before[16 * i] (an animation moved it). */
static bool instance_moved(const srv_scene_service *svc, const float *before, uint32_t i)
{
    const rd_scene *s = &svc->st.scene;
    const rd_instance *in = &s->instances[i];
    return svc->animated[in->node] &&
           memcmp(&before[16 * i], s->nodes[in->node].world, 16 * sizeof *before) != 0;
}

/* Poses the scene at the clock's time: the animated nodes' TRS (rd_scene_animate), world
 * matrices, the top-level BVH and, when an animated node carries a light, the lights. With
 * wake, the probes around the old and the new bounds of every instance that moved wake (and all
 * of them, gently, when a light moved). *moved: some instance or light moved. */
static rd_vk_result pose_scene(srv_scene_service *svc, bool wake, bool *moved, char *err,
                               size_t errlen)
{
    rd_scene *s = &svc->st.scene;
    *moved = false;
    if (!s->animation_count) return RD_VK_OK;
    uint32_t n = s->instance_count, nl = s->light_count;
    float *before = malloc((n ? n : 1) * 16 * sizeof *before);        /* world matrices */
    float *light_was = malloc((nl ? nl : 1) * 6 * sizeof *light_was); /* position, direction */
    if (!before || !light_was) abort();
    for (uint32_t i = 0; i < n; i++)
        memcpy(&before[16 * i], s->nodes[s->instances[i].node].world, 16 * sizeof *before);
    for (uint32_t i = 0; i < nl; i++) {
        memcpy(&light_was[6 * i], s->lights[i].position, 3 * sizeof *light_was);
        memcpy(&light_was[6 * i + 3], s->lights[i].direction, 3 * sizeof *light_was);
    }
    bool lights = animated_lights(svc);
    rd_scene_animate(s, svc->playback.time_s);
    rd_vk_result vr = RD_VK_OK;
    if (!rd_scene_update(s, err, errlen) || s->instance_count != n) {
        /* animations change no hierarchy: a broken invariant, reported, not fatal */
        if (s->instance_count != n) snprintf(err, errlen, "the posed scene lost instances");
        vr = RD_VK_ERR_VULKAN;
        goto done;
    }
    bool any = false, lights_moved = false;
    for (uint32_t i = 0; i < n && !any; i++)
        any = instance_moved(svc, before, i);
    for (uint32_t i = 0; lights && i < nl; i++)
        lights_moved |= memcmp(&light_was[6 * i], s->lights[i].position, 3 * sizeof(float)) ||
                        memcmp(&light_was[6 * i + 3], s->lights[i].direction, 3 * sizeof(float));
    if (any) vr = rd_gpu_scene_update_instances(svc->vk, &svc->gs, s, err, errlen);
    if (vr == RD_VK_OK && lights_moved)
        vr = rd_gpu_scene_update_lights(svc->vk, &svc->gs, s, err, errlen);
    if (vr != RD_VK_OK) goto done;
    *moved = any || lights_moved;
    if (lights_moved) publish_lights(svc, true); /* GET answers follow; no event per frame */
    if (!wake) goto done;
    /* first: waking all replaces the boxes waiting for the next update */
    if (lights_moved) lighting_changed(svc, PC_DDGI_WAKE_AGE_NUDGE); /* a small step a frame */
    for (uint32_t i = 0; any && i < n; i++) {
        if (!instance_moved(svc, before, i)) continue;
        const rd_instance *in = &s->instances[i];
        float lo[3], hi[3];
        empty_box(lo, hi); /* rd_world_wake_box grows the boxes by a probe spacing */
        grow_by_mesh(svc, in->mesh, &before[16 * i], lo, hi);
        rd_world_wake_box(&svc->world, lo, hi, PC_DDGI_WAKE_AGE_GEOMETRY);
        empty_box(lo, hi);
        grow_by_mesh(svc, in->mesh, s->nodes[in->node].world, lo, hi);
        rd_world_wake_box(&svc->world, lo, hi, PC_DDGI_WAKE_AGE_GEOMETRY);
    }
    if (any) {
        svc->gi_updates = 0;
        if (svc->was_converged) publish_probes(svc);
    }
done:
    free(before);
    free(light_was);
    return vr;
}

/* The posed nodes' documents, without events: GET /v1/nodes/{id} and the scene document's
 * nodes (both are not updated every frame; this runs on play, pause and seek). */
static void publish_pose(srv_scene_service *svc)
{
    const rd_scene *s = &svc->st.scene;
    uint32_t *ids = malloc((s->node_count ? s->node_count : 1) * sizeof *ids);
    cJSON **docs = malloc((s->node_count ? s->node_count : 1) * sizeof *docs);
    if (!ids || !docs) abort();
    uint32_t n = 0;
    for (uint32_t i = 0; i < s->node_count; i++) {
        if (!svc->animated[i]) continue;
        ids[n] = i;
        docs[n++] = srv_json_node(i, &s->nodes[i]);
    }
    srv_snapshot_pose_nodes(svc->snap, ids, docs, n);
    free(ids);
    free(docs);
    srv_snapshot_patch_scene(svc->snap, "nodes", nodes_json(s));
}

/* A new scene: which nodes its animations move, the clock at 0 (playing when there is
 * something to play) and the scene posed there. Before publish_scene. */
static void load_playback(srv_scene_service *svc)
{
    const rd_scene *s = &svc->st.scene;
    free(svc->animated);
    svc->animated = calloc(s->node_count ? s->node_count : 1, sizeof *svc->animated);
    if (!svc->animated) abort();
    rd_scene_animated_nodes(s, svc->animated);
    srv_playback_load(&svc->playback, s->animation_count, rd_scene_animation_duration(s),
                      srv_mono_ms());
    char err[256];
    bool moved;
    if (pose_scene(svc, false, &moved, err, sizeof err) != RD_VK_OK)
        srv_warn("render", "the scene's animations cannot be posed: %s", err);
    srv_snapshot_set_playback(svc->snap, &svc->playback, false);
    if (s->animation_count)
        srv_info("render", "%u animation(s) over %.3g s: playing", s->animation_count,
                 svc->playback.duration_s);
}

void srv_scene_service_watch(srv_scene_service *svc, unsigned viewers, double now_ms)
{
    /* the clock starts or stops: GET answers extrapolate from the new copy (no event) */
    if (srv_playback_set_watched(&svc->playback, viewers > 0, now_ms))
        srv_snapshot_set_playback(svc->snap, &svc->playback, true);
}

/* PATCH /v1/animation: seek and/or play or pause, then pose the scene at the clock's time and
 * publish the posed nodes (a seek, or where a pause stopped). */
static unsigned patch_playback(srv_scene_service *svc, srv_cmd *c)
{
    double now = srv_mono_ms();
    srv_playback *p = &svc->playback;
    srv_playback_advance(p, now);
    if (c->playback.has & SRV_PLAY_TIME) srv_playback_seek(p, c->playback.time_s, now);
    if (c->playback.has & SRV_PLAY_PLAYING) srv_playback_set_playing(p, c->playback.playing, now);
    char err[256];
    bool moved = false;
    if (pose_scene(svc, true, &moved, err, sizeof err) != RD_VK_OK) {
        srv_cmd_fail(c, 500, SRV_ERR_GPU, err);
        return 0;
    }
    if (svc->st.scene.animation_count) publish_pose(svc);
    srv_snapshot_set_playback(svc->snap, p, false);
    srv_cmd_complete_json(c, 200, srv_json_playback(p, now));
    return moved ? SRV_CHANGE_VIEWS : 0;
}

static unsigned replace_scene(srv_scene_service *svc, srv_cmd *c)
{
    char err[256];
    rd_gpu_scene ngs;
    double t0 = srv_mono_ms();
    rd_vk_result vr;
    if (c->prepared) {
        vr = rd_gpu_scene_upload(svc->vk, &ngs, c->scene, c->prepared, err, sizeof err);
    } else {
        vr = rd_gpu_scene_create(svc->vk, &ngs, c->scene, err, sizeof err);
    }
    if (vr != RD_VK_OK) {
        srv_warn("render", "uploaded scene rejected by the GPU: %s", err);
        srv_cmd_fail(c, vr == RD_VK_ERR_UNSUPPORTED ? 422 : 500,
                     vr == RD_VK_ERR_UNSUPPORTED ? SRV_ERR_INVALID_GLTF : SRV_ERR_GPU, err);
        return 0;
    }
    rd_gpu_scene_destroy(svc->vk, &svc->gs);
    svc->gs = ngs;
    rd_world_set_scene(&svc->world, &svc->gs);
    srv_state_set_scene(&svc->st, c->scene, c->source, ++svc->generation_counter);
    memcpy(svc->st.file_name, c->file_name, sizeof svc->st.file_name);
    free(c->scene);
    c->scene = NULL;
    /* a scene without light got the default key light (scene_state.h), which the GPU scene,
     * built from the upload, does not have yet */
    if (svc->st.default_lighting &&
        rd_gpu_scene_update_lights(svc->vk, &svc->gs, &svc->st.scene, err, sizeof err) != RD_VK_OK)
        srv_warn("render", "the default lighting could not be uploaded: %s", err);
    apply_sky(svc);
    srv_animation_reset(&svc->anim);
    load_playback(svc);
    if (configure_gi(svc, err, sizeof err) != RD_VK_OK)
        srv_warn("render", "global illumination is off for this scene: %s", err);
    srv_info("render",
             "scene replaced (generation %llu, %llu triangles, %.0f ms on the render thread)",
             (unsigned long long)svc->st.generation, (unsigned long long)svc->st.scene.tri_total,
             srv_mono_ms() - t0);
    publish_scene(svc);
    pthread_mutex_lock(&c->mu);
    c->reply.scene_generation = svc->st.generation;
    pthread_mutex_unlock(&c->mu);
    srv_cmd_complete_json(c, 200, scene_json(svc));
    return SRV_CHANGE_VIEWS | SRV_CHANGE_SCENE | SRV_CHANGE_PERSIST;
}

/* PUT /v1/environment (an image: the mode becomes image) or DELETE (none: image mode shows the
 * sky uniformly, so the mode goes back to uniform). */
static unsigned set_environment_image(srv_scene_service *svc, srv_cmd *c)
{
    char err[256];
    bool upload = c->env_image != NULL;
    rd_env_image none = {0};
    rd_vk_result vr =
        rd_world_set_environment_image(&svc->world, upload ? c->env_image : &none, err, sizeof err);
    if (vr != RD_VK_OK) {
        srv_cmd_fail(c, 500, SRV_ERR_GPU, err);
        apply_sky(svc);
        return 0;
    }
    svc->st.settings.sky_mode = upload ? PC_ENV_IMAGE : PC_ENV_UNIFORM;
    apply_sky(svc);
    lighting_changed(svc, PC_DDGI_WAKE_AGE_LIGHT);
    srv_snapshot_publish(svc->snap, SRV_DOC_SETTINGS, srv_json_settings(&svc->st.settings), false);
    publish_scene(svc);
    if (upload) {
        cJSON *j = cJSON_CreateObject();
        cJSON_AddNumberToObject(j, "width", svc->world.image.width);
        cJSON_AddNumberToObject(j, "height", svc->world.image.height);
        cJSON_AddStringToObject(j, "sky_mode", "image");
        srv_cmd_complete_json(c, 200, j);
    } else {
        srv_cmd_complete(c, 204, NULL);
    }
    return SRV_CHANGE_VIEWS | SRV_CHANGE_PERSIST;
}

static unsigned patch_settings(srv_scene_service *svc, srv_cmd *c)
{
    srv_api_error e;
    srv_settings old = svc->st.settings;
    if (!srv_state_settings_apply(&svc->st.settings, &c->settings, &e)) {
        srv_cmd_complete_error(c, &e);
        return 0;
    }
    if (c->settings.has & SRV_SET_GI_FIELDS) {
        char err[256];
        rd_vk_result vr = configure_gi(svc, err, sizeof err);
        if (vr != RD_VK_OK) {
            svc->st.settings = old;
            char err2[256];
            configure_gi(svc, err2, sizeof err2);
            if (vr == RD_VK_ERR_UNSUPPORTED)
                srv_cmd_fail(c, 400, SRV_ERR_INVALID_FIELD, err);
            else
                srv_cmd_fail(c, 500, SRV_ERR_GPU, err);
            return 0;
        }
        publish_probes(svc);
    }
    if (c->settings.has & SRV_SET_ENV_FIELDS) {
        apply_sky(svc);
        lighting_changed(svc, PC_DDGI_WAKE_AGE_LIGHT);
    }
    if (!svc->st.settings.animate) srv_animation_pause(&svc->anim);
    srv_snapshot_publish(svc->snap, SRV_DOC_SETTINGS, srv_json_settings(&svc->st.settings), false);
    srv_cmd_complete_json(c, 200, srv_json_settings(&svc->st.settings));
    unsigned changes = SRV_CHANGE_VIEWS | SRV_CHANGE_PERSIST;
    if (c->settings.has & (SRV_SET_WIDTH | SRV_SET_HEIGHT)) changes |= SRV_CHANGE_SIZE;
    if (c->settings.has & SRV_SET_MAX_PIXELS) changes |= SRV_CHANGE_LIMITS;
    return changes;
}

unsigned srv_scene_service_apply(srv_scene_service *svc, srv_cmd *c)
{
    srv_api_error e;
    srv_scene_state *st = &svc->st;
    if (svc->vk->device_lost) {
        srv_cmd_fail(c, 503, SRV_ERR_GPU, "The GPU device was lost; restart the server.");
        return 0;
    }
    switch (c->kind) {
    case SRV_CMD_REPLACE_SCENE:
        return replace_scene(svc, c);
    case SRV_CMD_PATCH_SETTINGS:
        return patch_settings(svc, c);
    case SRV_CMD_PATCH_ANIMATION:
        return patch_playback(svc, c);
    case SRV_CMD_SET_ENVIRONMENT:
        return set_environment_image(svc, c);
    case SRV_CMD_PATCH_LIGHT: {
        int i = srv_state_light_index(st, c->id);
        if (i < 0) {
            srv_api_fail(&e, 404, SRV_ERR_NOT_FOUND, "There is no light with id %u.", c->id);
            srv_cmd_complete_error(c, &e);
            return 0;
        }
        if (!srv_state_light_apply(&st->scene.lights[i], &c->light, &e)) {
            srv_cmd_complete_error(c, &e);
            return 0;
        }
        if (svc->anim.valid && svc->anim.light == c->id) srv_animation_reset(&svc->anim);
        bool took_over = st->default_lighting && c->id == st->default_light_id;
        if (took_over) st->default_lighting = false; /* the key light is the user's now */
        if (!lights_changed(svc, c)) return 0;
        if (took_over) default_lighting_ended(svc);
        srv_cmd_complete_json(c, 200, srv_json_light(c->id, &st->scene.lights[i]));
        return SRV_CHANGE_VIEWS | SRV_CHANGE_PERSIST;
    }
    case SRV_CMD_ADD_LIGHT: {
        uint32_t id;
        if (!srv_state_light_add(st, &c->light, &id, &e)) {
            srv_cmd_complete_error(c, &e);
            return 0;
        }
        /* the user's first light replaces the default lighting */
        bool replaced = srv_state_drop_default_lighting(st);
        if (!lights_changed(svc, c)) return 0;
        if (replaced) default_lighting_ended(svc);
        srv_cmd_complete_json(c, 201,
                              srv_json_light(id, &st->scene.lights[srv_state_light_index(st, id)]));
        return SRV_CHANGE_VIEWS | SRV_CHANGE_PERSIST;
    }
    case SRV_CMD_DELETE_LIGHT: {
        if (!srv_state_light_delete(st, c->id, &e)) {
            srv_cmd_complete_error(c, &e);
            return 0;
        }
        if (svc->anim.valid && svc->anim.light == c->id) srv_animation_reset(&svc->anim);
        bool removed_default = st->default_lighting && c->id == st->default_light_id;
        if (removed_default) st->default_lighting = false;
        if (!lights_changed(svc, c)) return 0;
        if (removed_default) default_lighting_ended(svc);
        srv_cmd_complete(c, 204, NULL);
        return SRV_CHANGE_VIEWS | SRV_CHANGE_PERSIST;
    }
    case SRV_CMD_PATCH_NODE: {
        float old_lo[3], old_hi[3], lo[3], hi[3];
        bool had_mesh = c->id < st->scene.node_count && node_bounds(svc, c->id, old_lo, old_hi);
        if (!srv_state_node_apply(st, c->id, &c->node, &e)) {
            srv_cmd_complete_error(c, &e);
            return 0;
        }
        char err[256];
        /* the top-level BVH follows the node; lights attached to it move too */
        if (rd_gpu_scene_update_instances(svc->vk, &svc->gs, &st->scene, err, sizeof err) !=
            RD_VK_OK) {
            srv_cmd_fail(c, 500, SRV_ERR_GPU, err);
            return 0;
        }
        if (!upload_lights(svc, c)) return 0;
        /* lights the node carries may reach anywhere; probes near its old and new place
         * wake with the geometry age (rd_world_wake_box grows the boxes by a probe spacing) */
        if (node_carries_light(&st->scene, c->id))
            rd_world_wake_all(&svc->world, PC_DDGI_WAKE_AGE_LIGHT);
        if (had_mesh && node_bounds(svc, c->id, lo, hi)) {
            rd_world_wake_box(&svc->world, old_lo, old_hi, PC_DDGI_WAKE_AGE_GEOMETRY);
            rd_world_wake_box(&svc->world, lo, hi, PC_DDGI_WAKE_AGE_GEOMETRY);
        }
        svc->gi_updates = 0;
        if (svc->was_converged) publish_probes(svc);
        srv_snapshot_set_node(svc->snap, c->id, srv_json_node(c->id, &st->scene.nodes[c->id]));
        publish_lights(svc, true); /* attached lights moved along */
        srv_cmd_complete_json(c, 200, srv_json_node(c->id, &st->scene.nodes[c->id]));
        return SRV_CHANGE_VIEWS | SRV_CHANGE_PERSIST;
    }
    default:
        srv_cmd_fail(c, 500, SRV_ERR_INTERNAL, "Not a world command.");
        return 0;
    }
}

rd_vk_result srv_scene_service_advance(srv_scene_service *svc, bool animating, unsigned updates,
                                       double now_ms, char *err, size_t errlen)
{
    if (animating && demo_runs(svc, 1)) { /* animating: someone watches */
        if (srv_animation_step(&svc->anim, &svc->st, now_ms) && upload_lights(svc, NULL)) {
            lighting_changed(svc, PC_DDGI_WAKE_AGE_NUDGE); /* a small step each frame */
            publish_lights(svc, true); /* GET answers follow; no event per frame */
        }
    } else {
        srv_animation_pause(&svc->anim);
    }
    if (srv_playback_advance(&svc->playback, now_ms)) { /* it moves only while it runs */
        bool moved;
        rd_vk_result vr = pose_scene(svc, true, &moved, err, errlen);
        if (vr != RD_VK_OK) return vr;
    }
    if (!svc->world.gi) updates = 0;
    if (animating && svc->world.gi && updates == 0) updates = 1;
    /* updates stop as soon as the field has converged: then every probe sleeps */
    unsigned done = 0;
    rd_vk_result vr = rd_world_converge(&svc->world, updates, &done, err, errlen);
    if (vr == RD_VK_OK && svc->gi_updates < UINT32_MAX - done) svc->gi_updates += done;
    if (svc->was_converged != !srv_scene_service_converging(svc)) publish_probes(svc);
    return vr;
}

cJSON *srv_scene_service_state_json(srv_scene_service *svc, const srv_camera *default_camera)
{
    svc->st.camera = *default_camera;
    return srv_state_to_json(&svc->st);
}

/* ---- lifecycle ------------------------------------------------------------------------------ */

rd_vk_result srv_scene_service_init(srv_scene_service *svc, rd_vk *vk, srv_snapshot *snap,
                                    const srv_settings *settings, rd_scene *scene,
                                    const char *source, uint64_t generation,
                                    uint64_t generation_base, const cJSON *saved_state, char *err,
                                    size_t errlen)
{
    memset(svc, 0, sizeof *svc);
    svc->vk = vk;
    svc->snap = snap;
    srv_state_init(&svc->st);
    svc->st.settings = *settings;
    svc->generation_counter = generation_base > generation ? generation_base : generation;
    srv_state_set_scene(&svc->st, scene, source, generation);
    if (saved_state) {
        srv_api_error e;
        if (!srv_state_restore(&svc->st, saved_state, &e))
            srv_warn("render", "saved state not applied: %s", e.message);
        else if (e.message[0])
            srv_warn("render", "saved state partly applied: %s", e.message);
        else
            srv_info("render", "restored camera, lights, nodes and settings");
    }
    rd_vk_result vr = rd_gpu_scene_create(vk, &svc->gs, &svc->st.scene, err, errlen);
    svc->gs_ok = vr == RD_VK_OK;
    if (vr == RD_VK_OK) vr = rd_world_create(vk, &svc->world, err, errlen);
    svc->world_ok = vr == RD_VK_OK;
    if (vr != RD_VK_OK) {
        srv_scene_service_dispose(svc);
        return vr;
    }
    rd_world_set_scene(&svc->world, &svc->gs);
    apply_sky(svc);
    load_playback(svc);
    if (configure_gi(svc, err, errlen) != RD_VK_OK) {
        srv_warn("render", "global illumination is off: %s", err);
        err[0] = '\0';
    }
    publish_scene(svc);
    return RD_VK_OK;
}

void srv_scene_service_dispose(srv_scene_service *svc)
{
    if (svc->world_ok) rd_world_destroy(&svc->world);
    if (svc->gs_ok) rd_gpu_scene_destroy(svc->vk, &svc->gs);
    svc->world_ok = svc->gs_ok = false;
    free(svc->animated);
    svc->animated = NULL;
    srv_state_dispose(&svc->st);
}
