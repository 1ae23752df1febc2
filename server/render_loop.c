/* render_loop.c: the render thread: command queue, dirty tracking, pacing, GPU work. */
#include "render_loop.h"
#include "clock.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "api_json.h"
#include "log.h"
#include "readback.h"
#include "renderer/render.h"
#include "scene_state.h"

#define QUEUE_MAX 4096 /* commands waiting; viewers posting faster are refused */
#define PERSIST_INTERVAL_MS 250
#define ANIM_PERIOD_S 12.0
#define FPS_WINDOW 256
/* Probe updates per frame while the probes converge and no input arrives: the field settles
 * in a quarter of the frames (a probe update costs less than a frame's primary and shading
 * passes), and the frame right after an input still carries one update only. */
#define CONVERGE_UPDATES_PER_FRAME 4

struct srv_render_loop {
    srv_render_config cfg;
    rd_vk vk;
    bool vk_ok;
    rd_renderer r;
    rd_gpu_scene gs;
    srv_readback rb;
    srv_scene_state st;

    pthread_t thread;
    bool started;
    pthread_mutex_t mu; /* queue */
    pthread_cond_t cv;
    srv_cmd *head, *tail;
    unsigned queued;
    bool stop;
    uint64_t next_ticket;
    atomic_uint viewers;

    /* render thread only */
    uint64_t applied_ticket;
    uint64_t next_frame_id;
    uint64_t generation_counter;
    bool dirty;
    unsigned gi_updates, gi_converge;
    unsigned pt_samples, pt_target; /* progressive path tracing (gi_mode pathtrace) */
    double last_motion_ms, last_render_ms, last_render_end_ms;
    bool need_still;
    srv_image *last_image;
    srv_frame_info last_info;
    bool persist_dirty;
    double last_persist_ms;
    bool anim_valid;
    uint32_t anim_light;
    float anim_center[3], anim_radius;
    double anim_phase_s, anim_last_ms;

    pthread_mutex_t stats_mu;
    srv_render_stats stats;
    double frame_times[FPS_WINDOW];
    unsigned frame_time_next;
};



/* ---- commands ------------------------------------------------------------------------------- */

srv_cmd *srv_cmd_new(srv_cmd_kind kind)
{
    srv_cmd *c = calloc(1, sizeof *c);
    if (!c) abort();
    c->kind = kind;
    atomic_init(&c->refs, 1);
    pthread_mutex_init(&c->mu, NULL);
    pthread_cond_init(&c->cv, NULL);
    return c;
}

void srv_cmd_unref(srv_cmd *c)
{
    if (!c || atomic_fetch_sub(&c->refs, 1) != 1) return;
    if (c->scene) {
        rd_scene_destroy(c->scene);
        free(c->scene);
    }
    free(c->reply.body);
    pthread_cond_destroy(&c->cv);
    pthread_mutex_destroy(&c->mu);
    free(c);
}

/* Hands the reply to the waiting thread (or drops it when nobody waits any more). */
static void complete(srv_cmd *c, int status, char *body)
{
    pthread_mutex_lock(&c->mu);
    if (c->abandoned) {
        free(body);
    } else {
        c->reply.status = status;
        c->reply.body = body;
    }
    c->done = true;
    pthread_cond_broadcast(&c->cv);
    pthread_mutex_unlock(&c->mu);
}

static void complete_json(srv_cmd *c, int status, cJSON *j)
{
    complete(c, status, srv_json_print_delete(j));
}

static void complete_error(srv_cmd *c, const srv_api_error *e)
{
    complete(c, e->status, srv_json_error_body(e->code, e->message));
}

static void fail(srv_cmd *c, int status, const char *code, const char *message)
{
    complete(c, status, srv_json_error_body(code, message));
}

/* Appends c to the queue with the next ticket; false when stopped or full. Lock held. */
static bool enqueue_locked(srv_render_loop *l, srv_cmd *c, bool bounded)
{
    if (l->stop || (bounded && l->queued >= QUEUE_MAX)) return false;
    c->ticket = ++l->next_ticket;
    c->next = NULL;
    if (l->tail)
        l->tail->next = c;
    else
        l->head = c;
    l->tail = c;
    l->queued++;
    pthread_cond_signal(&l->cv);
    return true;
}

