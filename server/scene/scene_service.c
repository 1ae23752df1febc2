/* scene_service.c: the world's state, GPU resources and API semantics (see scene_service.h);
 * its documents are in scene_documents.c, its glTF animations in scene_pose.c. */
#include "server/scene/scene_service_internal.h"
#include "server/base/clock.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "server/api/api_json.h"
#include "server/base/log.h"

static rd_vk_result configure_gi(srv_scene_service *svc, char *err, size_t errlen)
{
    rd_ddgi_settings gi;
    srv_settings_to_gi(&svc->st.settings, &gi); /* pathtrace: no probes */
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
void srv_scene_lighting_changed(srv_scene_service *svc, float age)
{
    rd_world_wake_all(&svc->world, age);
    svc->gi_updates = 0;
    if (svc->was_converged) srv_scene_publish_probes(svc);
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
void srv_scene_grow_by_mesh(const srv_scene_service *svc, uint32_t mesh, const float m[16],
                            float lo[3], float hi[3])
{
    float a[3], b[3];
    rd_gpu_scene_mesh_world_bounds(&svc->gs, mesh, m, a, b);
    for (int k = 0; k < 3; k++) {
        lo[k] = fminf(lo[k], a[k]);
        hi[k] = fmaxf(hi[k], b[k]);
    }
}

void srv_scene_empty_box(float lo[3], float hi[3])
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
    srv_scene_empty_box(lo, hi);
    for (uint32_t i = 0; i < s->instance_count; i++) {
        int32_t n = (int32_t)s->instances[i].node;
        unsigned depth = 0;
        while (n >= 0 && (uint32_t)n != node && depth++ < s->node_count)
            n = s->nodes[n].parent;
        if (n < 0 || (uint32_t)n != node) continue;
        srv_scene_grow_by_mesh(svc, s->instances[i].mesh, s->nodes[s->instances[i].node].world, lo,
                               hi);
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

/* Says in the log when a scene arriving got default lighting, and why. */
static void log_default_lighting(const srv_scene_service *svc)
{
    if (!svc->st.default_lighting) return;
    char why[160];
    rd_default_lighting_describe(&svc->st.lighting, why, sizeof why);
    srv_info("render", "default lighting added (%s)", why);
}

/* Default lighting ended (the user added a light, or took the key light over): the default
 * environment goes too; GET /v1/scene says so. */
static void default_lighting_ended(srv_scene_service *svc)
{
    apply_sky(svc);
    srv_scene_lighting_changed(svc, PC_DDGI_WAKE_AGE_LIGHT);
    srv_scene_publish_scene(svc);
}

/* After a light was added, changed or removed: upload, reconverge, tell everyone. */
static bool lights_changed(srv_scene_service *svc, srv_cmd *c)
{
    if (!upload_lights(svc, c)) return false;
    srv_scene_lighting_changed(svc, PC_DDGI_WAKE_AGE_LIGHT);
    srv_scene_publish_lights(svc, false);
    return true;
}

/* ---- the scene's animations (glTF) ------------------------------------------------------- */

static unsigned replace_scene(srv_scene_service *svc, srv_cmd *c)
{
    char err[256];
    rd_gpu_scene ngs;
    double t0 = srv_mono_ms();
    rd_vk_result vr;
    if (c->staged) { /* staged by the uploading connection: only the copies run here */
        vr = rd_gpu_scene_commit(c->staged, &ngs, err, sizeof err);
    } else {
        vr = rd_gpu_scene_create(svc->vk, &ngs, c->scene, err, sizeof err);
    }
    if (vr != RD_VK_OK) {
        srv_warn("render", "uploaded scene rejected by the GPU: %s", err);
        srv_cmd_fail(c, vr == RD_VK_ERR_UNSUPPORTED ? 422 : 500,
                     vr == RD_VK_ERR_UNSUPPORTED ? SRV_ERR_INVALID_GLTF : SRV_ERR_GPU, err);
        return 0;
    }
    double t1 = srv_mono_ms();
    rd_vk_wait_idle(svc->vk); /* frames in flight may read the scene replaced */
    rd_gpu_scene_destroy(svc->vk, &svc->gs);
    svc->gs = ngs;
    rd_world_set_scene(&svc->world, &svc->gs);
    srv_state_set_scene(&svc->st, c->scene, c->source, ++svc->generation_counter);
    memcpy(svc->st.file_name, c->file_name, sizeof svc->st.file_name);
    free(c->scene);
    c->scene = NULL;
    log_default_lighting(svc);
    /* a scene without light got the default key light (scene_state.h), which the GPU scene,
     * built from the upload, does not have yet */
    if (svc->st.default_lighting &&
        rd_gpu_scene_update_lights(svc->vk, &svc->gs, &svc->st.scene, err, sizeof err) != RD_VK_OK)
        srv_warn("render", "the default lighting could not be uploaded: %s", err);
    apply_sky(svc);
    srv_animation_reset(&svc->anim);
    srv_scene_load_playback(svc);
    if (configure_gi(svc, err, sizeof err) != RD_VK_OK)
        srv_warn("render", "global illumination is off for this scene: %s", err);
    double t2 = srv_mono_ms();
    srv_info("render",
             "scene replaced (generation %llu, %llu triangles, %.1f ms on the render thread: "
             "GPU copies %.1f, the rest %.1f)",
             (unsigned long long)svc->st.generation, (unsigned long long)svc->st.scene.tri_total,
             t2 - t0, t1 - t0, t2 - t1);
    srv_scene_publish_scene(svc);
    pthread_mutex_lock(&c->mail.mu);
    c->scene_generation = svc->st.generation;
    pthread_mutex_unlock(&c->mail.mu);
    srv_cmd_complete_json(c, 200, srv_scene_json(svc));
    return SRV_CHANGE_VIEWS | SRV_CHANGE_SCENE | SRV_CHANGE_PERSIST;
}

/* PUT /v1/environment (an image: the mode becomes image) or DELETE (none: image mode shows the
 * sky uniformly, so the mode goes back to uniform). */
static unsigned set_environment_image(srv_scene_service *svc, srv_cmd *c)
{
    char err[256];
    bool upload = c->env_staged != NULL;
    double t0 = srv_mono_ms();
    rd_vk_result vr = rd_world_set_environment_staged(&svc->world, c->env_staged, err, sizeof err);
    srv_debug("render", "environment %s in %.1f ms on the render thread",
              upload ? "replaced" : "dropped", srv_mono_ms() - t0);
    if (vr != RD_VK_OK) {
        srv_cmd_fail(c, 500, SRV_ERR_GPU, err);
        apply_sky(svc);
        return 0;
    }
    svc->st.settings.sky_mode = upload ? PC_ENV_IMAGE : PC_ENV_UNIFORM;
    apply_sky(svc);
    srv_scene_lighting_changed(svc, PC_DDGI_WAKE_AGE_LIGHT);
    srv_snapshot_publish(svc->snap, SRV_DOC_SETTINGS, srv_json_settings(&svc->st.settings), false);
    srv_scene_publish_scene(svc);
    if (upload) {
        cJSON *j = cJSON_CreateObject();
        cJSON_AddNumberToObject(j, "width", svc->world.env_width);
        cJSON_AddNumberToObject(j, "height", svc->world.env_height);
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
        srv_scene_publish_probes(svc);
    }
    if (c->settings.has & SRV_SET_ENV_FIELDS) {
        apply_sky(svc);
        srv_scene_lighting_changed(svc, PC_DDGI_WAKE_AGE_LIGHT);
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
        return srv_scene_patch_playback(svc, c);
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
        /* the top-level BVH follows the node (and the BLASes of meshes skinned to it); lights
         * attached to it move too */
        if (rd_gpu_scene_update_pose(svc->vk, &svc->gs, &st->scene, NULL, err, sizeof err) !=
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
        if (svc->was_converged) srv_scene_publish_probes(svc);
        srv_snapshot_set_node(svc->snap, c->id, srv_json_node(c->id, &st->scene.nodes[c->id]));
        srv_scene_publish_lights(svc, true); /* attached lights moved along */
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
            srv_scene_lighting_changed(svc, PC_DDGI_WAKE_AGE_NUDGE); /* a small step each frame */
            srv_scene_publish_lights(svc, true); /* GET answers follow; no event per frame */
        }
    } else {
        srv_animation_pause(&svc->anim);
    }
    if (srv_playback_advance(&svc->playback, now_ms)) { /* it moves only while it runs */
        bool moved;
        rd_vk_result vr = srv_scene_pose(svc, true, &moved, err, errlen);
        if (vr != RD_VK_OK) return vr;
    }
    if (!svc->world.gi) updates = 0;
    if (animating && svc->world.gi && updates == 0) updates = 1;
    /* updates stop as soon as the field has converged: then every probe sleeps */
    unsigned done = 0;
    rd_vk_result vr = rd_world_converge(&svc->world, updates, &done, err, errlen);
    if (vr == RD_VK_OK && svc->gi_updates < UINT32_MAX - done) svc->gi_updates += done;
    if (svc->was_converged != !srv_scene_service_converging(svc)) srv_scene_publish_probes(svc);
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
    log_default_lighting(svc);
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
    srv_scene_load_playback(svc);
    if (configure_gi(svc, err, errlen) != RD_VK_OK) {
        srv_warn("render", "global illumination is off: %s", err);
        err[0] = '\0';
    }
    srv_scene_publish_scene(svc);
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
