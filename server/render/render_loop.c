/* render_loop.c: the render thread — commands in, scheduler's choice, GPU work, frames out. */
#include "server/render/render_loop.h"
#include "server/base/clock.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "server/api/api_json.h"
#include "server/scene/documents_json.h"
#include "server/render/frame_output.h"
#include "server/base/log.h"
#include "renderer/view.h"
#include "server/scene/scene_service.h"
#include "server/render/scheduler.h"
#include "server/render/view_pick.h"
#include "server/render/views.h"

#define PERSIST_INTERVAL_MS 250
#define DEFAULT_MAX_VIEWS 64u
#define DEFAULT_MAX_TOTAL_PIXELS (16ull * 1024 * 1024)

struct srv_render_loop {
    srv_render_config cfg;
    rd_vk vk;
    bool vk_ok;
    rd_view_passes passes;
    bool passes_ok;
    rd_pick pick; /* POST /v1/views/{id}/pick */
    srv_scene_service svc;
    bool svc_ok;
    srv_views views;
    srv_frame_output out; /* readback, GPU JPEG pass, hand-off to the encoders */
    srv_mailbox mb;
    srv_stats_board stats;

    pthread_t thread;
    bool started;
    atomic_uint viewers;
    atomic_uint next_view_id;

    /* render thread only */
    uint64_t next_frame_id;
    double last_tick_ms;
    double update_ms; /* wall time of one probe update, smoothed */
    bool persist_dirty;
    double last_persist_ms;
};

/* ---- views ---------------------------------------------------------------------------------- */

static void publish_view(srv_render_loop *l, const srv_view *v, bool structural)
{
    srv_view_info info;
    srv_view_info_of(v, &info);
    srv_snapshot_set_view(l->cfg.snapshot, &info, structural);
}

/* A view's picture changed because of input to it (or to the world). */
static void touch_view(srv_view *v, double now, bool input)
{
    v->dirty = true;
    v->pt_samples = 0; /* any change restarts the path-traced accumulation */
    if (input) v->last_input_ms = now;
}

/* Resizes view v (already clamped); the default view's size is also the width/height setting. */
static void resize_view(srv_render_loop *l, srv_view *v, unsigned w, unsigned h, double now)
{
    if (w == v->width && h == v->height) return;
    v->width = w;
    v->height = h;
    touch_view(v, now, true);
    publish_view(l, v, true);
    if (v->id == SRV_DEFAULT_VIEW) {
        srv_settings *s = &l->svc.st.settings;
        if (s->width != w || s->height != h) {
            s->width = w;
            s->height = h;
            srv_snapshot_publish(l->cfg.snapshot, SRV_DOC_SETTINGS, srv_json_settings(s), false);
        }
        l->persist_dirty = true;
    }
}

static srv_view *view_or_404(srv_render_loop *l, srv_cmd *c)
{
    srv_view *v = srv_views_find(&l->views, c->view);
    /* only the HTTP routes wait for an answer; the stream's commands may race a closing view */
    if (!v && (c->kind == SRV_CMD_SET_CAMERA || c->kind == SRV_CMD_FRAME_REQUEST ||
               c->kind == SRV_CMD_PICK)) {
        srv_api_error e;
        srv_api_fail(&e, 404, SRV_ERR_NOT_FOUND, "There is no view with id %u.", c->view);
        srv_cmd_complete_error(c, &e);
    }
    return v;
}

/* Applies what a world change means for the views. */
static void world_changed(srv_render_loop *l, unsigned changes, double now)
{
    const srv_settings *s = &l->svc.st.settings;
    if (changes & SRV_CHANGE_LIMITS) l->views.max_pixels = s->max_pixels;
    for (unsigned i = 0; i < l->views.count; i++) {
        srv_view *v = l->views.items[i];
        if (changes & SRV_CHANGE_VIEWS) touch_view(v, now, true);
        if (changes & SRV_CHANGE_SCENE) {
            v->camera = l->svc.st.camera; /* the old camera may be inside the new scene */
            publish_view(l, v, false);
        }
    }
    if (changes & SRV_CHANGE_SIZE) {
        srv_view *v0 = srv_views_find(&l->views, SRV_DEFAULT_VIEW);
        unsigned w, h;
        srv_views_fit(&l->views, SRV_DEFAULT_VIEW, s->width, s->height, &w, &h);
        if (v0) resize_view(l, v0, w, h, now);
    }
    if (changes & SRV_CHANGE_PERSIST) l->persist_dirty = true;
}

