/* commands.h: what the network threads (HTTP, WebSocket) post to the render thread.
 *
 * Network threads parse and type-check client input into these plain structs (api_json.h)
 * and post them as srv_cmd through the render loop's mailbox (render_loop.h); only the render
 * thread applies them to the scene and the GPU, so every mutation happens between two frames and
 * nothing else locks the scene. A patch carries a bit set `has` naming the fields it sets;
 * everything else is left alone.
 */
#ifndef SRV_COMMANDS_H
#define SRV_COMMANDS_H

#include <cjson/cJSON.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "renderer/env/environment.h"
#include "renderer/accel/gpu_scene.h"
#include "renderer/world.h"
#include "renderer/scene/scene.h"
#include "server/api/api_error.h"
#include "server/api/mailbox.h"

/* ---- camera ------------------------------------------------------------------------------ */

/* The shared view's camera as the API describes it. */
typedef struct srv_camera {
    float position[3];
    float forward[3];      /* unit */
    float up[3];           /* unit, orthogonal to forward */
    float fov_deg;         /* vertical field of view */
    float target_distance; /* the reported target is position + forward * target_distance */
} srv_camera;

enum {
    SRV_CAM_POSITION = 1u << 0,
    SRV_CAM_TARGET = 1u << 1,
    SRV_CAM_ORIENTATION = 1u << 2, /* quaternion x, y, z, w: camera looks down its -Z, up +Y */
    SRV_CAM_FORWARD = 1u << 3,
    SRV_CAM_UP = 1u << 4,
    SRV_CAM_FOV = 1u << 5,
};

typedef struct srv_camera_patch {
    unsigned has;
    float position[3], target[3], orientation[4], forward[3], up[3];
    float fov_deg;
} srv_camera_patch;

/* ---- lights --------------------------------------------------------------------------------- */

enum {
    SRV_LIGHT_TYPE = 1u << 0,
    SRV_LIGHT_NAME = 1u << 1,
    SRV_LIGHT_COLOR = 1u << 2,
    SRV_LIGHT_INTENSITY = 1u << 3,
    SRV_LIGHT_POSITION = 1u << 4,
    SRV_LIGHT_DIRECTION = 1u << 5,
    SRV_LIGHT_RANGE = 1u << 6,
    SRV_LIGHT_INNER_CONE = 1u << 7,
    SRV_LIGHT_OUTER_CONE = 1u << 8,
};

#define SRV_NAME_MAX 64
/* an uploaded scene's file name (PUT /v1/scene?name=), terminator included */
#define SRV_FILE_NAME_MAX 128

typedef struct srv_light_patch {
    unsigned has;
    uint32_t type; /* RD_LIGHT_* */
    char name[SRV_NAME_MAX];
    float color[3], intensity, position[3], direction[3], range, inner_cone, outer_cone;
} srv_light_patch;

/* ---- nodes ---------------------------------------------------------------------------------- */

enum {
    SRV_NODE_TRANSLATION = 1u << 0,
    SRV_NODE_ROTATION = 1u << 1,
    SRV_NODE_SCALE = 1u << 2,
};

typedef struct srv_node_patch {
    unsigned has;
    float translation[3], rotation[4], scale[3];
} srv_node_patch;

/* ---- animation playback ----------------------------------------------------------------- */

enum {
    SRV_PLAY_PLAYING = 1u << 0,
    SRV_PLAY_TIME = 1u << 1,
};

typedef struct srv_playback_patch {
    unsigned has;
    bool playing;
    double time_s; /* finite, >= 0 (wrapped into the loop when applied) */
} srv_playback_patch;

/* ---- settings ------------------------------------------------------------------------------- */

/* srv_settings, the SRV_SET_* bits and srv_settings_patch come from the settings table. */
#include "server/api/settings.h"

/* ---- commands --------------------------------------------------------------------------- */

