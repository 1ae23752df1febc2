/* ws_messages.c: the stream's text messages (protocol/stream.md): what viewers say (camera,
 * resize, follow, quality, ack) and what they are told (welcome, following, error, events). */
#include "server/stream/ws_internal.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "server/base/clock.h"
#include "server/base/log.h"

/* ---- server text messages (version 2) ------------------------------------------------------ */

/* Queues a text message (taken); a viewer that lets TEXT_QUEUE pile up is too slow to keep. */
void srv_ws_queue_text(viewer *v, char *text)
{
    if (v->version < 2) {
        free(text);
        return;
    }
    if (v->text_count == TEXT_QUEUE) {
        free(text);
        srv_ws_close_viewer(v, LWS_CLOSE_STATUS_POLICY_VIOLATION, "not reading messages");
        return;
    }
    v->texts[(v->text_head + v->text_count++) % TEXT_QUEUE] = text;
    lws_callback_on_writable(v->wsi);
}

void srv_ws_queue_textf(viewer *v, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    char *text = NULL;
    if (vasprintf(&text, fmt, ap) < 0) abort();
    va_end(ap);
    srv_ws_queue_text(v, text);
}

static char *event_text(const char *what, const char *doc)
{
    char *text = NULL;
    if (asprintf(&text, "{\"type\":\"event\",\"what\":\"%s\",\"data\":%s}", what, doc) < 0) abort();
    return text;
}

/* The next text message for v (malloc'd), or NULL: the queue first, then each kind of event
 * whose document changed since v saw it (only the newest document of a kind is sent). */
char *srv_ws_next_text(srv_ws_stream *ws, viewer *v)
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

bool srv_ws_has_news(srv_ws_stream *ws, const viewer *v)
{
    if (v->version < 2) return false;
    if (v->text_count) return true;
    for (int k = 0; k < SRV_DOC_COUNT; k++)
        if (srv_snapshot_version(ws->cfg.snapshot, (srv_doc)k) > v->seen[k]) return true;
    return srv_snapshot_node_version(ws->cfg.snapshot) > v->seen_node;
}

/* Sends one text message; -1 when the connection must close. */
int srv_ws_send_text(srv_ws_stream *ws, viewer *v, char *text)
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
void srv_ws_watch(srv_ws_stream *ws, viewer *v, uint32_t view)
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
    v->video_queued_id = 0;
    if (v->video) srv_video_stream_force_key(v->video); /* another picture: start it clean */
    srv_ws_video_count(ws, v);
    srv_ws_queue_textf(v, "{\"type\":\"following\",\"view\":%u}", view);
    lws_callback_on_writable(v->wsi);
}

/* Connections that follow a view whose owner left go back to their own view. */
void srv_ws_release_followers(srv_ws_stream *ws, uint32_t view)
{
    for (viewer *x = ws->viewers; x; x = x->next)
        if (x->watching == view && x->own_view != view) srv_ws_watch(ws, x, x->own_view);
}

/* ---- viewer messages ---------------------------------------------------------------------- */

/* Posts a viewer's command to the render loop; a full queue drops it (a flood of messages
 * outruns the renderer: the newest input wins anyway), counted in inputs_dropped. Returns the
 * ticket, 0 when dropped. */
static uint64_t post_input(srv_ws_stream *ws, viewer *v, srv_cmd *c)
{
    uint64_t ticket = srv_render_post(ws->cfg.loop, c);
    if (!ticket) {
        srv_debug("stream", "viewer %u: input dropped (render queue full)", v->id);
        pthread_mutex_lock(&ws->stats_mu);
        ws->stats.inputs_dropped++;
        pthread_mutex_unlock(&ws->stats_mu);
    }
    return ticket;
}

