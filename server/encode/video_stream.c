/* video_stream.c: a viewer's video encoder thread; see video_stream.h for the contract. */
#include "server/encode/video_stream.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "server/base/clock.h"
#include "server/base/log.h"

struct srv_video_stream {
    pthread_mutex_t mu;
    pthread_cond_t cv;
    pthread_t thread;
    bool stopping, failed, force_key, encoding;
    srv_frame *pending;
    srv_video_out *ready;
    unsigned kbps;
    void (*on_ready)(void *user);
    void *user;
    /* the thread's own */
    srv_video_codec codec;
    srv_video_encoder *enc;
    unsigned enc_w, enc_h, enc_kbps;
    unsigned speed, threads;
};

void srv_video_out_free(srv_video_out *o)
{
    if (!o) return;
    srv_frame_unref(o->frame);
    free(o->data);
    free(o);
}

static unsigned clamp_kbps(unsigned kbps)
{
    return kbps < SRV_VIDEO_MIN_KBPS   ? SRV_VIDEO_MIN_KBPS
           : kbps > SRV_VIDEO_MAX_KBPS ? SRV_VIDEO_MAX_KBPS
                                       : kbps;
}

/* Encodes f (thread only): a new encoder for a new size, then one packet. NULL on failure. */
static srv_video_out *encode(srv_video_stream *s, srv_frame *f, unsigned kbps, bool key)
{
    char err[256] = "";
    double t0 = srv_mono_ms();
    srv_video_result r = SRV_VIDEO_OK;
    if (!s->enc || s->enc_w != f->width || s->enc_h != f->height) {
        srv_video_encoder_destroy(s->enc);
        s->enc = NULL;
        pthread_mutex_lock(&s->mu);
        srv_video_desc d = {.codec = s->codec,
                            .width = f->width,
                            .height = f->height,
                            .bitrate_kbps = kbps,
                            .speed = s->speed,
                            .threads = s->threads ? s->threads
                                                  : srv_video_threads_for(f->width, f->height)};
        pthread_mutex_unlock(&s->mu);
        r = srv_video_encoder_create(&d, &s->enc, err, sizeof err);
        s->enc_w = f->width, s->enc_h = f->height, s->enc_kbps = kbps;
    } else if (kbps != s->enc_kbps) {
        r = srv_video_set_bitrate(s->enc, kbps, err, sizeof err);
        if (r == SRV_VIDEO_OK) s->enc_kbps = kbps;
        r = SRV_VIDEO_OK; /* on failure the old rate stays */
    }
    srv_video_packet p = {0};
    const srv_image *img = f->image;
    if (r == SRV_VIDEO_OK && img->i420_y_stride) { /* planes the GPU made */
        const uint8_t *y = img->data + img->i420_at;
        const uint8_t *cb = y + (size_t)img->i420_y_stride * img->height;
        const uint8_t *cr = cb + (size_t)img->i420_c_stride * ((img->height + 1) / 2);
        r = srv_video_encode_i420(s->enc, y, img->i420_y_stride, cb, cr, img->i420_c_stride, key,
                                  &p, err, sizeof err);
    } else if (r == SRV_VIDEO_OK) {
        r = srv_video_encode(s->enc, img->data, (size_t)f->width * 4, key, &p, err, sizeof err);
    }
    if (r == SRV_VIDEO_OK && p.size == 0) {
        r = SRV_VIDEO_LIBRARY;
        snprintf(err, sizeof err, "no packet for a frame");
    }
    if (r != SRV_VIDEO_OK) {
        srv_error("video", "%s encoding of a %ux%u frame failed: %s: %s",
                  srv_video_codec_name(s->codec), f->width, f->height, srv_video_strerror(r), err);
        return NULL;
    }
    srv_video_out *o = calloc(1, sizeof *o);
    uint8_t *data = malloc(p.size);
    if (!o || !data) abort();
    memcpy(data, p.data, p.size);
    o->frame = srv_frame_ref(f);
    o->data = data;
    o->size = p.size;
    o->key = p.key;
    o->kbps = s->enc_kbps;
    o->encode_us = srv_unix_us();
    o->encode_ms = srv_mono_ms() - t0;
    return o;
}

static void *run(void *arg)
{
    srv_video_stream *s = arg;
    pthread_mutex_lock(&s->mu);
    for (;;) {
        while (!s->stopping && !(s->pending && !s->ready && !s->failed))
            pthread_cond_wait(&s->cv, &s->mu);
        if (s->stopping) break;
        srv_frame *f = s->pending;
        s->pending = NULL;
        bool key = s->force_key;
        s->force_key = false;
        unsigned kbps = s->kbps;
        s->encoding = true;
        pthread_mutex_unlock(&s->mu);
        srv_video_out *o = encode(s, f, kbps, key);
        srv_frame_unref(f);
        pthread_mutex_lock(&s->mu);
        s->encoding = false;
        s->ready = o;
        if (!o) s->failed = true;
        bool tell = !s->stopping;
        pthread_mutex_unlock(&s->mu);
        if (tell) s->on_ready(s->user); /* a packet, or a failure the sender must see */
        pthread_mutex_lock(&s->mu);
    }
    pthread_mutex_unlock(&s->mu);
    return NULL;
}