typedef enum srv_cmd_kind {
    SRV_CMD_GET_SCENE = 1,
    SRV_CMD_REPLACE_SCENE,
    SRV_CMD_GET_CAMERA,
    SRV_CMD_SET_CAMERA, /* PATCH, or PUT when replace */
    SRV_CMD_GET_LIGHTS,
    SRV_CMD_ADD_LIGHT,
    SRV_CMD_GET_LIGHT,
    SRV_CMD_PATCH_LIGHT,
    SRV_CMD_DELETE_LIGHT,
    SRV_CMD_GET_NODE,
    SRV_CMD_PATCH_NODE,
    SRV_CMD_GET_SETTINGS,
    SRV_CMD_PATCH_SETTINGS,
    SRV_CMD_PATCH_ANIMATION, /* play, pause, seek the scene's animations */
    SRV_CMD_VIEWER_CAMERA,   /* from the stream; no reply */
    SRV_CMD_VIEWER_RESIZE,   /* from the stream; no reply */
    SRV_CMD_VIEWER_QUALITY,  /* from the stream: the own view's caps; no reply */
    SRV_CMD_VIEW_OPEN,       /* a stream connection's own view (id chosen by the stream) */
    SRV_CMD_VIEW_CLOSE,      /* its connection left: free the view */
    SRV_CMD_VIEW_WATCH,      /* delta connections more (or fewer) show view `view` */
    SRV_CMD_VIEW_VIDEO,      /* delta of view `view`'s watchers more (or fewer) take video */
    SRV_CMD_FRAME_REQUEST,   /* GET /v1/frame.jpg: reply {"after": frame id} to wait past */
    SRV_CMD_SET_ENVIRONMENT, /* PUT/DELETE /v1/environment: env_image, or NULL to drop it */
    SRV_CMD_PICK,            /* POST /v1/views/{id}/pick: what lies under pick[] in view */
} srv_cmd_kind;

typedef struct srv_cmd {
    srv_mail mail; /* the mailbox's part: ticket, reply, references (mailbox.h) */
    srv_cmd_kind kind;
    uint32_t id;   /* light or node id */
    uint32_t view; /* the view a camera, resize, watch or frame request is for (0: default) */
    int delta;     /* VIEW_WATCH */
    bool replace;  /* SET_CAMERA: PUT (position and a direction are required) */
    srv_camera_patch camera;
    srv_light_patch light;
    srv_node_patch node;
    srv_settings_patch settings;
    srv_playback_patch playback;
    unsigned width, height;     /* VIEWER_RESIZE: device pixels */
    unsigned jpeg_cap, fps_cap; /* VIEWER_QUALITY: the view's caps (0: none) */
    rd_scene *scene;            /* REPLACE_SCENE: validated scene, owned by the command */
    /* REPLACE_SCENE from an upload: its BVHs built and its GPU buffers staged by the poster
     * (owned; NULL: the render thread builds them) */
    rd_gpu_scene_staged *staged;
    char source[128]; /* REPLACE_SCENE: where it came from ("upload", "builtin:...") */
    char file_name[SRV_FILE_NAME_MAX]; /* REPLACE_SCENE: the uploaded file's name ("": none) */
    float pick[2];                     /* PICK: normalised picture point (x across, y down), 0..1 */
    /* SET_ENVIRONMENT: the image staged for the GPU by the poster (owned), NULL = none */
    rd_env_staged *env_staged;
    uint64_t scene_generation; /* REPLACE_SCENE, set before a 200 reply: the scene's generation */
} srv_cmd;

/* A new command with one reference (the caller's); the last srv_cmd_unref frees what it owns. */
srv_cmd *srv_cmd_new(srv_cmd_kind kind);
void srv_cmd_unref(srv_cmd *c);
/* The command holding m (all mail of the render loop's mailbox is commands). */
static inline srv_cmd *srv_cmd_of(srv_mail *m)
{
    return (srv_cmd *)((char *)m - offsetof(srv_cmd, mail));
}

/* Render thread: hands the reply (body malloc'd or NULL, taken) to the waiting thread. */
void srv_cmd_complete(srv_cmd *c, int status, char *body);
void srv_cmd_complete_json(srv_cmd *c, int status, cJSON *j); /* j is deleted */
void srv_cmd_complete_error(srv_cmd *c, const srv_api_error *e);
void srv_cmd_fail(srv_cmd *c, int status, const char *code, const char *message);

#endif