bool srv_render_call(srv_render_loop *l, srv_cmd *c, unsigned timeout_ms)
{
    atomic_fetch_add(&c->refs, 1); /* the queue's reference */
    pthread_mutex_lock(&l->mu);
    bool queued = enqueue_locked(l, c, false);
    pthread_mutex_unlock(&l->mu);
    if (!queued) {
        srv_cmd_unref(c);
        fail(c, 503, SRV_ERR_UNAVAILABLE, "The server is shutting down.");
        return false;
    }
    struct timespec deadline;
    clock_gettime(CLOCK_REALTIME, &deadline);
    deadline.tv_sec += timeout_ms / 1000;
    deadline.tv_nsec += (long)(timeout_ms % 1000) * 1000000L;
    if (deadline.tv_nsec >= 1000000000L) deadline.tv_sec++, deadline.tv_nsec -= 1000000000L;
    pthread_mutex_lock(&c->mu);
    while (!c->done)
        if (pthread_cond_timedwait(&c->cv, &c->mu, &deadline) != 0) break;
    bool ok = c->done;
    if (!ok) {
        c->abandoned = true;
        c->reply.status = 503;
        c->reply.body = srv_json_error_body(
            SRV_ERR_UNAVAILABLE, "The render thread did not answer in time; the change may still "
                                 "be applied.");
    }
    pthread_mutex_unlock(&c->mu);
    return ok;
}

uint64_t srv_render_post(srv_render_loop *l, srv_cmd *c)
{
    pthread_mutex_lock(&l->mu);
    bool queued = enqueue_locked(l, c, true);
    uint64_t ticket = queued ? c->ticket : 0;
    pthread_mutex_unlock(&l->mu);
    if (!queued) srv_cmd_unref(c);
    return ticket;
}

void srv_render_set_viewers(srv_render_loop *l, unsigned viewers)
{
    atomic_store(&l->viewers, viewers);
    pthread_mutex_lock(&l->mu);
    pthread_cond_signal(&l->cv);
    pthread_mutex_unlock(&l->mu);
}

/* ---- state changes ------------------------------------------------------------------------ */

static unsigned converge_updates(const srv_settings *s)
{
    if (s->gi_mode == 0) return 0;
    double h = s->hysteresis > 0 ? s->hysteresis : 0.97;
    /* updates until the old value's weight falls below 1%: h^n < 0.01 */
    double n = ceil(log(0.01) / log(h < 0.999 ? h : 0.999));
    return n < 4 ? 4 : n > 1000 ? 1000 : (unsigned)n;
}

static void mark_view_changed(srv_render_loop *l, bool input, bool lighting)
{
    l->dirty = true;
    if (input) l->last_motion_ms = srv_mono_ms();
    if (lighting) l->gi_updates = 0;
    l->pt_samples = 0; /* any change restarts the path-traced accumulation */
}

static rd_vk_result configure_gi(srv_render_loop *l, char *err, size_t errlen)
{
    rd_ddgi_settings gi;
    srv_settings_to_gi(&l->st.settings, &gi);
    rd_vk_result vr = rd_renderer_configure_gi(&l->r, l->st.scene.bounds_min,
                                               l->st.scene.bounds_max, &gi, err, errlen);
    l->gi_updates = 0;
    l->gi_converge = l->r.gi ? converge_updates(&l->st.settings) : 0;
    l->pt_samples = 0;
    l->pt_target = l->st.settings.gi_mode == SRV_GI_PATHTRACE ? (l->vk.is_cpu ? 64 : 4096) : 0;
    return vr;
}

static cJSON *scene_json(srv_render_loop *l)
{
    const rd_scene *s = &l->st.scene;
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "source", l->st.source);
    cJSON_AddNumberToObject(j, "generation", (double)l->st.generation);
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
    cJSON *nodes = cJSON_AddArrayToObject(j, "nodes");
    const uint32_t node_limit = 1000;
    for (uint32_t i = 0; i < s->node_count && i < node_limit; i++)
        cJSON_AddItemToArray(nodes, srv_json_node(i, &s->nodes[i]));
    cJSON_AddBoolToObject(j, "nodes_truncated", s->node_count > node_limit);
    cJSON *lights = cJSON_AddArrayToObject(j, "lights");
    for (uint32_t i = 0; i < s->light_count; i++)
        cJSON_AddItemToArray(lights, srv_json_light(l->st.light_ids[i], &s->lights[i]));
    cJSON *bvh = cJSON_AddObjectToObject(j, "bvh");
    cJSON_AddNumberToObject(bvh, "triangles", (double)l->gs.tri_count);
    cJSON_AddNumberToObject(bvh, "blas_nodes", (double)l->gs.blas_node_count);
    cJSON_AddNumberToObject(bvh, "tlas_nodes", l->gs.tlas_node_count);
    cJSON_AddNumberToObject(bvh, "max_blas_depth", l->gs.max_blas_depth);
    cJSON_AddNumberToObject(bvh, "blas_build_ms", l->gs.blas_build_ms);
    cJSON_AddNumberToObject(bvh, "tlas_build_ms", l->gs.tlas_build_ms);
    cJSON_AddNumberToObject(bvh, "upload_ms", l->gs.upload_ms);
    cJSON *probes = cJSON_AddObjectToObject(j, "probes");
    cJSON_AddStringToObject(probes, "mode",
                            l->r.gi ? srv_gi_mode_name(l->st.settings.gi_mode) : "off");
    const pc_ddgi_volume *v = &l->r.ddgi.vol;
    unsigned counts[3] = {0, 0, 0};
    float spacing[3] = {0, 0, 0}, origin[3] = {0, 0, 0};
    if (l->r.gi) {
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
    cJSON_AddNumberToObject(probes, "rays_per_probe", l->r.gi ? v->counts.w : 0);
    cJSON_AddNumberToObject(probes, "updates", l->r.gi ? l->r.ddgi.updates : 0);
    cJSON_AddBoolToObject(probes, "converged", (!l->r.gi || l->gi_updates >= l->gi_converge) &&
                                                   l->pt_samples >= l->pt_target);
    cJSON *w = cJSON_AddArrayToObject(j, "warnings");
    for (uint32_t i = 0; i < s->warning_count; i++)
        cJSON_AddItemToArray(w, cJSON_CreateString(s->warnings[i]));
    return j;
}

