/* ws_stream.c: the frame stream on libwebsockets (one service thread): connections, flow control
 * and sending frames; handshake checks are in ws_handshake.c, text messages in ws_messages.c. */
#include "server/stream/ws_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>
#include <unistd.h>

#include "server/api/access.h"
#include "server/base/clock.h"
#include "server/base/log.h"

/* Takes the connections srv_ws_adopt queued onto the bridge vhost (service thread). */
static void adopt_pending(srv_ws_stream *ws)
{
    pthread_mutex_lock(&ws->adopt_mu);
    srv_ws_adoption *a = ws->adopt_head;
    ws->adopt_head = NULL;
    pthread_mutex_unlock(&ws->adopt_mu);
    while (a) {
        srv_ws_adoption *next = a->next;
        if (atomic_load(&ws->stopping)) {
            close(a->fd);
            free(a);
        } else {
            /* plain HTTP on the pair whatever the listening vhost's TLS: the API did the TLS */
            lws_adopt_desc_t d = {.vh = ws->bridge,
                                  .type = LWS_ADOPT_SOCKET | LWS_ADOPT_HTTP,
                                  .fd = {.sockfd = a->fd},
                                  .opaque = a->ip};
            /* the wsi owns a (its ip string) from here; freed at LWS_CALLBACK_WSI_DESTROY.
             * On failure lws has closed the socket. */
            if (!lws_adopt_descriptor_vhost_via_info(&d)) {
                srv_warn("stream", "could not take over a connection from %s", a->ip);
                free(a);
            }
        }
        a = next;
    }
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

/* ---- quality and flow --------------------------------------------------------------------- */

/* Guacamole's rule: quality = 90 - (lag_ms - 20), clamped to [30, 90]; 90 means no cap. */
unsigned srv_ws_cap_from_lag(double lag_ms)
{
    double q = 90 - (lag_ms - 20);
    if (q >= 90) return 100;
    if (q < SRV_CAP_MIN) q = SRV_CAP_MIN;
    return (unsigned)(q / 10) * 10;
}

void srv_ws_update_caps(srv_ws_stream *ws)
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

/* The newest of the viewer's inputs that a frame of view with input ticket reflects: its ring
 * slot, or -1 (another view's frame, or only evicted inputs). */
static int input_for(const viewer *v, uint32_t view, uint64_t ticket)
{
    if (view != v->own_view) return -1; /* its camera messages go to its own view only */
    for (unsigned i = 0; i < v->input_count; i++) {
        unsigned k = (v->input_head + INPUT_RING - 1 - i) % INPUT_RING;
        if (v->inputs[k].ticket <= ticket) return (int)k;
    }
    return -1;
}

static uint32_t seq_for(const viewer *v, uint32_t view, uint64_t ticket)
{
    int k = input_for(v, view, ticket);
    return k >= 0 ? v->inputs[k].seq : view == v->own_view ? v->evicted_seq : 0;
}

/* Whether a newer frame than the viewer's last one is published. */
static bool has_new_frame(srv_ws_stream *ws, const viewer *v)
{
    if (v->video) return true; /* a packet may be ready (a spurious wake sends nothing) */
    srv_frame *f = srv_encoder_latest(ws->cfg.encoders, v->watching);
    bool fresh = f && f->info.frame_id > v->last_sent_id && f->variant_count > 0;
    srv_frame_unref(f);
    return fresh;
}

void srv_ws_close_viewer(viewer *v, int code, const char *reason)
{
    if (v->close_code) return;
    v->close_code = code;
    snprintf(v->close_reason, sizeof v->close_reason, "%s", reason);
    lws_callback_on_writable(v->wsi);
}

/* Sends the next fragment of the viewer's frame, starting the newest frame when idle (text
 * messages go first, between frames). Returns -1 when the connection must close. */
static int send_some(srv_ws_stream *ws, viewer *v)
{
    double now = srv_mono_ms();
    if (!v->cur) {
        char *text = srv_ws_next_text(ws, v);
        if (text) return srv_ws_send_text(ws, v, text);
        if (flow_blocked(v, now)) return 0;
        srv_video_out *o;
        srv_frame *f;
        srv_ws_video_next(ws, v, &o, &f);
        if (!o && !f) return 0;
        proto_frame_header h = {.send_us = srv_unix_us(), .version = (uint16_t)v->version};
        if (o) {
            f = srv_frame_ref(o->frame);
            v->cur_video = o;
            v->encode_ms =
                v->encode_ms > 0 ? 0.8 * v->encode_ms + 0.2 * o->encode_ms : o->encode_ms;
            v->cur_data = o->data;
            v->cur_size = o->size;
            h.encode_us = o->encode_us;
            h.format = (uint8_t)v->format;
            h.flags = o->key ? PROTO_STREAM_FLAG_KEY : 0;
        } else {
            const srv_jpeg *jpeg = srv_frame_pick(f, v->cap);
            v->cur_data = jpeg->data;
            v->cur_size = jpeg->size;
            h.encode_us = f->encode_us;
            h.quality = (uint8_t)jpeg->quality;
            h.flags = f->info.still ? PROTO_STREAM_FLAG_STILL : 0;
        }
        v->cur = f;
        v->cur_pos = 0;
        h.frame_id = f->info.frame_id;
        h.capture_us = f->info.capture_us;
        h.view_id = f->info.view_id;
        h.width = f->width;
        h.height = f->height;
        h.input_seq = seq_for(v, f->info.view_id, f->info.input_ticket);
        h.jpeg_size = (uint32_t)v->cur_size;
        proto_frame_header_pack(&h, v->cur_header);
        /* the first frame to reflect a new input gives a latency sample when fully sent */
        int k = input_for(v, f->info.view_id, f->info.input_ticket);
        v->cur_input_us = 0;
        if (k >= 0 && v->inputs[k].seq != v->timed_seq) {
            v->timed_seq = v->inputs[k].seq;
            v->cur_input_us = v->inputs[k].received_us;
            v->cur_send_us = h.send_us;
        }
        pthread_mutex_lock(&ws->stats_mu);
        if (v->last_sent_id && f->info.frame_id > v->last_sent_id + 1)
            ws->stats.frames_skipped += f->info.frame_id - v->last_sent_id - 1;
        pthread_mutex_unlock(&ws->stats_mu);
    }
    size_t total = PROTO_STREAM_HEADER_SIZE + v->cur_size;
    size_t chunk = total - v->cur_pos < FRAGMENT_BYTES ? total - v->cur_pos : FRAGMENT_BYTES;
    uint8_t *out = v->tx + LWS_PRE;
    size_t filled = 0;
    if (v->cur_pos < PROTO_STREAM_HEADER_SIZE) {
        filled = PROTO_STREAM_HEADER_SIZE - v->cur_pos;
        memcpy(out, v->cur_header + v->cur_pos, filled);
    }
    size_t jpeg_off = v->cur_pos + filled - PROTO_STREAM_HEADER_SIZE;
    memcpy(out + filled, v->cur_data + jpeg_off, chunk - filled);
    bool first = v->cur_pos == 0, last = v->cur_pos + chunk == total;
    int mode = first ? LWS_WRITE_BINARY : LWS_WRITE_CONTINUATION;
    if (!last) mode |= LWS_WRITE_NO_FIN;
    int n = lws_write(v->wsi, out, chunk, (enum lws_write_protocol)mode);
    if (n < (int)chunk) return -1;
    v->cur_pos += chunk;
    pthread_mutex_lock(&ws->stats_mu);
    ws->stats.bytes_sent += chunk;
    if (last) ws->stats.frames_sent++;
    if (last && v->cur_input_us) {
        srv_latency_stamps st = {
            .input_us = v->cur_input_us,
            .capture_us = v->cur->info.capture_us,
            .ready_us = v->cur->info.ready_us,
            .encode_us = v->cur_video ? v->cur_video->encode_us : v->cur->encode_us,
            .send_us = v->cur_send_us,
            .done_us = srv_unix_us(),
        };
        srv_latency_add(&ws->latency, &st);
    }
    pthread_mutex_unlock(&ws->stats_mu);
    if (last) {
        v->last_sent_id = v->cur->info.frame_id;
        v->sent[v->sent_head].id = v->last_sent_id;
        v->sent[v->sent_head].ms = now;
        v->sent[v->sent_head].bytes = v->cur_size;
        v->sent_bytes += v->cur_size;
        v->sent_head = (v->sent_head + 1) % SENT_RING;
        srv_frame_unref(v->cur);
        v->cur = NULL;
        srv_video_out_free(v->cur_video);
        v->cur_video = NULL;
    }
    if (v->cur || has_new_frame(ws, v)) lws_callback_on_writable(v->wsi);
    return 0;
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
        const char *why = srv_ws_handshake_refusal(ws, wsi);
        if (!why) return 0;
        char ip[64] = "";
        srv_ws_peer_ip(wsi, ip, sizeof ip);
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
        srv_ws_peer_ip(wsi, v->ip, sizeof v->ip);
        v->version = srv_ws_offers_v2(wsi) ? 2 : 1;
        if (v->version == 2) {
            /* its own view, opened by the render thread; it watches it from the start */
            v->own_view = v->watching = srv_render_new_view_id(ws->cfg.loop);
            srv_cmd *c = srv_cmd_new(SRV_CMD_VIEW_OPEN);
            c->view = v->own_view;
            srv_render_post(ws->cfg.loop, c);
            ws->v2_count++;
            v->seen_node = srv_snapshot_node_version(ws->cfg.snapshot);
            const srv_settings_view_size sz = default_size(ws);
            srv_ws_queue_textf(v,
                               "{\"type\":\"welcome\",\"protocol\":2,\"view\":%u,\"width\":%u,"
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
                srv_ws_release_followers(ws, v->own_view);
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
        srv_video_out_free(v->cur_video);
        v->cur_video = NULL;
        srv_ws_video_stop(ws, v);
        free(v->tx);
        v->tx = NULL;
        v->wsi = NULL;
        set_viewer_count(ws);
        srv_ws_update_caps(ws);
        srv_info("stream", "viewer %u disconnected (%u watching)", v->id, ws->viewer_count);
        return 0;

    case LWS_CALLBACK_RECEIVE: {
        double now = srv_mono_ms();
        if (now - v->rate_window_ms >= 1000) v->rate_window_ms = now, v->rate_count = 0;
        if (lws_frame_is_binary(wsi)) {
            srv_ws_close_viewer(v, LWS_CLOSE_STATUS_UNACCEPTABLE_OPCODE, "text messages only");
        } else if (v->rx_len + len > SRV_VIEWER_MSG_MAX) {
            srv_ws_close_viewer(v, LWS_CLOSE_STATUS_MESSAGE_TOO_LARGE, "message too large");
        } else {
            memcpy(v->rx + v->rx_len, in, len);
            v->rx_len += len;
            if (lws_is_final_fragment(wsi) && lws_remaining_packet_payload(wsi) == 0) {
                if (++v->rate_count > RATE_LIMIT_PER_S)
                    srv_ws_close_viewer(v, LWS_CLOSE_STATUS_POLICY_VIOLATION, "too many messages");
                else
                    srv_ws_handle_message(ws, v);
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

    case LWS_CALLBACK_WSI_DESTROY: {
        /* an adopted connection's record (ip is its first member) */
        srv_ws_adoption *a = lws_get_opaque_user_data(wsi);
        lws_set_opaque_user_data(wsi, NULL);
        free(a);
        return 0;
    }

    case LWS_CALLBACK_EVENT_WAIT_CANCELLED:
        adopt_pending(ws);
        if (atomic_load(&ws->stopping)) {
            for (viewer *x = ws->viewers; x; x = x->next)
                srv_ws_close_viewer(x, LWS_CLOSE_STATUS_GOINGAWAY, "server stopping");
        } else {
            bool frames = atomic_exchange(&ws->frame_pending, false);
            bool events = atomic_exchange(&ws->event_pending, false);
            for (viewer *x = ws->viewers; x; x = x->next)
                if (!x->cur && (frames || (events && srv_ws_has_news(ws, x))))
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
    srv_ws_video_tick(ws, dt);
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

/* While srv_ws_create sets up the vhost on this thread: where lws's first error goes, so that a
 * failure can say what lws said. */
static _Thread_local char *start_error;
static _Thread_local size_t start_error_len;

static void lws_log(int level, const char *line)
{
    char buf[512];
    snprintf(buf, sizeof buf, "%s", line);
    size_t n = strlen(buf);
    while (n > 0 && (buf[n - 1] == '\n' || buf[n - 1] == '\r'))
        buf[--n] = 0;
    if (level == LLL_ERR && start_error && !start_error[0])
        snprintf(start_error, start_error_len, "%s", buf);
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
    pthread_mutex_init(&ws->adopt_mu, NULL);
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
    bool tls = cfg->tls_cert_path && cfg->tls_key_path;
    info.options = LWS_SERVER_OPTION_EXPLICIT_VHOSTS | LWS_SERVER_OPTION_VALIDATE_UTF8;
    if (tls) info.options |= LWS_SERVER_OPTION_DO_SSL_GLOBAL_INIT;
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
    info.protocols = ws->protocols;
    info.retry_and_idle_policy = &ws->retry;
    /* connections the HTTP API hands over (GET /v1/stream on its own address, srv_ws_adopt):
     * plain HTTP over a socket pair, whatever TLS the API speaks to its client */
    info.port = CONTEXT_PORT_NO_LISTEN_SERVER;
    info.vhost_name = "api";
    ws->bridge = lws_create_vhost(ws->ctx, &info);
    if (!ws->bridge) {
        snprintf(err, errlen, "cannot set up the stream's connections from the HTTP API");
        srv_ws_destroy(ws);
        return NULL;
    }
    if (!cfg->address) return ws; /* no --ws: the stream is reached through the API only */
    info.port = (int)cfg->port;
    info.iface = cfg->address;
    info.vhost_name = "probecast";
    if (tls) {
#if defined(LWS_WITH_TLS)
        /* wss:// only (no plain connections on this port); the chain is read from the file */
        info.ssl_cert_filepath = cfg->tls_cert_path;
        info.ssl_private_key_filepath = cfg->tls_key_path;
        info.ssl_options_set = SSL_OP_NO_TLSv1 | SSL_OP_NO_TLSv1_1;
#else
        snprintf(err, errlen,
                 "this libwebsockets was built without TLS, so it cannot serve wss://");
        srv_ws_destroy(ws);
        return NULL;
#endif
    }
    char lws_said[256] = "";
    start_error = lws_said;
    start_error_len = sizeof lws_said;
    ws->vhost = lws_create_vhost(ws->ctx, &info);
    start_error = NULL;
    if (!ws->vhost) {
        if (tls && lws_said[0])
            snprintf(err, errlen, "cannot serve the stream over TLS on %s:%u: %s", cfg->address,
                     cfg->port, lws_said);
        else
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
    return ws->vhost ? (unsigned)lws_get_vhost_listen_port(ws->vhost) : 0;
}

bool srv_ws_adopt(srv_ws_stream *ws, int fd, const char *peer_ip)
{
    if (atomic_load(&ws->stopping)) return false;
    srv_ws_adoption *a = calloc(1, sizeof *a);
    if (!a) abort();
    a->fd = fd;
    snprintf(a->ip, sizeof a->ip, "%s", peer_ip ? peer_ip : "");
    pthread_mutex_lock(&ws->adopt_mu);
    a->next = ws->adopt_head;
    ws->adopt_head = a;
    pthread_mutex_unlock(&ws->adopt_mu);
    lws_cancel_service(ws->ctx);
    return true;
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
    for (srv_ws_adoption *a = ws->adopt_head, *next; a; a = next) {
        next = a->next;
        close(a->fd);
        free(a);
    }
    pthread_mutex_destroy(&ws->adopt_mu);
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
    srv_latency_summarise(&ws->latency, &out->latency);
    pthread_mutex_unlock(&ws->stats_mu);
}
