/* ws_video.c: a viewer's video stream (protocol/stream.md, "video"): starting and stopping its
 * encoder thread (server/encode/video_stream.h), choosing what it is sent next, and its target
 * bitrate. Service thread only.
 *
 * One encoder per viewer, not per view: every viewer joins with a key frame of its own and is
 * paced by its own link (Pixel Streaming 2 dropped its shared encoding for the same reasons), and
 * a version-2 viewer owns its view, so a shared encoder would save only followers' encodes. */
#include "server/stream/ws_internal.h"

#include "server/base/log.h"

/* Where the target starts: VP9 matched JPEG q60 at about 1.25 Mbit/s at 640x360
 * (tests/bench/results/lavapipe/video_encode*.txt); Selkies quotes 8-12 Mbit/s for 1080p60. */
#define START_KBPS 4000u

static srv_video_codec codec_of(unsigned format)
{
    return format == PROTO_FORMAT_VP8 ? SRV_VIDEO_VP8 : SRV_VIDEO_VP9;
}

static void post_video_delta(srv_ws_stream *ws, uint32_t view, int delta)
{
    srv_cmd *c = srv_cmd_new(SRV_CMD_VIEW_VIDEO);
    c->view = view;
    c->delta = delta;
    srv_render_post(ws->cfg.loop, c);
}

void srv_ws_video_count(srv_ws_stream *ws, viewer *v)
{
    bool want = v->video != NULL;
    if (v->video_counted && (!want || v->video_counted_view != v->watching)) {
        post_video_delta(ws, v->video_counted_view, -1);
        v->video_counted = false;
    }
    if (want && !v->video_counted) {
        post_video_delta(ws, v->watching, 1);
        v->video_counted = true;
        v->video_counted_view = v->watching;
    }
}

void srv_ws_video_stop(srv_ws_stream *ws, viewer *v)
{
    srv_video_stream_destroy(v->video);
    v->video = NULL;
    v->format = PROTO_FORMAT_JPEG;
    v->video_queued_id = 0;
    srv_ws_video_count(ws, v);
}

void srv_ws_video_set(srv_ws_stream *ws, viewer *v, unsigned format, unsigned max_kbps)
{
    if (format == PROTO_FORMAT_JPEG) {
        srv_ws_video_stop(ws, v);
        return;
    }
    unsigned cap = max_kbps ? max_kbps : SRV_VIDEO_DEFAULT_MAX_KBPS;
    v->video_max_kbps = max_kbps;
    if (v->video && v->format == format) {
        /* the same codec again: a new cap, and a key frame (a viewer asks again to resync) */
        if (srv_video_stream_kbps(v->video) > cap) srv_video_stream_set_kbps(v->video, cap);
        srv_video_stream_force_key(v->video);
        return;
    }
    srv_ws_video_stop(ws, v);
    v->video = srv_video_stream_create(codec_of(format), START_KBPS < cap ? START_KBPS : cap,
                                       srv_ws_frame_ready, ws);
    if (v->video && format == PROTO_FORMAT_VP9)
        srv_video_stream_tune(v->video, ws->cfg.vp9_speed, ws->cfg.video_threads);
    else if (v->video)
        srv_video_stream_tune(v->video, 0, ws->cfg.video_threads);
    if (!v->video) {
        srv_ws_queue_textf(v, "{\"type\":\"error\",\"message\":\"Video is not available now; "
                              "frames stay JPEG.\"}");
        return;
    }
    v->format = format;
    srv_ws_video_count(ws, v);
    srv_info("stream", "viewer %u: %s video (cap %u kbit/s)", v->id, proto_format_name(format),
             cap);
}

void srv_ws_video_next(srv_ws_stream *ws, viewer *v, srv_video_out **out, srv_frame **jpeg)
{
    *out = NULL;
    *jpeg = NULL;
    if (v->video) {
        *out = srv_video_stream_take(v->video);
        if (*out) return;
        if (srv_video_stream_failed(v->video)) {
            srv_ws_video_stop(ws, v);
            srv_ws_queue_textf(v, "{\"type\":\"error\",\"message\":\"Video encoding failed; "
                                  "frames are JPEG again.\"}");
        }
    }
    srv_frame *f = srv_encoder_latest(ws->cfg.encoders, v->watching);
    uint64_t seen = v->last_sent_id > v->video_queued_id ? v->last_sent_id : v->video_queued_id;
    if (!f || f->info.frame_id <= seen) {
        srv_frame_unref(f);
        return;
    }
    if (v->video) {
        /* moving frames go to the encoder; a still is sent as today's sharp JPEG, once the
         * packets before it are out (a video frame must not overtake it) */
        if (!f->info.still && srv_video_stream_submit(v->video, f)) {
            v->video_queued_id = f->info.frame_id;
            srv_frame_unref(f);
            return;
        }
        if (!srv_video_stream_idle(v->video)) {
            srv_frame_unref(f);
            return;
        }
    }
    if (!f->variant_count) { /* a moving frame made for video viewers only (no JPEG) */
        srv_frame_unref(f);
        return;
    }
    *jpeg = f;
}

static void viewer_tick(viewer *v, double seconds)
{
    uint64_t acked = v->acked_bytes;
    v->acked_bytes = 0;
    if (!v->video || seconds <= 0) return;
    unsigned cur = srv_video_stream_kbps(v->video);
    /* acks lag when the JPEG path's lag-driven quality cap is on (lag over 20 ms) */
    unsigned next = srv_video_next_kbps(cur, (double)acked * 8 / 1000 / seconds, v->cap < 100,
                                        v->video_max_kbps);
    if (next != cur) srv_video_stream_set_kbps(v->video, next);
}

void srv_ws_video_tick(srv_ws_stream *ws, double seconds)
{
    unsigned n = 0, video = 0;
    for (viewer *v = ws->viewers; v; v = v->next) {
        v->sent_kbps = seconds > 0 ? (double)v->sent_bytes * 8 / 1000 / seconds : 0;
        v->sent_bytes = 0;
        viewer_tick(v, seconds);
        video += v->video != NULL;
        if (n < SRV_WS_STATS_VIEWERS)
            ws->stats.per_viewer[n++] = (srv_ws_viewer_stats){
                .viewer = v->id,
                .view = v->watching,
                .format = v->video ? v->format : PROTO_FORMAT_JPEG,
                .target_kbps = v->video ? srv_video_stream_kbps(v->video) : 0,
                .sent_kbps = v->sent_kbps,
                .encode_ms = v->video ? v->encode_ms : 0,
            };
    }
    ws->stats.viewer_count = n;
    ws->stats.video_viewers = video;
}