/* A count moved by delta, never below 0 (a watcher's -1 may arrive for a view it never reached). */
static unsigned count_plus(unsigned n, int delta)
{
    return delta < 0 && (unsigned)-delta > n ? 0 : (unsigned)((int)n + delta);
}

static void apply_view_cmd(srv_render_loop *l, srv_cmd *c, double now)
{
    srv_api_error e;
    srv_view *v = view_or_404(l, c);
    switch (c->kind) {
    case SRV_CMD_SET_CAMERA:
        if (!v) return;
        if (!srv_state_camera_apply(&v->camera, &c->camera, c->replace, &e)) {
            srv_cmd_complete_error(c, &e);
            return;
        }
        touch_view(v, now, true);
        publish_view(l, v, false);
        if (v->id == SRV_DEFAULT_VIEW) l->persist_dirty = true;
        srv_cmd_complete_json(c, 200, srv_json_camera(&v->camera));
        return;
    case SRV_CMD_VIEWER_CAMERA:
        if (!v) return; /* the view went away meanwhile */
        if (!srv_state_camera_apply(&v->camera, &c->camera, false, &e)) {
            srv_debug("render", "viewer camera ignored: %s", e.message);
            return;
        }
        v->input_ticket = c->mail.ticket;
        touch_view(v, now, true);
        publish_view(l, v, false);
        if (v->id == SRV_DEFAULT_VIEW) l->persist_dirty = true;
        return;
    case SRV_CMD_VIEWER_RESIZE: {
        if (!v) return;
        unsigned w, h;
        srv_views_fit(&l->views, v->id, c->width, c->height, &w, &h);
        resize_view(l, v, w, h, now);
        return;
    }
    case SRV_CMD_VIEWER_QUALITY:
        if (v && srv_view_set_caps(v, c->jpeg_cap, c->fps_cap))
            srv_debug("render", "view %u: jpeg cap %u, fps cap %u (0: none)", v->id, v->jpeg_cap,
                      v->fps_cap);
        return;
    case SRV_CMD_VIEW_OPEN: {
        const srv_view *v0 = srv_views_find(&l->views, SRV_DEFAULT_VIEW);
        const srv_settings *s = &l->svc.st.settings;
        srv_view *nv =
            srv_views_add(&l->views, c->view, c->width ? c->width : s->width,
                          c->height ? c->height : s->height, v0 ? &v0->camera : &l->svc.st.camera);
        if (!nv) {
            srv_warn("render", "view %u not opened: %u views exist (the limit)", c->view,
                     l->views.count);
            return;
        }
        nv->watchers = 1; /* its connection */
        publish_view(l, nv, true);
        return;
    }
    case SRV_CMD_VIEW_CLOSE:
        if (!v || v->id == SRV_DEFAULT_VIEW) return;
        srv_views_remove(&l->views, c->view);
        srv_encoder_forget_view(l->cfg.encoders, c->view);
        srv_snapshot_remove_view(l->cfg.snapshot, c->view);
        return;
    case SRV_CMD_VIEW_WATCH:
        if (!v) return;
        v->watchers = count_plus(v->watchers, c->delta);
        publish_view(l, v, true);
        return;
    case SRV_CMD_VIEW_VIDEO:
        if (!v) return;
        v->video_watchers = count_plus(v->video_watchers, c->delta);
        return;
    case SRV_CMD_FRAME_REQUEST: {
        if (!v) return;
        uint64_t after;
        if (!v->dirty && v->last_frame_id) {
            after = v->last_frame_id - 1; /* its newest frame is current */
        } else {
            v->requests++;
            after = l->next_frame_id; /* the next frame of it */
        }
        cJSON *j = cJSON_CreateObject();
        cJSON_AddNumberToObject(j, "after", (double)after);
        srv_cmd_complete_json(c, 200, j);
        return;
    }
    case SRV_CMD_PICK:
        if (v) srv_view_pick(&l->pick, &l->svc, v, c);
        return;
    default:
        srv_cmd_fail(c, 500, SRV_ERR_INTERNAL, "Unknown command.");
        return;
    }
}

