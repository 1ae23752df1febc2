/* ws_internal.h: what the stream's files share (ws_stream.c: connections, the libwebsockets
 * callback and sending frames; ws_messages.c: text messages in both directions — viewer input,
 * follow, events, welcome). Service thread only. Not for use outside the stream. */
#ifndef SRV_WS_INTERNAL_H
#define SRV_WS_INTERNAL_H

#include <libwebsockets.h>
#include <pthread.h>
#include <stdatomic.h>

#include "server/encode/video_stream.h"
#include "server/stream/viewer_msg.h"
#include "protocol/stream.h"
#include "server/stream/ws_stream.h"

#define FRAGMENT_BYTES (64 * 1024) /* payload per WebSocket fragment */
#define INPUT_RING 64              /* remembered (ticket, seq) pairs per viewer */
#define SENT_RING 16               /* remembered send times per viewer */
#define MAX_UNACKED 4              /* frames sent ahead of the viewer's acks */
#define ACK_STALL_MS 1000          /* after this long without acks, stop waiting for them */
#define RATE_LIMIT_PER_S 1000      /* viewer messages per second before the connection is closed */
#define STOP_GRACE_MS 1000
#define TEXT_QUEUE 16        /* server text messages waiting per viewer (v2) */
#define EVENT_MAX (4u << 20) /* the largest event document sent (bytes) */

typedef struct viewer {
    struct lws *wsi;
    struct viewer *prev, *next;
    uint32_t id;
    char ip[64];
    /* views (protocol/stream.md): version 2 owns a view; version 1 shares view 0 */
    unsigned version;
    uint32_t own_view; /* 0 for version 1 */
    uint32_t watching; /* the view whose frames it is sent */
    /* server text messages (version 2): a small queue, then the newest events */
    char *texts[TEXT_QUEUE];
    unsigned text_head, text_count;
    uint64_t seen[SRV_DOC_COUNT], seen_node;
    /* input: which ticket carried which seq */
    struct {
        uint64_t ticket;
        uint32_t seq;
        uint64_t received_us; /* Unix time the message arrived (latency stages) */
    } inputs[INPUT_RING];
    unsigned input_head, input_count;
    uint32_t evicted_seq;
    uint32_t timed_seq;    /* newest input whose first frame gave a latency sample */
    uint64_t cur_input_us; /* the input the current frame is the first to reflect, else 0 */
    uint64_t cur_send_us;
    /* receive */
    char rx[SRV_VIEWER_MSG_MAX + 1];
    size_t rx_len;
    double rate_window_ms;
    unsigned rate_count;
    /* send */
    uint8_t *tx; /* LWS_PRE + FRAGMENT_BYTES */
    srv_frame *cur;
    const uint8_t *cur_data; /* the payload: a JPEG variant of cur, or cur_video's packet */
    size_t cur_size;
    srv_video_out *cur_video;
    size_t cur_pos; /* bytes of the current message sent (header included) */
    uint8_t cur_header[PROTO_STREAM_HEADER_SIZE];
    uint64_t last_sent_id; /* of the watched view (frame ids are global over views) */
    struct {
        uint64_t id;
        double ms;
        size_t bytes;
    } sent[SENT_RING];
    unsigned sent_head;
    uint64_t acked_id;
    bool acked_any;
    double lag_ms, last_ack_ms;
    unsigned cap; /* quality cap from lag (100 = none) */
    /* video (protocol/stream.md, "video" message): NULL while the viewer gets JPEG */
    srv_video_stream *video;
    unsigned format;          /* proto_format of the video stream */
    unsigned video_max_kbps;  /* the viewer's cap (0: none) */
    uint64_t video_queued_id; /* newest frame handed to the video encoder */
    /* the view whose video watchers count this viewer (render loop: srv_view.video_watchers);
     * 0 with video_counted false */
    bool video_counted;
    uint32_t video_counted_view;
    uint64_t acked_bytes; /* payload bytes of acknowledged frames since the last tick */
    uint64_t sent_bytes;  /* payload bytes sent since the last tick */
    double encode_ms;     /* smoothed video encode time */
    double sent_kbps;     /* over the last tick */
    /* closing */
    int close_code;
    char close_reason[64];
} viewer;