static cJSON *lights_json(srv_render_loop *l)
{
    cJSON *a = cJSON_CreateArray();
    for (uint32_t i = 0; i < l->st.scene.light_count; i++)
        cJSON_AddItemToArray(a, srv_json_light(l->st.light_ids[i], &l->st.scene.lights[i]));
    cJSON *j = cJSON_CreateObject();
    cJSON_AddItemToObject(j, "lights", a);
    return j;
}

static bool upload_lights(srv_render_loop *l, srv_cmd *c)
{
    char err[256];
    if (rd_gpu_scene_update_lights(&l->vk, &l->gs, &l->st.scene, err, sizeof err) != RD_VK_OK) {
        if (c) fail(c, 500, SRV_ERR_GPU, err);
        return false;
    }
    return true;
}

static void replace_scene(srv_render_loop *l, srv_cmd *c)
{
    char err[256];
    rd_gpu_scene ngs;
    memset(&ngs, 0, sizeof ngs);
    double t0 = srv_mono_ms();
    rd_vk_result vr = rd_gpu_scene_create(&l->vk, &ngs, c->scene, err, sizeof err);
    if (vr != RD_VK_OK) {
        srv_warn("render", "uploaded scene rejected by the GPU: %s", err);
        fail(c, vr == RD_VK_ERR_UNSUPPORTED ? 422 : 500,
             vr == RD_VK_ERR_UNSUPPORTED ? SRV_ERR_INVALID_GLTF : SRV_ERR_GPU, err);
        return;
    }
    rd_gpu_scene_destroy(&l->vk, &l->gs);
    l->gs = ngs;
    srv_state_set_scene(&l->st, c->scene, c->source, ++l->generation_counter);
    free(c->scene);
    c->scene = NULL;
    l->anim_valid = false;
    if (configure_gi(l, err, sizeof err) != RD_VK_OK)
        srv_warn("render", "global illumination is off for this scene: %s", err);
    mark_view_changed(l, true, true);
    l->persist_dirty = true;
    srv_info("render", "scene replaced (generation %llu, %llu triangles, %.0f ms on the GPU side)",
             (unsigned long long)l->st.generation, (unsigned long long)l->st.scene.tri_total,
             srv_mono_ms() - t0);
    pthread_mutex_lock(&c->mu);
    c->reply.scene_generation = l->st.generation;
    pthread_mutex_unlock(&c->mu);
    complete_json(c, 200, scene_json(l));
}

static void patch_settings(srv_render_loop *l, srv_cmd *c)
{
    srv_api_error e;
    srv_settings old = l->st.settings;
    if (!srv_state_settings_apply(&l->st.settings, &c->settings, &e)) {
        complete_error(c, &e);
        return;
    }
    if (c->settings.has & SRV_SET_GI_FIELDS) {
        char err[256];
        rd_vk_result vr = configure_gi(l, err, sizeof err);
        if (vr != RD_VK_OK) {
            l->st.settings = old;
            char err2[256];
            configure_gi(l, err2, sizeof err2);
            if (vr == RD_VK_ERR_UNSUPPORTED)
                fail(c, 400, SRV_ERR_INVALID_FIELD, err);
            else
                fail(c, 500, SRV_ERR_GPU, err);
            return;
        }
    }
    l->gi_converge = l->r.gi ? converge_updates(&l->st.settings) : 0;
    mark_view_changed(l, true, false);
    l->persist_dirty = true;
    complete_json(c, 200, srv_json_settings(&l->st.settings));
}

