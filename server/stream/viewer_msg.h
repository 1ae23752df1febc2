/* viewer_msg.h: the text messages a viewer sends on the stream (protocol/stream.md), parsed
 * as strictly as the API's bodies (server/api/api_json.h, whose field readers it uses): one JSON
 * object of a known type whose every member is known, of the right type and in range; otherwise
 * a 400 srv_api_error whose message names the field. ws_messages.c acts on what it returns.
 */
#ifndef SRV_VIEWER_MSG_H
#define SRV_VIEWER_MSG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "server/api/api_error.h"
#include "server/api/commands.h"

/* Longest viewer message accepted. */
#define SRV_VIEWER_MSG_MAX 4096

typedef enum srv_viewer_msg_type {
    SRV_VIEWER_CAMERA = 1,
    SRV_VIEWER_RESIZE,
    SRV_VIEWER_ACK,
    SRV_VIEWER_FOLLOW,  /* version 2 */
    SRV_VIEWER_QUALITY, /* version 2 */
    SRV_VIEWER_VIDEO,   /* version 2 */
} srv_viewer_msg_type;

/* Per-view caps a viewer sets for its own view (quality message); 0 means no cap. */
#define SRV_VIEW_JPEG_CAP_MAX 100u
#define SRV_VIEW_FPS_CAP_MAX 240u

typedef struct srv_viewer_msg {
    srv_viewer_msg_type type;
    uint32_t seq;            /* camera */
    srv_camera_patch camera; /* camera */
    unsigned width, height;  /* resize: CSS pixels */
    float dpr;               /* resize: device pixel ratio (default 1) */
    uint64_t frame;          /* ack */
    uint32_t view;           /* follow: the view to watch */
    bool follow_own;         /* follow: null (back to the own view) */
    unsigned jpeg_cap;       /* quality: JPEG quality 1..100 at most (0: no cap) */
    unsigned fps_cap;        /* quality: frames per second 1..240 at most (0: no cap) */
    char codec[16];          /* video: the codec asked for, as sent (cut short); "" for null */
    double max_kbps;         /* video: the bitrate cap as sent; -1 for null (no cap) */
} srv_viewer_msg;

/* What a video message asks for once checked: format is a proto_format (JPEG for codec null),
 * max_kbps the cap (0: none). A codec the live stream does not offer, or a cap outside
 * SRV_VIDEO_MIN_KBPS..SRV_VIDEO_MAX_KBPS, is not a malformed message but a request that cannot be
 * done: false, with the sentence for the protocol's error message in why (the viewer stays on
 * what it had). */
bool srv_viewer_video_request(const srv_viewer_msg *m, unsigned *format, unsigned *max_kbps,
                              char *why, size_t why_size);

/* A text message of the stream: {"type": "camera" | "resize" | "follow" | "ack" | "quality" |
 * "video",
 * ...} of at most SRV_VIEWER_MSG_MAX bytes (a longer one fails with SRV_ERR_TOO_LARGE). */
bool srv_json_viewer_msg(const char *text, size_t len, srv_viewer_msg *out, srv_api_error *e);

#endif