static void apply(srv_render_loop *l, srv_cmd *c)
{
    double now = srv_mono_ms();
    switch (c->kind) {
    case SRV_CMD_REPLACE_SCENE:
    case SRV_CMD_ADD_LIGHT:
    case SRV_CMD_PATCH_LIGHT:
    case SRV_CMD_DELETE_LIGHT:
    case SRV_CMD_PATCH_NODE:
    case SRV_CMD_PATCH_SETTINGS:
    case SRV_CMD_PATCH_ANIMATION:
    case SRV_CMD_SET_ENVIRONMENT:
        world_changed(l, srv_scene_service_apply(&l->svc, c), now);
        break;
    default:
        apply_view_cmd(l, c, now);
        break;
    }
    pthread_mutex_lock(&l->stats.mu);
    l->stats.s.commands_applied++;
    pthread_mutex_unlock(&l->stats.mu);
}

/* ---- frames --------------------------------------------------------------------------------- */

static void render_view(srv_render_loop *l, srv_view *v, double now)
{
    const srv_settings *s = &l->svc.st.settings;
    char err[256];
    if (!v->gpu_ok) {
        if (rd_view_create(&l->vk, &l->passes, &v->gpu, err, sizeof err) != RD_VK_OK) {
            srv_error("render", "view %u: %s", v->id, err);
            srv_stats_board_error(&l->stats, err, l->vk.device_lost);
            v->dirty = false;
            return;
        }
        v->gpu_ok = true;
    }
    /* near-field rays refine a resting view only: frames while input arrives show the probe
     * field alone, at no cost; once the camera rests they accumulate (rd_view_settling) */
    bool still = now - v->last_input_ms >= s->still_delay_ms;
    rd_view_settings vs = {
        .width = v->width,
        .height = v->height,
        .exposure_ev = s->exposure_ev,
        .tonemap = s->tonemap,
        .view = l->svc.world.gi ? s->view : PC_VIEW_FINAL,
        .near_field = still ? s->near_field : PC_NEAR_OFF,
        .shadow_cull = s->shadow_cull,
    };
    if (l->svc.pt_target) { /* progressive: add samples to the view's accumulation */
        vs.pathtrace_spp = l->vk.is_cpu ? 1 : 16;
        vs.pathtrace_first = v->pt_samples;
        vs.seed = 1;
    }
    rd_view_camera cam;
    srv_camera_to_view(&v->camera, &cam);
    srv_frame_info info = {
        .frame_id = ++l->next_frame_id,
        .view_id = v->id,
        .capture_us = srv_unix_us(),
        .input_ticket = v->input_ticket,
        .still = still,
        /* a moving frame that no watcher takes as JPEG (a still always goes out as one) */
        .video_only =
            !still && v->video_watchers >= v->watchers && v->video_watchers > 0 && v->requests == 0,
    };
    v->dirty = v->behind_world = false;
    v->requests = 0;
    v->renders_since_tick++;
    v->last_render_ms = now;
    unsigned quality = srv_view_quality(v, info.still ? s->quality_still : s->quality_interactive);
    rd_vk_result vr;
    rd_cmd *cmd;
    if (vs.pathtrace_spp) {
        /* path tracing submits batches of its own and waits for them */
        vr = rd_view_render(&v->gpu, &l->svc.world, &cam, &vs, err, sizeof err);
        v->pt_samples = vr == RD_VK_OK ? v->gpu.pathtrace_samples : 0;
        if (v->pt_samples < l->svc.pt_target) v->dirty = true; /* keep accumulating */
        if (vr == RD_VK_OK) vr = srv_frame_output_begin(&l->out, &cmd, err, sizeof err);
        if (vr == RD_VK_OK)
            vr = srv_frame_output_finish(&l->out, v, &info, quality, false, err, sizeof err);
        if (vr == RD_VK_OK)
            srv_stats_board_frame(&l->stats, &v->gpu.stats, v->gpu.width, v->gpu.height, now,
                                  srv_mono_ms() - now);
    } else {
        /* the frame and its output in one submission, not waited for: the GPU renders it while
         * this thread records the next view; srv_frame_output_poll delivers it */
        vr = srv_frame_output_begin(&l->out, &cmd, err, sizeof err);
        if (vr == RD_VK_OK) {
            vr = rd_view_record(&v->gpu, &l->svc.world, &cam, &vs, cmd, err, sizeof err);
            /* a young near-field history: keep rendering while the view rests, until it has
             * settled (then nothing more until something changes) */
            if (vr == RD_VK_OK && rd_view_settling(&v->gpu)) v->dirty = true;
            if (vr == RD_VK_OK)
                vr = srv_frame_output_finish(&l->out, v, &info, quality, true, err, sizeof err);
            else
                srv_frame_output_abort(&l->out);
        }
        v->in_flight = vr == RD_VK_OK;
    }
    if (vr != RD_VK_OK) {
        srv_error("render", "frame %llu of view %u failed: %s", (unsigned long long)info.frame_id,
                  v->id, err);
        srv_stats_board_error(&l->stats, err, l->vk.device_lost);
        return;
    }
    v->need_still = !info.still;
    v->last_frame_id = info.frame_id;
    srv_debug("render", "frame %llu: view %u, %ux%u, %s, %.2f ms to submit",
              (unsigned long long)info.frame_id, v->id, v->width, v->height,
              info.still ? "still" : "interactive", srv_mono_ms() - now);
}