static void apply(srv_render_loop *l, srv_cmd *c)
{
    srv_api_error e;
    srv_scene_state *st = &l->st;
    if (l->vk.device_lost && c->kind != SRV_CMD_VIEWER_CAMERA && c->kind != SRV_CMD_VIEWER_RESIZE &&
        c->kind != SRV_CMD_GET_SETTINGS && c->kind != SRV_CMD_GET_CAMERA) {
        fail(c, 503, SRV_ERR_GPU, "The GPU device was lost; restart the server.");
        return;
    }
    switch (c->kind) {
    case SRV_CMD_GET_SCENE:
        complete_json(c, 200, scene_json(l));
        break;
    case SRV_CMD_REPLACE_SCENE:
        replace_scene(l, c);
        break;
    case SRV_CMD_GET_CAMERA:
        complete_json(c, 200, srv_json_camera(&st->camera));
        break;
    case SRV_CMD_SET_CAMERA:
        if (!srv_state_camera_apply(&st->camera, &c->camera, c->replace, &e)) {
            complete_error(c, &e);
            break;
        }
        mark_view_changed(l, true, false);
        l->persist_dirty = true;
        complete_json(c, 200, srv_json_camera(&st->camera));
        break;
    case SRV_CMD_VIEWER_CAMERA:
        if (srv_state_camera_apply(&st->camera, &c->camera, false, &e)) {
            mark_view_changed(l, true, false);
            l->persist_dirty = true;
        } else {
            srv_debug("render", "viewer camera ignored: %s", e.message);
        }
        break;
    case SRV_CMD_VIEWER_RESIZE: {
        double w = c->width, h = c->height, max = st->settings.max_pixels;
        if (w * h > max) {
            double k = sqrt(max / (w * h));
            w = floor(w * k), h = floor(h * k);
        }
        unsigned nw = w < 16 ? 16 : w > 4096 ? 4096 : (unsigned)w;
        unsigned nh = h < 16 ? 16 : h > 4096 ? 4096 : (unsigned)h;
        if ((uint64_t)nw * nh <= st->settings.max_pixels &&
            (nw != st->settings.width || nh != st->settings.height)) {
            st->settings.width = nw;
            st->settings.height = nh;
            mark_view_changed(l, true, false);
            l->persist_dirty = true;
        }
        break;
    }
    case SRV_CMD_GET_LIGHTS:
        complete_json(c, 200, lights_json(l));
        break;
    case SRV_CMD_GET_LIGHT:
    case SRV_CMD_PATCH_LIGHT: {
        int i = srv_state_light_index(st, c->id);
        if (i < 0) {
            srv_api_fail(&e, 404, SRV_ERR_NOT_FOUND, "There is no light with id %u.", c->id);
            complete_error(c, &e);
            break;
        }
        if (c->kind == SRV_CMD_PATCH_LIGHT) {
            if (!srv_state_light_apply(&st->scene.lights[i], &c->light, &e)) {
                complete_error(c, &e);
                break;
            }
            if (l->anim_valid && l->anim_light == c->id) l->anim_valid = false;
            if (!upload_lights(l, c)) break;
            mark_view_changed(l, true, true);
            l->persist_dirty = true;
        }
        complete_json(c, 200, srv_json_light(c->id, &st->scene.lights[i]));
        break;
    }
    case SRV_CMD_ADD_LIGHT: {
        uint32_t id;
        if (!srv_state_light_add(st, &c->light, &id, &e)) {
            complete_error(c, &e);
            break;
        }
        if (!upload_lights(l, c)) break;
        mark_view_changed(l, true, true);
        l->persist_dirty = true;
        complete_json(c, 201, srv_json_light(id, &st->scene.lights[st->scene.light_count - 1]));
        break;
    }
    case SRV_CMD_DELETE_LIGHT:
        if (!srv_state_light_delete(st, c->id, &e)) {
            complete_error(c, &e);
            break;
        }
        if (l->anim_valid && l->anim_light == c->id) l->anim_valid = false;
        if (!upload_lights(l, c)) break;
        mark_view_changed(l, true, true);
        l->persist_dirty = true;
        complete(c, 204, NULL);
        break;
    case SRV_CMD_GET_NODE:
        if (c->id >= st->scene.node_count) {
            srv_api_fail(&e, 404, SRV_ERR_NOT_FOUND, "There is no node with id %u.", c->id);
            complete_error(c, &e);
            break;
        }
        complete_json(c, 200, srv_json_node(c->id, &st->scene.nodes[c->id]));
        break;
    case SRV_CMD_PATCH_NODE: {
        if (!srv_state_node_apply(st, c->id, &c->node, &e)) {
            complete_error(c, &e);
            break;
        }
        char err[256];
        /* the top-level BVH follows the node; lights attached to it move too */
        if (rd_gpu_scene_update_instances(&l->vk, &l->gs, &st->scene, err, sizeof err) !=
            RD_VK_OK) {
            fail(c, 500, SRV_ERR_GPU, err);
            break;
        }
        if (!upload_lights(l, c)) break;
        mark_view_changed(l, true, true);
        l->persist_dirty = true;
        complete_json(c, 200, srv_json_node(c->id, &st->scene.nodes[c->id]));
        break;
    }
    case SRV_CMD_GET_SETTINGS:
        complete_json(c, 200, srv_json_settings(&st->settings));
        break;
    case SRV_CMD_PATCH_SETTINGS:
        patch_settings(l, c);
        break;
    }
    if (c->ticket > l->applied_ticket) l->applied_ticket = c->ticket;
    pthread_mutex_lock(&l->stats_mu);
    l->stats.commands_applied++;
    pthread_mutex_unlock(&l->stats_mu);
}

