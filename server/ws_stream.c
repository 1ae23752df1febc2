/* ws_stream.c: the frame stream on libwebsockets (one service thread). */
#include "ws_stream.h"
#include "clock.h"

#include <libwebsockets.h>
#include <math.h>
#include <stdarg.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>

#include "api_json.h"
#include "log.h"
#include "protocol/stream.h"

#define FRAGMENT_BYTES (64 * 1024) /* payload per WebSocket fragment */
#define INPUT_RING 64              /* remembered (ticket, seq) pairs per viewer */
#define SENT_RING 16               /* remembered send times per viewer */
#define MAX_UNACKED 4              /* frames sent ahead of the viewer's acks */
#define ACK_STALL_MS 1000          /* after this long without acks, stop waiting for them */
#define RATE_LIMIT_PER_S 1000      /* viewer messages per second before the connection is closed */
#define STOP_GRACE_MS 1000
#define TEXT_QUEUE 16              /* server text messages waiting per viewer (v2) */
#define EVENT_MAX (4u << 20)       /* the largest event document sent (bytes) */

typedef struct viewer {
    struct lws *wsi;
    struct viewer *prev, *next;
    uint32_t id;
    char ip[64];
    /* views (protocol/stream.md): version 2 owns a view; version 1 shares view 0 */
    unsigned version;
    uint32_t own_view;  /* 0 for version 1 */
    uint32_t watching;  /* the view whose frames it is sent */
    /* server text messages (version 2): a small queue, then the newest events */
    char *texts[TEXT_QUEUE];
    unsigned text_head, text_count;
    uint64_t seen[SRV_DOC_COUNT], seen_node;
    /* input: which ticket carried which seq */
    struct {
        uint64_t ticket;
        uint32_t seq;
    } inputs[INPUT_RING];
    unsigned input_head, input_count;
    uint32_t evicted_seq;
    /* receive */
    char rx[SRV_VIEWER_MSG_MAX + 1];
    size_t rx_len;
    double rate_window_ms;
    unsigned rate_count;
    /* send */
    uint8_t *tx; /* LWS_PRE + FRAGMENT_BYTES */
    srv_frame *cur;
    const srv_jpeg *cur_jpeg;
    size_t cur_pos; /* bytes of the current message sent (header included) */
    uint8_t cur_header[PROTO_STREAM_HEADER_SIZE];
    uint64_t last_sent_id; /* of the watched view (frame ids are global over views) */
    struct {
        uint64_t id;
        double ms;
    } sent[SENT_RING];
    unsigned sent_head;
    uint64_t acked_id;
    bool acked_any;
    double lag_ms, last_ack_ms;
    unsigned cap; /* quality cap from lag (100 = none) */
    /* closing */
    int close_code;
    char close_reason[64];
} viewer;

struct srv_ws_stream {
    srv_ws_config cfg;
    char token[256], http_host[256];
    struct lws_context *ctx;
    struct lws_vhost *vhost;
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
};



/* ---- handshake checks --------------------------------------------------------------------- */

bool srv_token_equal(const char *given, size_t given_len, const char *token)
{
    size_t n = strlen(token);
    unsigned char diff = given_len != n;
    for (size_t i = 0; i < given_len; i++)
        diff |= (unsigned char)(given[i] ^ token[i % (n ? n : 1)]);
    return diff == 0 && n > 0;
}

static bool is_loopback_name(const char *h)
{
    return strcasecmp(h, "localhost") == 0 || strncmp(h, "127.", 4) == 0 || strcmp(h, "::1") == 0 ||
           strcmp(h, "[::1]") == 0;
}

/* Splits "host[:port]" or "[v6]:port"; port stays dflt when absent. */
static bool split_host_port(const char *s, size_t len, char *host, size_t hostlen, unsigned *port,
                            unsigned dflt)
{
    *port = dflt;
    const char *end = s + len, *colon = NULL;
    if (len > 0 && s[0] == '[') {
        const char *rb = memchr(s, ']', len);
        if (!rb) return false;
        if (rb + 1 < end) {
            if (rb[1] != ':') return false;
            colon = rb + 1;
        }
        size_t hl = (size_t)(rb - s - 1);
        if (hl + 1 > hostlen) return false;
        memcpy(host, s + 1, hl);
        host[hl] = 0;
    } else {
        colon = memchr(s, ':', len);
        size_t hl = colon ? (size_t)(colon - s) : len;
        if (hl == 0 || hl + 1 > hostlen) return false;
        memcpy(host, s, hl);
        host[hl] = 0;
    }
    if (colon) {
        char *e = NULL;
        char buf[8];
        size_t pl = (size_t)(end - colon - 1);
        if (pl == 0 || pl >= sizeof buf) return false;
        memcpy(buf, colon + 1, pl);
        buf[pl] = 0;
        unsigned long p = strtoul(buf, &e, 10);
        if (*e || p == 0 || p > 65535) return false;
        *port = (unsigned)p;
    }
    return true;
}