/* Re-encodes a view's last image at still quality as a new frame (nothing is rendered). With
 * near-field rays on, the still is rendered instead: they refine a resting view (render_view),
 * and the frames while input arrived had none. */
static void emit_still(srv_render_loop *l, srv_view *v)
{
    v->need_still = false;
    if (l->svc.world.gi && !l->svc.pt_target && l->svc.st.settings.near_field != PC_NEAR_OFF) {
        v->dirty = true;
        return;
    }
    srv_frame_info info = v->last_info;
    info.frame_id = l->next_frame_id + 1;
    info.still = true;
    info.video_only = false; /* a still goes out as JPEG to every watcher */
    if (!srv_frame_output_again(&l->out, v, &info,
                                srv_view_quality(v, l->svc.st.settings.quality_still)))
        return;
    l->next_frame_id = info.frame_id;
    v->last_frame_id = info.frame_id;
    pthread_mutex_lock(&l->stats.mu);
    l->stats.s.stills_reencoded++;
    pthread_mutex_unlock(&l->stats.mu);
}

static void advance_world(srv_render_loop *l, bool animating, unsigned updates, double now)
{
    char err[256];
    rd_vk_result vr = srv_scene_service_advance(&l->svc, animating, updates, now, err, sizeof err);
    l->last_tick_ms = now;
    if (updates && vr == RD_VK_OK) {
        double ms = (srv_mono_ms() - now) / updates;
        l->update_ms = l->update_ms > 0 ? 0.8 * l->update_ms + 0.2 * ms : ms;
    }
    if (vr != RD_VK_OK) {
        srv_error("render", "probe update failed: %s", err);
        srv_stats_board_error(&l->stats, err, l->vk.device_lost);
        return;
    }
    unsigned ran = l->svc.world.gi ? updates + (animating && updates == 0) : 0;
    srv_stats_board_tick(&l->stats, &l->svc.world.stats, ran, now);
    srv_views_mark_all(&l->views, true);
    if (l->svc.pt_target)
        for (unsigned i = 0; i < l->views.count; i++)
            l->views.items[i]->pt_samples = 0;
}

static void post_state(srv_render_loop *l, double now)
{
    l->persist_dirty = false;
    l->last_persist_ms = now;
    if (!l->cfg.persist) return;
    const srv_view *v0 = srv_views_find(&l->views, SRV_DEFAULT_VIEW);
    srv_persist_post_state(l->cfg.persist, l->svc.st.generation, l->svc.st.source,
                           srv_scene_service_state_json(&l->svc, &v0->camera));
}