srv_video_stream *srv_video_stream_create(srv_video_codec codec, unsigned kbps,
                                          void (*ready)(void *user), void *user)
{
    srv_video_stream *s = calloc(1, sizeof *s);
    if (!s) abort();
    s->codec = codec;
    s->kbps = clamp_kbps(kbps);
    s->on_ready = ready;
    s->user = user;
    pthread_mutex_init(&s->mu, NULL);
    pthread_cond_init(&s->cv, NULL);
    if (pthread_create(&s->thread, NULL, run, s) != 0) {
        pthread_cond_destroy(&s->cv);
        pthread_mutex_destroy(&s->mu);
        free(s);
        return NULL;
    }
    return s;
}

void srv_video_stream_destroy(srv_video_stream *s)
{
    if (!s) return;
    pthread_mutex_lock(&s->mu);
    s->stopping = true;
    pthread_cond_signal(&s->cv);
    pthread_mutex_unlock(&s->mu);
    pthread_join(s->thread, NULL);
    srv_frame_unref(s->pending);
    srv_video_out_free(s->ready);
    srv_video_encoder_destroy(s->enc);
    pthread_cond_destroy(&s->cv);
    pthread_mutex_destroy(&s->mu);
    free(s);
}

bool srv_video_stream_submit(srv_video_stream *s, srv_frame *f)
{
    const srv_image *img = f->image; /* RGBA8 pixels or I420 planes */
    if (!img || (img->coef_sets && !img->i420_y_stride) || img->width != f->width ||
        img->height != f->height)
        return false;
    pthread_mutex_lock(&s->mu);
    srv_frame_unref(s->pending);
    s->pending = srv_frame_ref(f);
    pthread_cond_signal(&s->cv);
    pthread_mutex_unlock(&s->mu);
    return true;
}

srv_video_out *srv_video_stream_take(srv_video_stream *s)
{
    pthread_mutex_lock(&s->mu);
    srv_video_out *o = s->ready;
    s->ready = NULL;
    if (o) pthread_cond_signal(&s->cv); /* a pending frame may be encoded now */
    pthread_mutex_unlock(&s->mu);
    return o;
}

bool srv_video_stream_idle(srv_video_stream *s)
{
    pthread_mutex_lock(&s->mu);
    bool idle = !s->pending && !s->encoding && !s->ready;
    pthread_mutex_unlock(&s->mu);
    return idle;
}

bool srv_video_stream_failed(srv_video_stream *s)
{
    pthread_mutex_lock(&s->mu);
    bool failed = s->failed;
    pthread_mutex_unlock(&s->mu);
    return failed;
}

unsigned srv_video_threads_for(unsigned width, unsigned height)
{
    unsigned t = (unsigned)((uint64_t)width * height / 1000000u);
    return t < 1 ? 1 : t > 4 ? 4 : t;
}

void srv_video_stream_tune(srv_video_stream *s, unsigned speed, unsigned threads)
{
    pthread_mutex_lock(&s->mu);
    s->speed = speed;
    s->threads = threads;
    pthread_mutex_unlock(&s->mu);
}

void srv_video_stream_force_key(srv_video_stream *s)
{
    pthread_mutex_lock(&s->mu);
    s->force_key = true;
    pthread_mutex_unlock(&s->mu);
}

void srv_video_stream_set_kbps(srv_video_stream *s, unsigned kbps)
{
    pthread_mutex_lock(&s->mu);
    s->kbps = clamp_kbps(kbps);
    pthread_mutex_unlock(&s->mu);
}

unsigned srv_video_stream_kbps(srv_video_stream *s)
{
    pthread_mutex_lock(&s->mu);
    unsigned kbps = s->kbps;
    pthread_mutex_unlock(&s->mu);
    return kbps;
}

unsigned srv_video_next_kbps(unsigned cur, double acked_kbps, bool lagging, unsigned cap)
{
    if (!cap) cap = SRV_VIDEO_DEFAULT_MAX_KBPS;
    double next = cur;
    if (lagging)
        next = 0.85 * (acked_kbps < cur ? acked_kbps : cur);
    else if (acked_kbps > 0)
        next = cur * 1.25;
    if (next > cap) next = cap;
    if (next < SRV_VIDEO_MIN_KBPS) next = SRV_VIDEO_MIN_KBPS;
    return (unsigned)next;
}