bool srv_ws_origin_allowed(const char *origin, const char *http_host, unsigned http_port,
                           const char *request_host)
{
    unsigned dflt;
    const char *rest;
    if (strncasecmp(origin, "http://", 7) == 0)
        dflt = 80, rest = origin + 7;
    else if (strncasecmp(origin, "https://", 8) == 0)
        dflt = 443, rest = origin + 8;
    else
        return false; /* "null", file://, other schemes */
    char host[256];
    unsigned port;
    size_t len = strcspn(rest, "/");
    if (!split_host_port(rest, len, host, sizeof host, &port, dflt)) return false;
    if (port != http_port) return false;
    bool wildcard = strcmp(http_host, "0.0.0.0") == 0 || strcmp(http_host, "::") == 0;
    if (wildcard) {
        /* listening everywhere: the page must come from the host name this request used */
        char rhost[256];
        unsigned rport;
        if (!request_host ||
            !split_host_port(request_host, strlen(request_host), rhost, sizeof rhost, &rport, 80))
            return false;
        return strcasecmp(host, rhost) == 0 || (is_loopback_name(host) && is_loopback_name(rhost));
    }
    return strcasecmp(host, http_host) == 0 ||
           (is_loopback_name(host) && is_loopback_name(http_host));
}

/* Token from "Authorization: Bearer T", "?token=T" or a "bearer.T" subprotocol entry. */
static bool token_ok(srv_ws_stream *ws, struct lws *wsi)
{
    if (!ws->token[0]) return true;
    char buf[1024];
    int n = lws_hdr_copy(wsi, buf, sizeof buf, WSI_TOKEN_HTTP_AUTHORIZATION);
    if (n > 7 && strncasecmp(buf, "Bearer ", 7) == 0 &&
        srv_token_equal(buf + 7, (size_t)n - 7, ws->token))
        return true;
    const char *v = lws_get_urlarg_by_name(wsi, "token=", buf, sizeof buf);
    if (v && srv_token_equal(v, strlen(v), ws->token)) return true;
    n = lws_hdr_copy(wsi, buf, sizeof buf, WSI_TOKEN_PROTOCOL);
    for (char *save = NULL, *t = n > 0 ? strtok_r(buf, ", ", &save) : NULL; t;
         t = strtok_r(NULL, ", ", &save))
        if (strncmp(t, "bearer.", 7) == 0 && srv_token_equal(t + 7, strlen(t + 7), ws->token))
            return true;
    return false;
}

/* Whether the client asked for protocol version 2 (its own view). */
static bool offers_v2(struct lws *wsi)
{
    char buf[1024];
    int n = lws_hdr_copy(wsi, buf, sizeof buf, WSI_TOKEN_PROTOCOL);
    for (char *save = NULL, *t = n > 0 ? strtok_r(buf, ", ", &save) : NULL; t;
         t = strtok_r(NULL, ", ", &save))
        if (strcmp(t, "probecast.v2") == 0) return true;
    return false;
}

typedef struct srv_settings_view_size {
    unsigned width, height;
} srv_settings_view_size;

/* The size a new view starts at (the width and height settings, as published). */
static srv_settings_view_size default_size(srv_ws_stream *ws)
{
    srv_settings_view_size sz = {0, 0};
    srv_view_info v0;
    if (srv_snapshot_view(ws->cfg.snapshot, SRV_DEFAULT_VIEW, &v0))
        sz.width = v0.width, sz.height = v0.height;
    return sz;
}

/* 0 to accept the upgrade, else a reason logged and the connection refused. */
static const char *handshake_refusal(srv_ws_stream *ws, struct lws *wsi)
{
    char buf[1024], host[256] = "";
    if (atomic_load(&ws->stopping)) return "shutting down";
    if (lws_hdr_copy(wsi, buf, sizeof buf, WSI_TOKEN_GET_URI) <= 0 ||
        strcmp(buf, "/v1/stream") != 0)
        return "unknown path";
    if (lws_hdr_total_length(wsi, WSI_TOKEN_ORIGIN) > 0) {
        if (lws_hdr_total_length(wsi, WSI_TOKEN_ORIGIN) >= (int)sizeof buf)
            return "origin too long";
        lws_hdr_copy(wsi, buf, sizeof buf, WSI_TOKEN_ORIGIN);
        lws_hdr_copy(wsi, host, sizeof host, WSI_TOKEN_HOST);
        if (!srv_ws_origin_allowed(buf, ws->http_host, ws->cfg.http_port, host))
            return "origin not allowed";
    }
    if (!token_ok(ws, wsi)) return "missing or wrong token";
    if (ws->viewer_count >= ws->cfg.max_viewers) return "too many viewers";
    if (offers_v2(wsi)) {
        srv_view_limits lim;
        srv_render_view_limits(ws->cfg.loop, &lim);
        if (ws->v2_count + 1 >= lim.max_views)
            return "too many views (the server's --max-views); connect with probecast.v1 to "
                   "share the default view";
    }
    char ip[64] = "";
    lws_get_peer_simple(wsi, ip, sizeof ip);
    unsigned same = 0;
    for (viewer *v = ws->viewers; v; v = v->next)
        same += strcmp(v->ip, ip) == 0;
    if (same >= ws->cfg.max_per_ip) return "too many viewers from this address";
    return NULL;
}

