/* scene_state.h: what the render thread owns besides the GPU: the scene model, stable light
 * ids, the shared view's camera and the settings, and how API patches change them (settings
 * patches: srv_state_settings_apply in settings.h).
 *
 * Everything here is plain CPU code (tested without a GPU). Each apply function validates
 * the patch against the current state and either changes the state completely or leaves it
 * untouched and fills the srv_api_error.
 */
#ifndef SRV_SCENE_STATE_H
#define SRV_SCENE_STATE_H

#include <cjson/cJSON.h>

#include "server/api/commands.h"
#include "renderer/scene/camera.h"
#include "renderer/gi/ddgi.h"
#include "renderer/env/environment.h"
#include "renderer/scene/default_lighting.h"

typedef struct srv_scene_state {
    rd_scene scene;
    bool loaded;
    char source[128];                  /* "upload" or the scene given on the command line */
    char file_name[SRV_FILE_NAME_MAX]; /* the uploaded file's name, cleaned ("": not given) */
    uint64_t generation;               /* increases with every scene replacement */
    uint32_t *light_ids;               /* parallel to scene.lights */
    uint32_t next_light_id;
    bool *node_moved; /* parallel to scene.nodes: changed through the API */
    srv_camera camera;
    srv_settings settings;
    /* Default lighting (the renderer's rule, renderer/scene/default_lighting.h): a scene that
     * brings no light, no environment and no emitter strong enough gets the key light framed to
     * its default camera plus the default environment, until the user adds a light
     * (srv_state_drop_default_lighting) or takes the key light over (patch, delete); a sky the
     * user sets replaces the default environment. */
    bool default_lighting;
    uint32_t default_light_id;
    rd_default_lighting_check lighting; /* the rule's last check (at the scene's arrival) */
} srv_scene_state;

/* Empty state with default settings. */
void srv_state_init(srv_scene_state *st);
void srv_state_dispose(srv_scene_state *st); /* idempotent */

/* Takes over *scene (left zeroed), numbers its lights 0.. (continuing next_light_id), and
 * points the camera at it (the scene's first camera, else one framing its bounds). */
void srv_state_set_scene(srv_scene_state *st, rd_scene *scene, const char *source,
                         uint64_t generation);

/* An uploaded file's name as the client gave it (already URL-decoded) made safe to show and
 * store: the part after the last '/' or '\\', control characters and bytes that are not UTF-8
 * replaced by '_', cut to fewer than SRV_FILE_NAME_MAX bytes on a character boundary. False
 * (out empty) when nothing is left. */
bool srv_state_clean_file_name(const char *raw, char out[SRV_FILE_NAME_MAX]);

/* The environment the world renders with (e->image left NULL: the world owns the image): the
 * settings', or the default environment while default lighting is on and the settings' does not
 * light the scene. */
void srv_state_environment(const srv_scene_state *st, rd_environment *e);
/* Ends default lighting: removes the key light. False when it was off. */
bool srv_state_drop_default_lighting(srv_scene_state *st);

/* Index into scene.lights of light id, or -1. */
int srv_state_light_index(const srv_scene_state *st, uint32_t id);

bool srv_state_camera_apply(srv_camera *cam, const srv_camera_patch *p, bool replace,
                            srv_api_error *e);
/* Applies p to light l (position or direction detach it from its node). */
bool srv_state_light_apply(rd_light *l, const srv_light_patch *p, srv_api_error *e);
/* Adds a light (p must name its type); returns its id through *id. */
bool srv_state_light_add(srv_scene_state *st, const srv_light_patch *p, uint32_t *id,
                         srv_api_error *e);
bool srv_state_light_delete(srv_scene_state *st, uint32_t id, srv_api_error *e);
/* Moves node id and recomputes world matrices (rd_scene_update). */
bool srv_state_node_apply(srv_scene_state *st, uint32_t id, const srv_node_patch *p,
                          srv_api_error *e);

void srv_camera_from_view(const rd_view_camera *v, float target_distance, srv_camera *c);
void srv_camera_to_view(const srv_camera *c, rd_view_camera *v);

/* The persisted document: {"camera", "settings", "lights", "nodes" (moved nodes only),
 * "default_lighting" (the id of the default key light, or false)}. */
cJSON *srv_state_to_json(const srv_scene_state *st);
/* Applies a document written by srv_state_to_json to the current scene. Members that do not
 * fit the scene (a node id it lacks) are skipped with a warning in e->message; returns false
 * only for a document that is not of this shape. */
bool srv_state_restore(srv_scene_state *st, const cJSON *doc, srv_api_error *e);

#endif
