/* ws_stream.h: the WebSocket frame stream (/v1/stream, protocol/stream.md) on libwebsockets.
 *
 * One service thread owns every connection. Encoder threads only signal it (a frame was
 * published: lws_cancel_service); it then asks each idle viewer's socket for writability and
 * sends the newest frame of the view the viewer watches, fragmented, at the quality the viewer's
 * lag allows. Each version-2 connection owns a view (opened and closed through the render
 * thread's mailbox) and may follow another; version-1 connections share view 0. World changes
 * published to the snapshot go out as event messages between frames. Each viewer has
 * at most one frame in flight and the newest one pending (never a queue), so a slow viewer
 * only skips frames: it never slows the renderer or the other viewers. Viewer text messages
 * (camera, resize, ack) are validated, size- and rate-capped, and posted to the render thread.
 */
#ifndef SRV_WS_STREAM_H
#define SRV_WS_STREAM_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "server/api/access.h"
#include "server/encode/encoder_pool.h"
#include "server/render/latency_stats.h"
#include "server/render/render_loop.h"

typedef struct srv_ws_config {
    const char *address; /* numeric IP to listen on; NULL: no port of its own (srv_ws_adopt only) */
    unsigned port;       /* 0 = any free port */
    const char *token;   /* NULL or "" = no token required */
    const char *public_names; /* Host names besides loopback and IP literals (comma-separated) */
    const char *http_host;    /* the HTTP API's address, for the Origin check */
    unsigned http_port;
    unsigned max_viewers; /* 0 = 100 */
    unsigned max_per_ip;  /* 0 = 64 */
    /* both or neither: wss:// only, with the PEM certificate (chain) and key in these files
     * (tls_cert.h checked them) */
    const char *tls_cert_path, *tls_key_path;
    srv_render_loop *loop;
    srv_encoder_pool *encoders;
    srv_snapshot *snapshot;
    unsigned vp9_speed, video_threads; /* video viewers' encoders (0: defaults) */
} srv_ws_config;

/* One viewer's frame format (issue 26), as of the last tick (once a second). */
#define SRV_WS_STATS_VIEWERS 64
typedef struct srv_ws_viewer_stats {
    uint32_t viewer, view; /* the connection, and the view it watches */
    unsigned format;       /* proto_format it is sent (stills are JPEG in every format) */
    unsigned target_kbps;  /* video: the encoder's target bitrate; 0 for JPEG */
    double sent_kbps;      /* payload kbit/s sent over the last second */
    double encode_ms;      /* video: smoothed encode time of a frame; 0 for JPEG */
} srv_ws_viewer_stats;

typedef struct srv_ws_stats {
    unsigned viewers;
    uint64_t frames_sent, frames_skipped, bytes_sent, messages_received, events_sent;
    uint64_t connections_rejected, connections_closed_for_abuse;
    uint64_t inputs_dropped;     /* viewer messages the render queue had no room for (a flood) */
    double bandwidth_bps;        /* bits per second sent over the last second */
    double lag_ms_max;           /* largest smoothed viewer lag */
    srv_latency_summary latency; /* input-to-frame stages (server/render/latency_stats.h) */
    unsigned viewer_count;       /* of per_viewer: the first SRV_WS_STATS_VIEWERS viewers */
    unsigned video_viewers;      /* viewers on a video format (all of them, not only listed) */
    srv_ws_viewer_stats per_viewer[SRV_WS_STATS_VIEWERS];
} srv_ws_stats;

typedef struct srv_ws_stream srv_ws_stream;

/* Binds the listening socket (when cfg->address is set). NULL with a message on failure. */
srv_ws_stream *srv_ws_create(const srv_ws_config *cfg, char *err, size_t errlen);
/* The listening port; 0 without one. */
unsigned srv_ws_port(const srv_ws_stream *ws);
/* Hands over a connected socket whose first bytes will be an HTTP upgrade request for
 * /v1/stream (any thread; the service thread adopts it). peer_ip is the client's address, for the
 * per-address limit. Takes fd (closed on failure); false when stopping. */
bool srv_ws_adopt(srv_ws_stream *ws, int fd, const char *peer_ip);
/* The HTTP API's port for the Origin check, once it is known (before srv_ws_start). */
void srv_ws_set_http_port(srv_ws_stream *ws, unsigned port);
bool srv_ws_start(srv_ws_stream *ws);
/* Closes every viewer (1001 going away), stops the thread and frees ws (NULL is fine). */
void srv_ws_destroy(srv_ws_stream *ws);
/* The encoder pool's listener: a new frame was published (any thread). */
void srv_ws_frame_ready(void *ws);
/* The snapshot's listener: the world changed, viewers get events (any thread). */
void srv_ws_event_ready(void *ws);
void srv_ws_get_stats(srv_ws_stream *ws, srv_ws_stats *out);

#endif
