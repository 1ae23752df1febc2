/* scene_pose.c: the scene's own (glTF) animations in the scene service — posing the scene at
 * the playback clock's time, waking the probes around what moved, PATCH /v1/animation (see
 * scene_service_internal.h). */
#include "server/scene/scene_service_internal.h"
#include "server/base/clock.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "server/api/api_json.h"
#include "server/base/log.h"
#include "renderer/scene/animation_clip.h"

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

/* Poses the scene at the clock's time: the animated nodes' TRS and morph weights
 * (rd_scene_animate), world matrices and deformed meshes (rd_scene_update), the bottom-level BVHs
 * of the meshes whose deformation changed and the top-level BVH (rd_gpu_scene_update_pose) and,
 * when an animated node carries a light, the lights. With wake, the probes around the old and
 * the new bounds of every instance that moved or deformed wake (and all of them, gently, when a
 * light moved). *moved: some instance or light moved, or some mesh deformed. */
rd_vk_result srv_scene_pose(srv_scene_service *svc, bool wake, bool *moved, char *err,
                            size_t errlen)
{
    rd_scene *s = &svc->st.scene;
    *moved = false;
    if (!s->animation_count) return RD_VK_OK;
    uint32_t n = s->instance_count, nl = s->light_count;
    float *before = malloc((n ? n : 1) * 16 * sizeof *before);        /* world matrices */
    float *light_was = malloc((nl ? nl : 1) * 6 * sizeof *light_was); /* position, direction */
    bool *deformed = malloc((n ? n : 1) * sizeof *deformed);
    float *was = malloc((n ? n : 1) * 6 * sizeof *was); /* deformed instances' old boxes */
    if (!before || !light_was || !deformed || !was) abort();
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
    for (uint32_t i = 0; i < n; i++) { /* deformed: its mesh's BLAS is to be rebuilt */
        deformed[i] = rd_gpu_scene_mesh_stale(&svc->gs, s, s->instances[i].mesh);
        if (deformed[i]) { /* where it was, before the BLAS box changes */
            srv_scene_empty_box(&was[6 * i], &was[6 * i + 3]);
            srv_scene_grow_by_mesh(svc, s->instances[i].mesh, &before[16 * i], &was[6 * i],
                                   &was[6 * i + 3]);
        }
        any = any || deformed[i] || instance_moved(svc, before, i);
    }
    for (uint32_t i = 0; lights && i < nl; i++)
        lights_moved |= memcmp(&light_was[6 * i], s->lights[i].position, 3 * sizeof(float)) ||
                        memcmp(&light_was[6 * i + 3], s->lights[i].direction, 3 * sizeof(float));
    if (any) vr = rd_gpu_scene_update_pose(svc->vk, &svc->gs, s, NULL, err, errlen);
    if (vr == RD_VK_OK && lights_moved)
        vr = rd_gpu_scene_update_lights(svc->vk, &svc->gs, s, err, errlen);
    if (vr != RD_VK_OK) goto done;
    *moved = any || lights_moved;
    if (lights_moved)
        srv_scene_publish_lights(svc, true); /* GET answers follow; no event per frame */
    if (!wake) goto done;
    /* first: waking all replaces the boxes waiting for the next update */
    if (lights_moved)
        srv_scene_lighting_changed(svc, PC_DDGI_WAKE_AGE_NUDGE); /* a small step a frame */
    for (uint32_t i = 0; any && i < n; i++) {
        if (!deformed[i] && !instance_moved(svc, before, i)) continue;
        const rd_instance *in = &s->instances[i];
        float lo[3], hi[3];
        srv_scene_empty_box(lo, hi); /* rd_world_wake_box grows the boxes by a probe spacing */
        if (deformed[i])             /* the old shape's box at the old place */
            memcpy(lo, &was[6 * i], sizeof lo), memcpy(hi, &was[6 * i + 3], sizeof hi);
        else
            srv_scene_grow_by_mesh(svc, in->mesh, &before[16 * i], lo, hi);
        rd_world_wake_box(&svc->world, lo, hi, PC_DDGI_WAKE_AGE_GEOMETRY);
        srv_scene_empty_box(lo, hi);
        srv_scene_grow_by_mesh(svc, in->mesh, s->nodes[in->node].world, lo, hi);
        rd_world_wake_box(&svc->world, lo, hi, PC_DDGI_WAKE_AGE_GEOMETRY);
    }
    if (any) {
        svc->gi_updates = 0;
        if (svc->was_converged) srv_scene_publish_probes(svc);
    }
done:
    free(before);
    free(light_was);
    free(deformed);
    free(was);
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
    srv_snapshot_patch_scene(svc->snap, "nodes", srv_scene_nodes_json(s));
}

/* A new scene: which nodes its animations move, the clock at 0 (playing when there is
 * something to play) and the scene posed there. Before srv_scene_publish_scene. */
void srv_scene_load_playback(srv_scene_service *svc)
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
    if (srv_scene_pose(svc, false, &moved, err, sizeof err) != RD_VK_OK)
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
unsigned srv_scene_patch_playback(srv_scene_service *svc, srv_cmd *c)
{
    double now = srv_mono_ms();
    srv_playback *p = &svc->playback;
    srv_playback_advance(p, now);
    if (c->playback.has & SRV_PLAY_TIME) srv_playback_seek(p, c->playback.time_s, now);
    if (c->playback.has & SRV_PLAY_PLAYING) srv_playback_set_playing(p, c->playback.playing, now);
    char err[256];
    bool moved = false;
    if (srv_scene_pose(svc, true, &moved, err, sizeof err) != RD_VK_OK) {
        srv_cmd_fail(c, 500, SRV_ERR_GPU, err);
        return 0;
    }
    if (svc->st.scene.animation_count) publish_pose(svc);
    srv_snapshot_set_playback(svc->snap, p, false);
    srv_cmd_complete_json(c, 200, srv_json_playback(p, now));
    return moved ? SRV_CHANGE_VIEWS : 0;
}