/* A connection the HTTP API handed over (srv_ws_adopt), until the service thread takes it. */
typedef struct srv_ws_adoption {
    char ip[64]; /* first: the adopted wsi's opaque user data points here */
    int fd;
    struct srv_ws_adoption *next;
} srv_ws_adoption;

struct srv_ws_stream {
    srv_ws_config cfg;
    char token[256], http_host[256];
    struct lws_context *ctx;
    struct lws_vhost *vhost;  /* --ws's listening socket; NULL without one */
    struct lws_vhost *bridge; /* no socket of its own: connections from the HTTP API */
    pthread_mutex_t adopt_mu;
    srv_ws_adoption *adopt_head;
    struct lws_protocols protocols[3];
    lws_retry_bo_t retry;
    lws_sorted_usec_list_t tick;
    pthread_t thread;
    bool started;
    atomic_bool stopping, frame_pending, event_pending;
    bool exit_loop;
    double stop_deadline_ms;
    viewer *viewers; /* service thread only */
    unsigned viewer_count, v2_count;
    uint32_t next_viewer_id;
    uint64_t bytes_at_tick;
    double tick_ms;
    pthread_mutex_t stats_mu;
    srv_ws_stats stats;
    srv_latency_ring latency; /* under stats_mu */
};

void srv_ws_close_viewer(viewer *v, int code, const char *reason);
/* ws_handshake.c: NULL to accept the upgrade, else the reason it is refused (logged); the
 * client's address (for a connection handed over by the HTTP API, the one it came from there);
 * whether it offered protocol version 2 (a view of its own). */
const char *srv_ws_handshake_refusal(srv_ws_stream *ws, struct lws *wsi);
void srv_ws_peer_ip(struct lws *wsi, char *ip, size_t n);
bool srv_ws_offers_v2(struct lws *wsi);
void srv_ws_update_caps(srv_ws_stream *ws);
unsigned srv_ws_cap_from_lag(double lag_ms);
void srv_ws_queue_text(viewer *v, char *text);
#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
void srv_ws_queue_textf(viewer *v, const char *fmt, ...);
char *srv_ws_next_text(srv_ws_stream *ws, viewer *v);
bool srv_ws_has_news(srv_ws_stream *ws, const viewer *v);
int srv_ws_send_text(srv_ws_stream *ws, viewer *v, char *text);
void srv_ws_watch(srv_ws_stream *ws, viewer *v, uint32_t view);
void srv_ws_release_followers(srv_ws_stream *ws, uint32_t view);
void srv_ws_handle_message(srv_ws_stream *ws, viewer *v);
/* Video (ws_video.c): starts, changes or (format JPEG) stops v's video stream. */
void srv_ws_video_set(srv_ws_stream *ws, viewer *v, unsigned format, unsigned max_kbps);
void srv_ws_video_stop(srv_ws_stream *ws, viewer *v);
/* Tells the render loop when v starts or stops taking video of the view it watches (call after
 * either changes): a view all of whose watchers take video skips the JPEG of moving frames. */
void srv_ws_video_count(srv_ws_stream *ws, viewer *v);
/* What v is sent next: a video packet (*out), a frame to send as JPEG (*jpeg: every frame
 * without video; a still, or a frame without pixels, with it), or neither (nothing new, or the
 * encoder is busy: its ready callback wakes the service thread). */
void srv_ws_video_next(srv_ws_stream *ws, viewer *v, srv_video_out **out, srv_frame **jpeg);
/* Once a second, with stats_mu held: each viewer's sent bitrate, its video target bitrate from
 * its acknowledged bytes and lag, and the per-viewer stats. */
void srv_ws_video_tick(srv_ws_stream *ws, double seconds);

#endif