/* ---- frames ------------------------------------------------------------------------------- */

static void on_readback(void *user, const srv_frame_info *info, unsigned w, unsigned h,
                        const uint8_t *rgba)
{
    srv_render_loop *l = user;
    srv_image *img = srv_image_new(w, h);
    memcpy(img->rgba, rgba, (size_t)w * h * 4);
    srv_image_unref(l->last_image);
    l->last_image = img;
    l->last_info = *info;
    const srv_settings *s = &l->st.settings;
    srv_encoder_submit(l->cfg.encoders, img, info,
                       info->still ? s->quality_still : s->quality_interactive);
}

static void poll_readback(srv_render_loop *l, uint64_t timeout_ns)
{
    char err[256];
    if (srv_readback_poll(&l->rb, timeout_ns, on_readback, l, err, sizeof err) != RD_VK_OK) {
        srv_error("render", "frame readback failed: %s", err);
        pthread_mutex_lock(&l->stats_mu);
        snprintf(l->stats.last_error, sizeof l->stats.last_error, "%s", err);
        pthread_mutex_unlock(&l->stats_mu);
    }
}

/* The demo animation: the first light circles its starting point, one turn per 12 s. */
static void animate(srv_render_loop *l, double now)
{
    srv_scene_state *st = &l->st;
    if (!l->anim_valid || srv_state_light_index(st, l->anim_light) < 0) {
        if (st->scene.light_count == 0) return;
        l->anim_light = st->light_ids[0];
        memcpy(l->anim_center, st->scene.lights[0].position, sizeof l->anim_center);
        float ex = st->scene.bounds_max[0] - st->scene.bounds_min[0];
        float ez = st->scene.bounds_max[2] - st->scene.bounds_min[2];
        l->anim_radius = 0.25f * (ex < ez ? ex : ez);
        l->anim_phase_s = 0;
        l->anim_valid = true;
    }
    double dt = l->anim_last_ms > 0 ? (now - l->anim_last_ms) / 1000.0 : 0;
    l->anim_last_ms = now;
    l->anim_phase_s += dt < 0.1 ? dt : 0.1;
    rd_light *light = &st->scene.lights[srv_state_light_index(st, l->anim_light)];
    double a = 2 * M_PI * l->anim_phase_s / ANIM_PERIOD_S;
    light->node = -1;
    light->position[0] = l->anim_center[0] + l->anim_radius * (float)(cos(a) - 1.0);
    light->position[1] = l->anim_center[1];
    light->position[2] = l->anim_center[2] + l->anim_radius * (float)sin(a);
    if (upload_lights(l, NULL)) mark_view_changed(l, false, true);
}

static void record_stats(srv_render_loop *l, double now, double wall_ms)
{
    const rd_frame_stats *fs = &l->r.stats;
    pthread_mutex_lock(&l->stats_mu);
    srv_render_stats *s = &l->stats;
    s->frames_rendered++;
    s->frame_ms_last = wall_ms;
    s->width = l->r.width;
    s->height = l->r.height;
    s->pass_count = fs->pass_count;
    s->gpu_ms_last = 0;
    for (unsigned i = 0; i < fs->pass_count && i < RD_TIMER_MAX; i++) {
        snprintf(s->pass_name[i], SRV_PASS_NAME_MAX, "%s",
                 fs->pass_name[i] ? fs->pass_name[i] : "?");
        s->pass_ms[i] = fs->pass_ms[i];
        s->gpu_ms_last += fs->pass_ms[i];
    }
    s->rays_last = (uint64_t)fs->rays.primary_rays + fs->rays.shadow_rays + fs->rays.probe_rays +
                   fs->rays.path_rays + fs->rays.probe_shadow_rays;
    s->rays_per_second = s->gpu_ms_last > 0 ? s->rays_last / (s->gpu_ms_last * 1e-3) : 0;
    l->frame_times[l->frame_time_next++ % FPS_WINDOW] = now;
    pthread_mutex_unlock(&l->stats_mu);
}