/* ---- quality and flow --------------------------------------------------------------------- */

/* Guacamole's rule: quality = 90 - (lag_ms - 20), clamped to [30, 90]; 90 means no cap. */
static unsigned cap_from_lag(double lag_ms)
{
    double q = 90 - (lag_ms - 20);
    if (q >= 90) return 100;
    if (q < SRV_CAP_MIN) q = SRV_CAP_MIN;
    return (unsigned)(q / 10) * 10;
}

static void update_caps(srv_ws_stream *ws)
{
    uint32_t mask = 0;
    double lag_max = 0;
    for (viewer *v = ws->viewers; v; v = v->next) {
        if (v->cap < 90) mask |= 1u << ((v->cap - SRV_CAP_MIN) / 10);
        if (v->lag_ms > lag_max) lag_max = v->lag_ms;
    }
    srv_encoder_set_caps(ws->cfg.encoders, mask);
    pthread_mutex_lock(&ws->stats_mu);
    ws->stats.lag_ms_max = lag_max;
    pthread_mutex_unlock(&ws->stats_mu);
}

static unsigned unacked(const viewer *v)
{
    unsigned n = 0;
    for (unsigned i = 0; i < SENT_RING; i++)
        n += v->sent[i].id > v->acked_id;
    return n;
}

static bool flow_blocked(const viewer *v, double now)
{
    return v->acked_any && unacked(v) >= MAX_UNACKED && now - v->last_ack_ms < ACK_STALL_MS;
}

static uint32_t seq_for(const viewer *v, uint32_t view, uint64_t ticket)
{
    if (view != v->own_view) return 0; /* its camera messages go to its own view only */
    for (unsigned i = 0; i < v->input_count; i++) {
        unsigned k = (v->input_head + INPUT_RING - 1 - i) % INPUT_RING;
        if (v->inputs[k].ticket <= ticket) return v->inputs[k].seq;
    }
    return v->evicted_seq;
}

/* Whether a newer frame than the viewer's last one is published. */
static bool has_new_frame(srv_ws_stream *ws, const viewer *v)
{
    srv_frame *f = srv_encoder_latest(ws->cfg.encoders, v->watching);
    bool fresh = f && f->info.frame_id > v->last_sent_id;
    srv_frame_unref(f);
    return fresh;
}

static void close_viewer(viewer *v, int code, const char *reason)
{
    if (v->close_code) return;
    v->close_code = code;
    snprintf(v->close_reason, sizeof v->close_reason, "%s", reason);
    lws_callback_on_writable(v->wsi);
}

/* ---- server text messages (version 2) ------------------------------------------------------ */

/* Queues a text message (taken); a viewer that lets TEXT_QUEUE pile up is too slow to keep. */
static void queue_text(viewer *v, char *text)
{
    if (v->version < 2) {
        free(text);
        return;
    }
    if (v->text_count == TEXT_QUEUE) {
        free(text);
        close_viewer(v, LWS_CLOSE_STATUS_POLICY_VIOLATION, "not reading messages");
        return;
    }
    v->texts[(v->text_head + v->text_count++) % TEXT_QUEUE] = text;
    lws_callback_on_writable(v->wsi);
}