/* Copies what /v1/stats reports about the world and the views. */
static void share_state(srv_render_loop *l, bool rendering)
{
    const rd_world *w = &l->svc.world;
    unsigned watched = 0;
    for (unsigned i = 0; i < l->views.count; i++)
        watched += l->views.items[i]->watchers > 0;
    pthread_mutex_lock(&l->stats.mu);
    srv_render_stats *s = &l->stats.s;
    s->rendering = rendering;
    s->gi_updates = l->svc.gi_updates;
    s->gi_converged = rd_world_converged(w);
    s->probes_awake = w->gi ? w->ddgi.census.awake : 0;
    s->probes_sleeping = w->gi ? w->ddgi.census.sleeping : 0;
    s->probes_off = w->gi ? w->ddgi.census.off : 0;
    s->gi_drift = w->gi ? w->ddgi.drift : 0;
    s->shadow_map_lights = rd_shadow_maps_valid(&w->shadow_maps);
    s->shadow_map_builds = w->shadow_maps.builds;
    s->shadow_map_bytes = w->shadow_maps.capacity * 4;
    s->device_lost = l->vk.device_lost;
    s->gi_mode = w->gi || l->svc.pt_target ? l->svc.st.settings.gi_mode : 0;
    s->probe_counts[0] = w->gi ? w->ddgi.vol.counts.x : 0;
    s->probe_counts[1] = w->gi ? w->ddgi.vol.counts.y : 0;
    s->probe_counts[2] = w->gi ? w->ddgi.vol.counts.z : 0;
    s->probes = s->probe_counts[0] * s->probe_counts[1] * s->probe_counts[2];
    s->rays_per_probe = w->gi ? w->ddgi.vol.counts.w : 0;
    s->scene_generation = l->svc.st.generation;
    s->triangles = l->svc.st.scene.tri_total;
    s->deform_build_ms = l->svc.gs.deform_build_ms;
    s->deform_ms = l->svc.gs.deform_ms;
    s->refit_ms = l->svc.gs.refit_ms;
    s->deform_refits = l->svc.gs.deform_refits;
    s->deform_rebuilds = l->svc.gs.deform_rebuilds;
    s->deform_gpu_rebuilds = l->svc.gs.deform_gpu_rebuilds;
    s->views = l->views.count;
    s->views_watched = watched;
    s->pt_target = l->svc.pt_target;
    s->pt_samples = l->svc.pt_target ? srv_views_pt_samples_min(&l->views) : 0;
    s->pt_view_count = 0;
    for (unsigned i = 0; l->svc.pt_target && i < l->views.count && i < SRV_STATS_PT_VIEWS; i++) {
        s->pt_views[i].view = l->views.items[i]->id;
        s->pt_views[i].samples = l->views.items[i]->pt_samples;
        s->pt_view_count = i + 1;
    }
    pthread_mutex_unlock(&l->stats.mu);
}