static void render_frame(srv_render_loop *l, double now, bool animating)
{
    if (animating)
        animate(l, now);
    else
        l->anim_last_ms = 0; /* paused: no jump when it resumes */
    const srv_settings *s = &l->st.settings;
    rd_frame_settings fs = {
        .width = s->width,
        .height = s->height,
        .sky = {s->sky[0], s->sky[1], s->sky[2]},
        .exposure_ev = s->exposure_ev,
        .tonemap = s->tonemap,
        .view = l->r.gi ? s->view : PC_VIEW_FINAL,
        .gi_updates = 1,
    };
    bool still = now - l->last_motion_ms >= s->still_delay_ms;
    if (still && !animating && l->r.gi && l->gi_updates + 1 < l->gi_converge) {
        unsigned left = l->gi_converge - l->gi_updates;
        fs.gi_updates = left < CONVERGE_UPDATES_PER_FRAME ? left : CONVERGE_UPDATES_PER_FRAME;
    }
    if (s->gi_mode == SRV_GI_PATHTRACE) { /* progressive: add samples to the accumulation */
        fs.pathtrace_spp = l->vk.is_cpu ? 1 : 16;
        fs.pathtrace_first = l->pt_samples;
        fs.seed = 1;
    }
    rd_view_camera cam;
    srv_camera_to_view(&l->st.camera, &cam);
    srv_frame_info info = {
        .frame_id = ++l->next_frame_id,
        .capture_us = srv_unix_us(),
        .input_ticket = l->applied_ticket,
        .still = still,
    };
    l->dirty = false;
    l->last_render_ms = now;
    char err[256];
    rd_vk_result vr = rd_renderer_render(&l->r, &l->gs, &cam, &fs, err, sizeof err);
    l->last_render_end_ms = srv_mono_ms();
    double wall = l->last_render_end_ms - now;
    if (l->r.gi && l->gi_updates < UINT32_MAX - fs.gi_updates) l->gi_updates += fs.gi_updates;
    if (fs.pathtrace_spp) l->pt_samples = vr == RD_VK_OK ? l->r.pathtrace_samples : 0;
    if (vr == RD_VK_OK)
        vr = srv_readback_submit(&l->rb, &l->r.rgba8, l->r.width, l->r.height, &info, err,
                                 sizeof err);
    if (vr != RD_VK_OK) {
        srv_error("render", "frame %llu failed: %s", (unsigned long long)info.frame_id, err);
        pthread_mutex_lock(&l->stats_mu);
        snprintf(l->stats.last_error, sizeof l->stats.last_error, "%s", err);
        l->stats.device_lost = l->vk.device_lost;
        pthread_mutex_unlock(&l->stats_mu);
        return;
    }
    l->need_still = !info.still;
    record_stats(l, now, wall);
    srv_debug("render", "frame %llu: %ux%u, %s, %u probe update(s) (%u of %u), %.1f ms",
              (unsigned long long)info.frame_id, l->r.width, l->r.height,
              info.still ? "still" : "interactive", fs.gi_updates, l->gi_updates, l->gi_converge,
              wall);
}

/* Re-encodes the last image at still quality as a new frame (nothing is rendered). */
static void emit_still(srv_render_loop *l)
{
    l->need_still = false;
    if (!l->last_image) return;
    srv_frame_info info = l->last_info;
    info.frame_id = ++l->next_frame_id;
    info.still = true;
    srv_encoder_submit(l->cfg.encoders, l->last_image, &info, l->st.settings.quality_still);
    srv_debug("render", "frame %llu: the last image again at still quality",
              (unsigned long long)info.frame_id);
    pthread_mutex_lock(&l->stats_mu);
    l->stats.stills_reencoded++;
    pthread_mutex_unlock(&l->stats_mu);
}

static void post_state(srv_render_loop *l, double now)
{
    l->persist_dirty = false;
    l->last_persist_ms = now;
    if (l->cfg.persist)
        srv_persist_post_state(l->cfg.persist, l->st.generation, l->st.source,
                               srv_state_to_json(&l->st));
}

static void wait_until(srv_render_loop *l, double wake_ms)
{
    pthread_mutex_lock(&l->mu);
    if (!l->head && !l->stop) {
        if (isinf(wake_ms)) {
            pthread_cond_wait(&l->cv, &l->mu);
        } else {
            double delay = wake_ms - srv_mono_ms();
            if (delay > 0) {
                struct timespec ts;
                clock_gettime(CLOCK_REALTIME, &ts);
                long long ns = (long long)ts.tv_nsec + (long long)(delay * 1e6);
                ts.tv_sec += ns / 1000000000LL;
                ts.tv_nsec = ns % 1000000000LL;
                pthread_cond_timedwait(&l->cv, &l->mu, &ts);
            }
        }
    }
    pthread_mutex_unlock(&l->mu);
}