void srv_ws_handle_message(srv_ws_stream *ws, viewer *v)
{
    srv_viewer_msg m;
    srv_api_error e;
    pthread_mutex_lock(&ws->stats_mu);
    ws->stats.messages_received++;
    pthread_mutex_unlock(&ws->stats_mu);
    if (!srv_json_viewer_msg(v->rx, v->rx_len, &m, &e)) {
        srv_info("stream", "viewer %u (%s) sent an invalid message: %s", v->id, v->ip, e.message);
        srv_ws_close_viewer(v, LWS_CLOSE_STATUS_POLICY_VIOLATION, "invalid message");
        return;
    }
    switch (m.type) {
    case SRV_VIEWER_CAMERA: {
        srv_cmd *c = srv_cmd_new(SRV_CMD_VIEWER_CAMERA);
        c->view = v->own_view;
        c->camera = m.camera;
        uint64_t ticket = post_input(ws, v, c);
        if (!ticket) break;
        if (v->input_count == INPUT_RING) {
            v->evicted_seq = v->inputs[v->input_head].seq; /* the oldest is overwritten */
            v->input_count--;
        }
        v->inputs[v->input_head].ticket = ticket;
        v->inputs[v->input_head].seq = m.seq;
        v->inputs[v->input_head].received_us = srv_unix_us();
        v->input_head = (v->input_head + 1) % INPUT_RING;
        v->input_count++;
        break;
    }
    case SRV_VIEWER_RESIZE: {
        srv_cmd *c = srv_cmd_new(SRV_CMD_VIEWER_RESIZE);
        c->view = v->own_view;
        c->width = (unsigned)lroundf(m.width * m.dpr);
        c->height = (unsigned)lroundf(m.height * m.dpr);
        post_input(ws, v, c);
        break;
    }
    case SRV_VIEWER_FOLLOW: {
        if (v->version < 2) {
            srv_ws_close_viewer(v, LWS_CLOSE_STATUS_POLICY_VIOLATION, "follow needs probecast.v2");
            break;
        }
        uint32_t target = m.follow_own ? v->own_view : m.view;
        srv_view_info info;
        if (target != v->own_view && !srv_snapshot_view(ws->cfg.snapshot, target, &info)) {
            srv_ws_queue_textf(
                v, "{\"type\":\"error\",\"message\":\"There is no view with id %u.\"}", target);
            break;
        }
        srv_ws_watch(ws, v, target);
        break;
    }
    case SRV_VIEWER_QUALITY: {
        if (v->version < 2) {
            srv_ws_close_viewer(v, LWS_CLOSE_STATUS_POLICY_VIOLATION, "quality needs probecast.v2");
            break;
        }
        /* the own view's caps, also while following: the followed view keeps its owner's */
        srv_cmd *c = srv_cmd_new(SRV_CMD_VIEWER_QUALITY);
        c->view = v->own_view;
        c->jpeg_cap = m.jpeg_cap;
        c->fps_cap = m.fps_cap;
        post_input(ws, v, c);
        break;
    }
    case SRV_VIEWER_VIDEO: {
        if (v->version < 2) {
            srv_ws_close_viewer(v, LWS_CLOSE_STATUS_POLICY_VIOLATION, "video needs probecast.v2");
            break;
        }
        unsigned format, max_kbps;
        char why[160];
        if (!srv_viewer_video_request(&m, &format, &max_kbps, why, sizeof why)) {
            /* a request that cannot be done: the viewer keeps what it had */
            srv_ws_queue_textf(v, "{\"type\":\"error\",\"message\":\"%s\"}", why);
            break;
        }
        srv_ws_video_set(ws, v, format, max_kbps);
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
            v->acked_bytes += v->sent[i].bytes;
            v->sent[i].bytes = 0; /* counted once */
            unsigned cap = srv_ws_cap_from_lag(v->lag_ms);
            if (cap != v->cap) {
                v->cap = cap;
                srv_ws_update_caps(ws);
            }
            break;
        }
        if (!v->cur) lws_callback_on_writable(v->wsi); /* the window may have opened */
        break;
    }
    }
}