static void queue_textf(viewer *v, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void queue_textf(viewer *v, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    char *text = NULL;
    if (vasprintf(&text, fmt, ap) < 0) abort();
    va_end(ap);
    queue_text(v, text);
}

static char *event_text(const char *what, const char *doc)
{
    char *text = NULL;
    if (asprintf(&text, "{\"type\":\"event\",\"what\":\"%s\",\"data\":%s}", what, doc) < 0)
        abort();
    return text;
}

/* The next text message for v (malloc'd), or NULL: the queue first, then each kind of event
 * whose document changed since v saw it (only the newest document of a kind is sent). */
static char *next_text(srv_ws_stream *ws, viewer *v)
{
    if (v->version < 2) return NULL;
    if (v->text_count) {
        char *t = v->texts[v->text_head];
        v->text_head = (v->text_head + 1) % TEXT_QUEUE;
        v->text_count--;
        return t;
    }
    for (int k = 0; k < SRV_DOC_COUNT; k++) {
        if (srv_snapshot_version(ws->cfg.snapshot, (srv_doc)k) <= v->seen[k]) continue;
        char *doc = srv_snapshot_print(ws->cfg.snapshot, (srv_doc)k, &v->seen[k]);
        if (!doc) continue;
        char *t = strlen(doc) <= EVENT_MAX ? event_text(srv_doc_name((srv_doc)k), doc) : NULL;
        free(doc);
        if (t) return t;
    }
    uint64_t ver;
    char *doc = srv_snapshot_next_node(ws->cfg.snapshot, v->seen_node, &ver);
    if (doc) {
        v->seen_node = ver;
        char *t = event_text("node", doc);
        free(doc);
        return t;
    }
    return NULL;
}

static bool has_news(srv_ws_stream *ws, const viewer *v)
{
    if (v->version < 2) return false;
    if (v->text_count) return true;
    for (int k = 0; k < SRV_DOC_COUNT; k++)
        if (srv_snapshot_version(ws->cfg.snapshot, (srv_doc)k) > v->seen[k]) return true;
    return srv_snapshot_node_version(ws->cfg.snapshot) > v->seen_node;
}

/* Sends one text message; -1 when the connection must close. */
static int send_text(srv_ws_stream *ws, viewer *v, char *text)
{
    size_t len = strlen(text);
    uint8_t *buf = malloc(LWS_PRE + len);
    if (!buf) abort();
    memcpy(buf + LWS_PRE, text, len);
    free(text);
    int n = lws_write(v->wsi, buf + LWS_PRE, len, LWS_WRITE_TEXT);
    free(buf);
    if (n < (int)len) return -1;
    pthread_mutex_lock(&ws->stats_mu);
    ws->stats.bytes_sent += len;
    ws->stats.events_sent++;
    pthread_mutex_unlock(&ws->stats_mu);
    lws_callback_on_writable(v->wsi); /* more news, or the frame */
    return 0;
}

/* Points v at view `view` (its own, or one it follows), moving its watch there. */
static void watch(srv_ws_stream *ws, viewer *v, uint32_t view)
{
    if (view == v->watching) return;
    srv_cmd *c = srv_cmd_new(SRV_CMD_VIEW_WATCH);
    c->view = v->watching;
    c->delta = -1;
    srv_render_post(ws->cfg.loop, c);
    c = srv_cmd_new(SRV_CMD_VIEW_WATCH);
    c->view = view;
    c->delta = 1;
    srv_render_post(ws->cfg.loop, c);
    v->watching = view;
    v->last_sent_id = 0; /* frame ids of another view are not comparable */
    queue_textf(v, "{\"type\":\"following\",\"view\":%u}", view);
    lws_callback_on_writable(v->wsi);
}

/* Connections that follow a view whose owner left go back to their own view. */
static void release_followers(srv_ws_stream *ws, uint32_t view)
{
    for (viewer *x = ws->viewers; x; x = x->next)
        if (x->watching == view && x->own_view != view) watch(ws, x, x->own_view);
}

/* Sends the next fragment of the viewer's frame, starting the newest frame when idle (text
 * messages go first, between frames). Returns -1 when the connection must close. */
static int send_some(srv_ws_stream *ws, viewer *v)
{
    double now = srv_mono_ms();
    if (!v->cur) {
        char *text = next_text(ws, v);
        if (text) return send_text(ws, v, text);
        if (flow_blocked(v, now)) return 0;
        srv_frame *f = srv_encoder_latest(ws->cfg.encoders, v->watching);
        if (!f || f->info.frame_id <= v->last_sent_id) {
            srv_frame_unref(f);
            return 0;
        }
        v->cur = f;
        v->cur_jpeg = srv_frame_pick(f, v->cap);
        v->cur_pos = 0;
        proto_frame_header h = {
            .frame_id = f->info.frame_id,
            .capture_us = f->info.capture_us,
            .encode_us = f->encode_us,
            .send_us = srv_unix_us(),
            .view_id = f->info.view_id,
            .width = f->width,
            .height = f->height,
            .input_seq = seq_for(v, f->info.view_id, f->info.input_ticket),
            .jpeg_size = (uint32_t)v->cur_jpeg->size,
            .quality = (uint8_t)v->cur_jpeg->quality,
            .flags = f->info.still ? PROTO_STREAM_FLAG_STILL : 0,
        };
        h.version = (uint16_t)v->version;
        proto_frame_header_pack(&h, v->cur_header);
        pthread_mutex_lock(&ws->stats_mu);
        if (v->last_sent_id && f->info.frame_id > v->last_sent_id + 1)
            ws->stats.frames_skipped += f->info.frame_id - v->last_sent_id - 1;
        pthread_mutex_unlock(&ws->stats_mu);
    }
    size_t total = PROTO_STREAM_HEADER_SIZE + v->cur_jpeg->size;
    size_t chunk = total - v->cur_pos < FRAGMENT_BYTES ? total - v->cur_pos : FRAGMENT_BYTES;
    uint8_t *out = v->tx + LWS_PRE;
    size_t filled = 0;
    if (v->cur_pos < PROTO_STREAM_HEADER_SIZE) {
        filled = PROTO_STREAM_HEADER_SIZE - v->cur_pos;
        memcpy(out, v->cur_header + v->cur_pos, filled);
    }
    size_t jpeg_off = v->cur_pos + filled - PROTO_STREAM_HEADER_SIZE;
    memcpy(out + filled, v->cur_jpeg->data + jpeg_off, chunk - filled);
    bool first = v->cur_pos == 0, last = v->cur_pos + chunk == total;
    int mode = first ? LWS_WRITE_BINARY : LWS_WRITE_CONTINUATION;
    if (!last) mode |= LWS_WRITE_NO_FIN;
    int n = lws_write(v->wsi, out, chunk, (enum lws_write_protocol)mode);
    if (n < (int)chunk) return -1;
    v->cur_pos += chunk;
    pthread_mutex_lock(&ws->stats_mu);
    ws->stats.bytes_sent += chunk;
    if (last) ws->stats.frames_sent++;
    pthread_mutex_unlock(&ws->stats_mu);
    if (last) {
        v->last_sent_id = v->cur->info.frame_id;
        v->sent[v->sent_head].id = v->last_sent_id;
        v->sent[v->sent_head].ms = now;
        v->sent_head = (v->sent_head + 1) % SENT_RING;
        srv_frame_unref(v->cur);
        v->cur = NULL;
    }
    if (v->cur || has_new_frame(ws, v)) lws_callback_on_writable(v->wsi);
    return 0;
}

/* ---- viewer messages ---------------------------------------------------------------------- */

static void handle_message(srv_ws_stream *ws, viewer *v)
{
    srv_viewer_msg m;
    srv_api_error e;
    pthread_mutex_lock(&ws->stats_mu);
    ws->stats.messages_received++;
    pthread_mutex_unlock(&ws->stats_mu);
    if (!srv_json_viewer_msg(v->rx, v->rx_len, &m, &e)) {
        srv_info("stream", "viewer %u (%s) sent an invalid message: %s", v->id, v->ip, e.message);
        close_viewer(v, LWS_CLOSE_STATUS_POLICY_VIOLATION, "invalid message");
        return;
    }
    switch (m.type) {
    case SRV_VIEWER_CAMERA: {
        srv_cmd *c = srv_cmd_new(SRV_CMD_VIEWER_CAMERA);
        c->view = v->own_view;
        c->camera = m.camera;
        uint64_t ticket = srv_render_post(ws->cfg.loop, c);
        if (!ticket) {
            srv_debug("stream", "viewer %u: input dropped (render queue full)", v->id);
            break;
        }
        if (v->input_count == INPUT_RING) {
            v->evicted_seq = v->inputs[v->input_head].seq; /* the oldest is overwritten */
            v->input_count--;
        }
        v->inputs[v->input_head].ticket = ticket;
        v->inputs[v->input_head].seq = m.seq;
        v->input_head = (v->input_head + 1) % INPUT_RING;
        v->input_count++;
        break;
    }
    case SRV_VIEWER_RESIZE: {
        srv_cmd *c = srv_cmd_new(SRV_CMD_VIEWER_RESIZE);
        c->view = v->own_view;
        c->width = (unsigned)lroundf(m.width * m.dpr);
        c->height = (unsigned)lroundf(m.height * m.dpr);
        srv_render_post(ws->cfg.loop, c);
        break;
    }
    case SRV_VIEWER_FOLLOW: {
        if (v->version < 2) {
            close_viewer(v, LWS_CLOSE_STATUS_POLICY_VIOLATION, "follow needs probecast.v2");
            break;
        }
        uint32_t target = m.follow_own ? v->own_view : m.view;
        srv_view_info info;
        if (target != v->own_view && !srv_snapshot_view(ws->cfg.snapshot, target, &info)) {
            queue_textf(v, "{\"type\":\"error\",\"message\":\"There is no view with id %u.\"}",
                        target);
            break;
        }
        watch(ws, v, target);
        break;
    }
    case SRV_VIEWER_ACK: {
        double now = srv_mono_ms();
        for (unsigned i = 0; i < SENT_RING; i++) {
            if (v->sent[i].id != m.frame || m.frame == 0) continue;
            double lag = now - v->sent[i].ms;
            v->lag_ms = v->acked_any ? 0.7 * v->lag_ms + 0.3 * lag : lag;
            v->acked_any = true;
            v->last_ack_ms = now;
            if (m.frame > v->acked_id) v->acked_id = m.frame;
            unsigned cap = cap_from_lag(v->lag_ms);
            if (cap != v->cap) {
                v->cap = cap;
                update_caps(ws);
            }
            break;
        }
        if (!v->cur) lws_callback_on_writable(v->wsi); /* the window may have opened */
        break;
    }
    }
}

/* ---- the lws callback --------------------------------------------------------------------- */

static void set_viewer_count(srv_ws_stream *ws)
{
    srv_render_set_viewers(ws->cfg.loop, ws->viewer_count);
    pthread_mutex_lock(&ws->stats_mu);
    ws->stats.viewers = ws->viewer_count;
    pthread_mutex_unlock(&ws->stats_mu);
}

static int callback(struct lws *wsi, enum lws_callback_reasons reason, void *user, void *in,
                    size_t len)
{
    struct lws_context *ctx = lws_get_context(wsi);
    srv_ws_stream *ws = ctx ? lws_context_user(ctx) : NULL;
    viewer *v = user;
    if (!ws) return 0;
    switch (reason) {
    case LWS_CALLBACK_HTTP:
        /* plain HTTP on the stream port: nothing here */
        if (lws_return_http_status(wsi, HTTP_STATUS_NOT_FOUND,
                                   "Not found: the stream is at /v1/stream"))
            return -1;
        return lws_http_transaction_completed(wsi) ? -1 : 0;

    case LWS_CALLBACK_HTTP_CONFIRM_UPGRADE: {
        /* every check before the upgrade, so a refusal is a proper HTTP answer (401, 403) */
        const char *why = handshake_refusal(ws, wsi);
        if (!why) return 0;
        char ip[64] = "";
        lws_get_peer_simple(wsi, ip, sizeof ip);
        srv_info("stream", "refused a viewer from %s: %s", ip, why);
        pthread_mutex_lock(&ws->stats_mu);
        ws->stats.connections_rejected++;
        pthread_mutex_unlock(&ws->stats_mu);
        if (lws_return_http_status(
                wsi, strstr(why, "token") ? HTTP_STATUS_UNAUTHORIZED : HTTP_STATUS_FORBIDDEN, why))
            return -1;
        return 1;
    }

    case LWS_CALLBACK_ESTABLISHED: {
        memset(v, 0, sizeof *v);
        v->wsi = wsi;
        v->id = ++ws->next_viewer_id;
        v->cap = 100;
        lws_get_peer_simple(wsi, v->ip, sizeof v->ip);
        v->version = offers_v2(wsi) ? 2 : 1;
        if (v->version == 2) {
            /* its own view, opened by the render thread; it watches it from the start */
            v->own_view = v->watching = srv_render_new_view_id(ws->cfg.loop);
            srv_cmd *c = srv_cmd_new(SRV_CMD_VIEW_OPEN);
            c->view = v->own_view;
            srv_render_post(ws->cfg.loop, c);
            ws->v2_count++;
            v->seen_node = srv_snapshot_node_version(ws->cfg.snapshot);
            const srv_settings_view_size sz = default_size(ws);
            queue_textf(v, "{\"type\":\"welcome\",\"protocol\":2,\"view\":%u,\"width\":%u,"
                           "\"height\":%u}",
                        v->own_view, sz.width, sz.height);
        } else {
            srv_cmd *c = srv_cmd_new(SRV_CMD_VIEW_WATCH);
            c->view = SRV_DEFAULT_VIEW;
            c->delta = 1;
            srv_render_post(ws->cfg.loop, c);
        }
        v->tx = malloc(LWS_PRE + FRAGMENT_BYTES);
        if (!v->tx) abort();
        v->next = ws->viewers;
        if (ws->viewers) ws->viewers->prev = v;
        ws->viewers = v;
        ws->viewer_count++;
        set_viewer_count(ws);
        srv_info("stream", "viewer %u connected from %s (%u watching)", v->id, v->ip,
                 ws->viewer_count);
        lws_callback_on_writable(wsi); /* the current frame right away */
        return 0;
    }

    case LWS_CALLBACK_CLOSED:
        if (!v->wsi) return 0;
        if (v->prev)
            v->prev->next = v->next;
        else
            ws->viewers = v->next;
        if (v->next) v->next->prev = v->prev;
        ws->viewer_count--;
        {
            srv_cmd *c = srv_cmd_new(SRV_CMD_VIEW_WATCH);
            c->view = v->watching;
            c->delta = -1;
            srv_render_post(ws->cfg.loop, c);
            if (v->version == 2) {
                ws->v2_count--;
                v->watching = v->own_view; /* its followers are released below */
                release_followers(ws, v->own_view);
                c = srv_cmd_new(SRV_CMD_VIEW_CLOSE);
                c->view = v->own_view;
                srv_render_post(ws->cfg.loop, c);
            }
            while (v->text_count) {
                free(v->texts[v->text_head]);
                v->text_head = (v->text_head + 1) % TEXT_QUEUE;
                v->text_count--;
            }
        }
        srv_frame_unref(v->cur);
        v->cur = NULL;
        free(v->tx);
        v->tx = NULL;
        v->wsi = NULL;
        set_viewer_count(ws);
        update_caps(ws);
        srv_info("stream", "viewer %u disconnected (%u watching)", v->id, ws->viewer_count);
        return 0;

    case LWS_CALLBACK_RECEIVE: {
        double now = srv_mono_ms();
        if (now - v->rate_window_ms >= 1000) v->rate_window_ms = now, v->rate_count = 0;
        if (lws_frame_is_binary(wsi)) {
            close_viewer(v, LWS_CLOSE_STATUS_UNACCEPTABLE_OPCODE, "text messages only");
        } else if (v->rx_len + len > SRV_VIEWER_MSG_MAX) {
            close_viewer(v, LWS_CLOSE_STATUS_MESSAGE_TOO_LARGE, "message too large");
        } else {
            memcpy(v->rx + v->rx_len, in, len);
            v->rx_len += len;
            if (lws_is_final_fragment(wsi) && lws_remaining_packet_payload(wsi) == 0) {
                if (++v->rate_count > RATE_LIMIT_PER_S)
                    close_viewer(v, LWS_CLOSE_STATUS_POLICY_VIOLATION, "too many messages");
                else
                    handle_message(ws, v);
                v->rx_len = 0;
            }
        }
        if (v->close_code) {
            pthread_mutex_lock(&ws->stats_mu);
            ws->stats.connections_closed_for_abuse++;
            pthread_mutex_unlock(&ws->stats_mu);
        }
        return 0;
    }

    case LWS_CALLBACK_SERVER_WRITEABLE:
        if (v->close_code) {
            lws_close_reason(wsi, (enum lws_close_status)v->close_code,
                             (unsigned char *)v->close_reason, strlen(v->close_reason));
            return -1;
        }
        return send_some(ws, v);

    case LWS_CALLBACK_EVENT_WAIT_CANCELLED:
        if (atomic_load(&ws->stopping)) {
            for (viewer *x = ws->viewers; x; x = x->next)
                close_viewer(x, LWS_CLOSE_STATUS_GOINGAWAY, "server stopping");
        } else {
            bool frames = atomic_exchange(&ws->frame_pending, false);
            bool events = atomic_exchange(&ws->event_pending, false);
            for (viewer *x = ws->viewers; x; x = x->next)
                if (!x->cur && (frames || (events && has_news(ws, x))))
                    lws_callback_on_writable(x->wsi);
        }
        return 0;

    default:
        return 0;
    }
}

/* Once a second: bandwidth, stalled ack windows. */
static void on_tick(lws_sorted_usec_list_t *sul)
{
    srv_ws_stream *ws = lws_container_of(sul, srv_ws_stream, tick);
    double now = srv_mono_ms();
    pthread_mutex_lock(&ws->stats_mu);
    double dt = (now - ws->tick_ms) / 1000.0;
    if (dt > 0)
        ws->stats.bandwidth_bps = (double)(ws->stats.bytes_sent - ws->bytes_at_tick) * 8 / dt;
    ws->bytes_at_tick = ws->stats.bytes_sent;
    pthread_mutex_unlock(&ws->stats_mu);
    ws->tick_ms = now;
    for (viewer *v = ws->viewers; v; v = v->next)
        if (!v->cur && v->acked_any && now - v->last_ack_ms >= ACK_STALL_MS)
            lws_callback_on_writable(v->wsi);
    lws_sul_schedule(ws->ctx, 0, &ws->tick, on_tick, LWS_US_PER_SEC);
}

static void *service_main(void *arg)
{
    srv_ws_stream *ws = arg;
    while (!ws->exit_loop) {
        lws_service(ws->ctx, 0);
        if (atomic_load(&ws->stopping) &&
            (ws->viewer_count == 0 || srv_mono_ms() > ws->stop_deadline_ms))
            ws->exit_loop = true;
    }
    return NULL;
}

static void lws_log(int level, const char *line)
{
    char buf[512];
    snprintf(buf, sizeof buf, "%s", line);
    size_t n = strlen(buf);
    while (n > 0 && (buf[n - 1] == '\n' || buf[n - 1] == '\r'))
        buf[--n] = 0;
    srv_log(level == LLL_ERR ? SRV_LOG_ERROR : SRV_LOG_WARN, "lws", "%s", buf);
}

srv_ws_stream *srv_ws_create(const srv_ws_config *cfg, char *err, size_t errlen)
{
    srv_ws_stream *ws = calloc(1, sizeof *ws);
    if (!ws) abort();
    ws->cfg = *cfg;
    if (!ws->cfg.max_viewers) ws->cfg.max_viewers = 100;
    if (!ws->cfg.max_per_ip) ws->cfg.max_per_ip = 64;
    snprintf(ws->token, sizeof ws->token, "%s", cfg->token ? cfg->token : "");
    snprintf(ws->http_host, sizeof ws->http_host, "%s",
             cfg->http_host ? cfg->http_host : "127.0.0.1");
    pthread_mutex_init(&ws->stats_mu, NULL);
    /* the first is what clients offering no subprotocol get; offers_v2 decides the version */
    ws->protocols[0] = (struct lws_protocols){
        .name = "probecast.v1",
        .callback = callback,
        .per_session_data_size = sizeof(viewer),
        .rx_buffer_size = SRV_VIEWER_MSG_MAX,
    };
    ws->protocols[1] = ws->protocols[0];
    ws->protocols[1].name = "probecast.v2";
    ws->retry = (lws_retry_bo_t){.secs_since_valid_ping = 20, .secs_since_valid_hangup = 40};
    lws_set_log_level(LLL_ERR | LLL_WARN, lws_log);

    struct lws_context_creation_info info;
    memset(&info, 0, sizeof info);
    info.options = LWS_SERVER_OPTION_EXPLICIT_VHOSTS | LWS_SERVER_OPTION_VALIDATE_UTF8;
    info.user = ws;
    info.count_threads = 1;
    info.fd_limit_per_thread = ws->cfg.max_viewers + 32;
    info.timeout_secs = 10;
    ws->ctx = lws_create_context(&info);
    if (!ws->ctx) {
        snprintf(err, errlen, "cannot create the WebSocket context");
        srv_ws_destroy(ws);
        return NULL;
    }
    info.port = (int)cfg->port;
    info.iface = cfg->address;
    info.protocols = ws->protocols;
    info.vhost_name = "probecast";
    info.retry_and_idle_policy = &ws->retry;
    ws->vhost = lws_create_vhost(ws->ctx, &info);
    if (!ws->vhost) {
        snprintf(err, errlen,
                 "cannot listen for the stream on %s:%u (in use, or not a local address?)",
                 cfg->address, cfg->port);
        srv_ws_destroy(ws);
        return NULL;
    }
    return ws;
}

unsigned srv_ws_port(const srv_ws_stream *ws)
{
    return (unsigned)lws_get_vhost_listen_port(ws->vhost);
}

void srv_ws_set_http_port(srv_ws_stream *ws, unsigned port)
{
    ws->cfg.http_port = port;
}

bool srv_ws_start(srv_ws_stream *ws)
{
    ws->tick_ms = srv_mono_ms();
    lws_sul_schedule(ws->ctx, 0, &ws->tick, on_tick, LWS_US_PER_SEC);
    if (pthread_create(&ws->thread, NULL, service_main, ws) != 0) return false;
    ws->started = true;
    return true;
}

void srv_ws_destroy(srv_ws_stream *ws)
{
    if (!ws) return;
    if (ws->started) {
        ws->stop_deadline_ms = srv_mono_ms() + STOP_GRACE_MS;
        atomic_store(&ws->stopping, true);
        lws_cancel_service(ws->ctx);
        pthread_join(ws->thread, NULL);
        ws->started = false;
    }
    if (ws->ctx) lws_context_destroy(ws->ctx); /* closes what is left (CLOSED frees viewers) */
    ws->ctx = NULL;
    pthread_mutex_destroy(&ws->stats_mu);
    free(ws);
}

void srv_ws_frame_ready(void *arg)
{
    srv_ws_stream *ws = arg;
    atomic_store(&ws->frame_pending, true);
    lws_cancel_service(ws->ctx);
}

void srv_ws_event_ready(void *arg)
{
    srv_ws_stream *ws = arg;
    atomic_store(&ws->event_pending, true);
    lws_cancel_service(ws->ctx);
}

void srv_ws_get_stats(srv_ws_stream *ws, srv_ws_stats *out)
{
    pthread_mutex_lock(&ws->stats_mu);
    *out = ws->stats;
    pthread_mutex_unlock(&ws->stats_mu);
}