/* Copies what /v1/stats reports about the scene and GI into the shared stats. */
static void share_state(srv_render_loop *l, bool want)
{
    pthread_mutex_lock(&l->stats_mu);
    srv_render_stats *s = &l->stats;
    s->rendering = want;
    s->gi_updates = l->gi_updates;
    s->gi_converge_updates = l->gi_converge;
    s->device_lost = l->vk.device_lost;
    s->gi_mode = l->r.gi ? l->st.settings.gi_mode : 0;
    s->probe_counts[0] = l->r.gi ? l->r.ddgi.vol.counts.x : 0;
    s->probe_counts[1] = l->r.gi ? l->r.ddgi.vol.counts.y : 0;
    s->probe_counts[2] = l->r.gi ? l->r.ddgi.vol.counts.z : 0;
    s->probes = s->probe_counts[0] * s->probe_counts[1] * s->probe_counts[2];
    s->rays_per_probe = l->r.gi ? l->r.ddgi.vol.counts.w : 0;
    s->scene_generation = l->st.generation;
    s->triangles = l->st.scene.tri_total;
    pthread_mutex_unlock(&l->stats_mu);
}

static void *render_main(void *arg)
{
    srv_render_loop *l = arg;
    srv_info("render", "render thread running on %s", l->vk.device_name);
    for (;;) {
        pthread_mutex_lock(&l->mu);
        srv_cmd *batch = l->head;
        l->head = l->tail = NULL;
        l->queued = 0;
        bool stop = l->stop;
        pthread_mutex_unlock(&l->mu);
        while (batch) {
            srv_cmd *c = batch;
            batch = c->next;
            apply(l, c);
            srv_cmd_unref(c);
        }
        if (stop) break;
        poll_readback(l, 0);

        double now = srv_mono_ms();
        const srv_settings *s = &l->st.settings;
        bool lost = l->vk.device_lost;
        bool animating = s->animate && atomic_load(&l->viewers) > 0 && l->st.scene.light_count > 0;
        bool converging = (l->r.gi && l->gi_updates < l->gi_converge) || l->pt_samples < l->pt_target;
        bool want = !lost && (l->dirty || animating || converging);
        share_state(l, want);
        double wake = INFINITY;
        if (want) {
            double next = l->last_render_ms + 1000.0 / s->max_fps;
            /* After an interactive frame, a frame no input asked for (probes converging, the
             * animation) waits still_delay_ms: a viewer that answers a frame with its next
             * input then gets a frame of its own instead of queueing behind one it did not
             * ask for (rd_renderer_render cannot be interrupted). */
            if (!l->dirty && l->need_still && l->last_render_end_ms + s->still_delay_ms > next)
                next = l->last_render_end_ms + s->still_delay_ms;
            if (now >= next && srv_readback_has_free(&l->rb)) {
                /* rd_renderer_render blocks until its frame is done, so a copy still in flight
                 * would otherwise wait a whole frame to be delivered: collect it first (it is
                 * queued ahead of the next frame's work, so this costs only the copy); the frame
                 * counts as started now, so this wait does not turn it into a still */
                if (srv_readback_busy(&l->rb) > 0) poll_readback(l, 100ull * 1000 * 1000);
                render_frame(l, now, animating);
                continue;
            }
            wake = now < next ? next : now + 1;
        } else if (l->need_still && !lost) {
            double due = l->last_motion_ms + s->still_delay_ms;
            if (now >= due && srv_readback_busy(&l->rb) == 0) {
                emit_still(l);
                continue;
            }
            wake = due > now ? due : now + 1;
        }
        if (l->persist_dirty) {
            double due = l->last_persist_ms + PERSIST_INTERVAL_MS;
            if (now >= due)
                post_state(l, now);
            else if (due < wake)
                wake = due;
        }
        if (srv_readback_busy(&l->rb) > 0) {
            double ms = isinf(wake) ? 5 : wake - now;
            ms = ms < 0.1 ? 0.1 : ms > 5 ? 5 : ms;
            poll_readback(l, (uint64_t)(ms * 1e6));
            continue;
        }
        wait_until(l, wake);
    }
    /* answer what is still queued, then deliver the last frames */
    pthread_mutex_lock(&l->mu);
    srv_cmd *rest = l->head;
    l->head = l->tail = NULL;
    pthread_mutex_unlock(&l->mu);
    while (rest) {
        srv_cmd *c = rest;
        rest = c->next;
        fail(c, 503, SRV_ERR_UNAVAILABLE, "The server is shutting down.");
        srv_cmd_unref(c);
    }
    if (l->persist_dirty) post_state(l, srv_mono_ms());
    srv_info("render", "render thread stopped");
    return NULL;
}

/* ---- lifecycle ---------------------------------------------------------------------------- */