static void *render_main(void *arg)
{
    srv_render_loop *l = arg;
    srv_info("render", "render thread running on %s", l->vk.device_name);
    srv_sched_view sv[256];
    for (;;) {
        bool closed;
        srv_mail *batch = srv_mailbox_take(&l->mb, &closed);
        while (batch) {
            srv_cmd *c = srv_cmd_of(batch);
            batch = batch->next;
            apply(l, c);
            srv_cmd_unref(c);
        }
        if (closed) break;
        srv_frame_output_poll(&l->out, 0);

        double now = srv_mono_ms();
        const srv_settings *s = &l->svc.st.settings;
        bool lost = l->vk.device_lost;
        unsigned viewers = atomic_load(&l->viewers);
        srv_scene_service_watch(&l->svc, viewers, now);
        bool animating = srv_scene_service_animating(&l->svc, viewers);
        unsigned n = l->views.count < 256 ? l->views.count : 256;
        bool any_watched_dirty = false;
        for (unsigned i = 0; i < n; i++) {
            const srv_view *v = l->views.items[i];
            sv[i] = (srv_sched_view){.watched = !lost && (v->watchers > 0 || v->requests > 0),
                                     .dirty = v->dirty,
                                     .behind_world = v->behind_world,
                                     .need_still = v->need_still,
                                     .renders_since_tick = v->renders_since_tick,
                                     .busy = v->in_flight,
                                     .last_render_ms = v->last_render_ms,
                                     .last_input_ms = v->last_input_ms,
                                     .frame_interval_ms = v->fps_cap ? 1000.0 / v->fps_cap : 0};
            /* a still still due is a frame to come: "rendering" stays true until it went */
            any_watched_dirty |= sv[i].watched && (v->dirty || v->in_flight || v->need_still);
        }
        bool converging = srv_scene_service_converging(&l->svc);
        srv_sched_state ss = {
            .now_ms = now,
            .frame_interval_ms = 1000.0 / (s->max_fps ? s->max_fps : 1),
            .still_delay_ms = s->still_delay_ms,
            .world_wants_update = !lost && (converging || animating),
            /* the service stops a tick's updates early once every probe sleeps */
            .world_updates_left = converging ? SRV_SCHED_CONVERGE_UPDATES : 0,
            .update_ms = l->update_ms,
            .last_tick_ms = l->last_tick_ms,
            .readback_free = srv_frame_output_ready(&l->out),
            .views = sv,
            .view_count = n,
            .cursor = l->views.cursor < n ? l->views.cursor : 0,
        };
        share_state(l, any_watched_dirty || ss.world_wants_update);
        srv_sched_step step = srv_sched_next(&ss);
        switch (step.action) {
        case SRV_SCHED_ADVANCE_WORLD:
            advance_world(l, animating, step.world_updates, now);
            continue;
        case SRV_SCHED_RENDER_VIEW:
            l->views.cursor = (step.view + 1) % n;
            render_view(l, l->views.items[step.view], now);
            continue;
        case SRV_SCHED_EMIT_STILL:
            emit_still(l, l->views.items[step.view]);
            continue;
        case SRV_SCHED_SLEEP:
            break;
        }
        double wake = step.action == SRV_SCHED_SLEEP ? step.wake_ms : now + 1;
        if (l->persist_dirty) {
            double due = l->last_persist_ms + PERSIST_INTERVAL_MS;
            if (now >= due)
                post_state(l, now);
            else if (due < wake)
                wake = due;
        }
        if (srv_frame_output_busy(&l->out)) {
            double ms = isinf(wake) ? 5 : wake - now;
            ms = ms < 0.1 ? 0.1 : ms > 5 ? 5 : ms;
            srv_frame_output_poll(&l->out, (uint64_t)(ms * 1e6));
            continue;
        }
        srv_mailbox_wait(&l->mb, wake);
    }
    if (l->persist_dirty) post_state(l, srv_mono_ms());
    srv_info("render", "render thread stopped");
    return NULL;
}

/* ---- lifecycle ------------------------------------------------------------------------------ */

