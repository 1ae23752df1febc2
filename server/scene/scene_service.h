/* scene_service.h: the world side of the daemon — the scene state (scene, lights, nodes,
 * settings), its GPU scene and the shared rd_world (environment and probe field), the clock of
 * the scene's glTF animations (playback.h), and the API semantics of changing them. Render
 * thread only.
 *
 * srv_scene_service_apply takes a world command (scene replacement, light, node, settings or
 * animation playback change), validates it against the current state, applies it to the CPU
 * state and the GPU, completes the command with the API's reply, publishes the changed
 * documents to the snapshot (which turns them into events) and says what the views must do
 * about it.
 */
#ifndef SRV_SCENE_SERVICE_H
#define SRV_SCENE_SERVICE_H

#include <cjson/cJSON.h>

#include "server/scene/animation.h"
#include "server/api/commands.h"
#include "server/api/mailbox.h"
#include "server/scene/playback.h"
#include "renderer/world.h"
#include "server/scene/scene_state.h"
#include "server/scene/snapshot.h"

/* What a change means for the views (bits). */
enum {
    SRV_CHANGE_VIEWS = 1u << 0,  /* every view shows something new: re-render them all */
    SRV_CHANGE_SCENE = 1u << 1,  /* a new scene: every view's camera goes to st.camera */
    SRV_CHANGE_SIZE = 1u << 2,   /* settings width/height: the default view's size */
    SRV_CHANGE_LIMITS = 1u << 3, /* settings max_pixels */
    SRV_CHANGE_PERSIST = 1u << 4 /* the saved state is out of date */
};

typedef struct srv_scene_service {
    rd_vk *vk;
    srv_snapshot *snap;
    srv_scene_state st;
    rd_gpu_scene gs;
    bool gs_ok;
    rd_world world;
    bool world_ok;
    uint64_t generation_counter;
    unsigned gi_updates;   /* probe updates since the last change that woke probes */
    unsigned pt_target;    /* path tracing: samples per view to accumulate (0: not path tracing) */
    bool was_converged;    /* as last published in the scene document */
    srv_animation anim;    /* the demo light */
    srv_playback playback; /* the scene's own (glTF) animations */
    bool *animated;        /* parallel to st.scene.nodes: an animation moves the node */
} srv_scene_service;

/* Takes over scene (left zeroed) and builds its GPU scene and the world; applies saved_state
 * (may be NULL) first. On error everything is released and a message is in err. */
rd_vk_result srv_scene_service_init(srv_scene_service *svc, rd_vk *vk, srv_snapshot *snap,
                                    const srv_settings *settings, rd_scene *scene,
                                    const char *source, uint64_t generation,
                                    uint64_t generation_base, const cJSON *saved_state, char *err,
                                    size_t errlen);
void srv_scene_service_dispose(srv_scene_service *svc); /* idempotent; the device must be idle */

/* Applies a world command and completes it; returns SRV_CHANGE_* bits. */
unsigned srv_scene_service_apply(srv_scene_service *svc, srv_cmd *c);

/* The probe field still wants updates: some probe is awake (rd_world_converged). */
bool srv_scene_service_converging(const srv_scene_service *svc);
/* Tells the scene's animation clock whether someone watches (viewers is not 0): it runs only
 * then. Call before srv_scene_service_animating; cheap. */
void srv_scene_service_watch(srv_scene_service *svc, unsigned viewers, double now_ms);
/* The world moves by itself: the demo animation runs (enabled, the scene has a light, viewers
 * is not 0) or the scene's animations play (and someone watches). */
bool srv_scene_service_animating(const srv_scene_service *svc, unsigned viewers);
/* One world tick: moves the demo light and poses the scene at its animation clock's time (when
 * animating) and runs up to `updates` probe updates, fewer when the field converges first. */
rd_vk_result srv_scene_service_advance(srv_scene_service *svc, bool animating, unsigned updates,
                                       double now_ms, char *err, size_t errlen);
/* The saved-state document (the default view's camera passed in). */
cJSON *srv_scene_service_state_json(srv_scene_service *svc, const srv_camera *default_camera);

#endif