srv_render_loop *srv_render_loop_create(const srv_render_config *cfg, rd_scene *scene,
                                        const char *source, uint64_t generation,
                                        const cJSON *saved_state, char *err, size_t errlen)
{
    srv_render_loop *l = calloc(1, sizeof *l);
    if (!l) abort();
    l->cfg = *cfg;
    pthread_mutex_init(&l->mu, NULL);
    pthread_cond_init(&l->cv, NULL);
    pthread_mutex_init(&l->stats_mu, NULL);
    srv_state_init(&l->st);
    l->st.settings = cfg->settings;
    l->generation_counter = cfg->generation_base > generation ? cfg->generation_base : generation;

    rd_vk_options vo = {.device = cfg->device};
    rd_vk_result vr = rd_vk_create(&l->vk, &vo, err, errlen);
    if (vr != RD_VK_OK) {
        rd_scene_destroy(scene);
        srv_render_loop_destroy(l);
        return NULL;
    }
    l->vk_ok = true;
    if (cfg->adapt_to_cpu && l->vk.is_cpu) {
        srv_settings *s = &l->st.settings;
        unsigned g = cfg->settings_given;
        if (!(g & (SRV_SET_WIDTH | SRV_SET_HEIGHT))) s->width = 512, s->height = 288;
        if (!(g & SRV_SET_RAYS)) s->rays_per_probe = 64;
        if (!(g & SRV_SET_MAX_FPS)) s->max_fps = 15;
        srv_info("render",
                 "%s is a CPU device: starting at %ux%u, %u rays per probe, %u fps at most",
                 l->vk.device_name, s->width, s->height, s->rays_per_probe, s->max_fps);
    }
    srv_readback_init(&l->rb, &l->vk);
    srv_state_set_scene(&l->st, scene, source, generation);
    if (saved_state) {
        srv_api_error e;
        if (!srv_state_restore(&l->st, saved_state, &e))
            srv_warn("render", "saved state not applied: %s", e.message);
        else if (e.message[0])
            srv_warn("render", "saved state partly applied: %s", e.message);
        else
            srv_info("render", "restored camera, lights, nodes and settings");
    }
    vr = rd_gpu_scene_create(&l->vk, &l->gs, &l->st.scene, err, errlen);
    if (vr == RD_VK_OK) vr = rd_renderer_create(&l->vk, &l->r, err, errlen);
    if (vr == RD_VK_OK && configure_gi(l, err, errlen) != RD_VK_OK) {
        srv_warn("render", "global illumination is off: %s", err);
        err[0] = '\0';
    }
    if (vr != RD_VK_OK) {
        srv_render_loop_destroy(l);
        return NULL;
    }
    snprintf(l->stats.device, sizeof l->stats.device, "%s", l->vk.device_name);
    share_state(l, true);
    l->dirty = true;
    l->last_motion_ms = -1e9; /* the first frame is a still */
    l->last_render_ms = -1e9;
    l->last_persist_ms = -1e9;
    return l;
}

bool srv_render_loop_start(srv_render_loop *l)
{
    if (pthread_create(&l->thread, NULL, render_main, l) != 0) return false;
    l->started = true;
    return true;
}

void srv_render_loop_stop(srv_render_loop *l)
{
    if (!l) return;
    pthread_mutex_lock(&l->mu);
    l->stop = true;
    pthread_cond_signal(&l->cv);
    pthread_mutex_unlock(&l->mu);
    if (l->started) {
        pthread_join(l->thread, NULL);
        l->started = false;
    }
}

unsigned srv_render_loop_validation_messages(srv_render_loop *l)
{
    return l && l->vk_ok ? rd_vk_validation_messages(&l->vk) : 0;
}

void srv_render_loop_destroy(srv_render_loop *l)
{
    if (!l) return;
    srv_render_loop_stop(l);
    if (l->vk_ok) {
        if (l->vk.device && !l->vk.device_lost) vkDeviceWaitIdle(l->vk.device);
        srv_readback_dispose(&l->rb);
        rd_renderer_destroy(&l->r);
        rd_gpu_scene_destroy(&l->vk, &l->gs);
        unsigned v = rd_vk_validation_messages(&l->vk);
        if (v) srv_warn("render", "%u Vulkan validation message(s) during this run", v);
        rd_vk_destroy(&l->vk);
    }
    srv_image_unref(l->last_image);
    srv_state_dispose(&l->st);
    pthread_mutex_destroy(&l->stats_mu);
    pthread_cond_destroy(&l->cv);
    pthread_mutex_destroy(&l->mu);
    free(l);
}

void srv_render_get_stats(srv_render_loop *l, srv_render_stats *out)
{
    double now = srv_mono_ms();
    pthread_mutex_lock(&l->stats_mu);
    *out = l->stats;
    unsigned n = 0;
    for (unsigned i = 0; i < FPS_WINDOW && i < l->frame_time_next; i++)
        if (now - l->frame_times[i] <= 1000.0) n++;
    pthread_mutex_unlock(&l->stats_mu);
    out->fps = n;
    out->viewers = atomic_load(&l->viewers);
}