srv_render_loop *srv_render_loop_create(const srv_render_config *cfg, rd_scene *scene,
                                        const char *source, uint64_t generation,
                                        const cJSON *saved_state, char *err, size_t errlen)
{
    srv_render_loop *l = calloc(1, sizeof *l);
    if (!l) abort();
    l->cfg = *cfg;
    if (!l->cfg.max_views) l->cfg.max_views = DEFAULT_MAX_VIEWS;
    if (!l->cfg.max_total_pixels) l->cfg.max_total_pixels = DEFAULT_MAX_TOTAL_PIXELS;
    srv_mailbox_init(&l->mb);
    srv_stats_board_init(&l->stats);
    atomic_init(&l->next_view_id, SRV_DEFAULT_VIEW + 1);
    srv_settings settings = cfg->settings;

    rd_vk_options vo = {.device = cfg->device};
    rd_vk_result vr = rd_vk_create(&l->vk, &vo, err, errlen);
    if (vr != RD_VK_OK) {
        rd_scene_destroy(scene);
        srv_render_loop_destroy(l);
        return NULL;
    }
    l->vk_ok = true;
    if (cfg->adapt_to_cpu && l->vk.is_cpu) {
        srv_settings_adapt_to_cpu(&settings, cfg->settings_given);
        srv_info("render",
                 "%s is a CPU device: starting at %ux%u, %u rays per probe, %u fps at most, "
                 "probe paths %u, near-field rays %s",
                 l->vk.device_name, settings.width, settings.height, settings.rays_per_probe,
                 settings.max_fps, settings.probe_paths,
                 settings.near_field == PC_NEAR_OFF ? "off" : "on");
    }
    vr = srv_frame_output_init(&l->out, &l->vk, cfg->jpeg_path, cfg->encoders, &l->stats, &l->views,
                               err, errlen);
    if (vr == RD_VK_OK) vr = rd_view_passes_create(&l->vk, &l->passes, err, errlen);
    l->passes_ok = vr == RD_VK_OK;
    if (vr == RD_VK_OK) vr = rd_pick_create(&l->vk, &l->pick, err, errlen);
    if (vr == RD_VK_OK) {
        vr = srv_scene_service_init(&l->svc, &l->vk, cfg->snapshot, &settings, scene, source,
                                    generation, cfg->generation_base, saved_state, err, errlen);
        l->svc_ok = vr == RD_VK_OK;
    } else {
        rd_scene_destroy(scene);
    }
    if (vr != RD_VK_OK) {
        srv_render_loop_destroy(l);
        return NULL;
    }
    const srv_settings *s = &l->svc.st.settings;
    srv_views_init(&l->views, l->cfg.max_views, s->max_pixels, l->cfg.max_total_pixels);
    srv_view_limits limits;
    srv_render_view_limits(l, &limits);
    srv_snapshot_set_view_limits(cfg->snapshot, &limits);
    srv_view *v0 =
        srv_views_add(&l->views, SRV_DEFAULT_VIEW, s->width, s->height, &l->svc.st.camera);
    v0->requests = 1; /* a first frame, so /v1/frame.jpg and new viewers have one at once */
    publish_view(l, v0, true);
    snprintf(l->stats.s.device, sizeof l->stats.s.device, "%s", l->vk.device_name);
    l->stats.s.jpeg_gpu = l->out.gpu;
    share_state(l, true);
    l->last_tick_ms = -1e9;
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
    srv_mailbox_close(&l->mb);
    if (l->started) {
        pthread_join(l->thread, NULL);
        l->started = false;
    }
}

rd_vk *srv_render_loop_device(srv_render_loop *l)
{
    return &l->vk;
}

unsigned srv_render_loop_validation_messages(srv_render_loop *l)
{
    return l && l->vk_ok ? rd_vk_validation_messages(&l->vk) : 0;
}

void srv_render_loop_destroy(srv_render_loop *l)
{
    if (!l) return;
    srv_render_loop_stop(l);
    srv_mailbox_dispose(&l->mb);
    if (l->vk_ok) {
        rd_vk_wait_idle(&l->vk);
        srv_views_dispose(&l->views);      /* their last images end their readback leases */
        srv_frame_output_dispose(&l->out); /* idempotent, and a no-op before its init */
        if (l->svc_ok) srv_scene_service_dispose(&l->svc);
        rd_pick_destroy(&l->pick);
        if (l->passes_ok) rd_view_passes_destroy(&l->vk, &l->passes);
        unsigned v = rd_vk_validation_messages(&l->vk);
        if (v) srv_warn("render", "%u Vulkan validation message(s) during this run", v);
        rd_vk_destroy(&l->vk);
    }
    srv_stats_board_dispose(&l->stats);
    free(l);
}

bool srv_render_call(srv_render_loop *l, srv_cmd *c, unsigned timeout_ms)
{
    return srv_mailbox_call(&l->mb, &c->mail, timeout_ms);
}

uint64_t srv_render_post(srv_render_loop *l, srv_cmd *c)
{
    return srv_mailbox_post(&l->mb, &c->mail);
}

uint32_t srv_render_new_view_id(srv_render_loop *l)
{
    return atomic_fetch_add(&l->next_view_id, 1);
}

void srv_render_view_limits(const srv_render_loop *l, srv_view_limits *out)
{
    *out = (srv_view_limits){.max_views = l->cfg.max_views,
                             .max_pixels = l->views.max_pixels ? l->views.max_pixels
                                                               : l->cfg.settings.max_pixels,
                             .max_total_pixels = l->cfg.max_total_pixels};
}

void srv_render_set_viewers(srv_render_loop *l, unsigned viewers)
{
    atomic_store(&l->viewers, viewers);
    srv_mailbox_wake(&l->mb);
}

void srv_render_get_stats(srv_render_loop *l, srv_render_stats *out)
{
    srv_stats_board_get(&l->stats, out);
    out->viewers = atomic_load(&l->viewers);
}
