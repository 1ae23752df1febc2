/* A viewer's video encoder thread (server/encode/video_stream.h) without the daemon: the first
 * packet and the first of a new size are key frames, a forced key too and no others; a frame
 * waiting for the encoder is replaced by a newer one, but every packet made is kept until taken,
 * so the packets taken decode in order; a frame without RGBA8 pixels is refused; and the rate
 * control rule (srv_video_next_kbps). */
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "server/encode/video_stream.h"
#include "test_util.h"
#include "video_decode.h"

static atomic_int ready_calls;
static void on_ready(void *user)
{
    (void)user;
    atomic_fetch_add(&ready_calls, 1);
}

/* A published frame of w x h with a moving gradient (its own image). */
static srv_frame *make_frame(uint64_t id, unsigned w, unsigned h)
{
    srv_frame *f = calloc(1, sizeof *f);
    atomic_init(&f->refs, 1);
    f->info.frame_id = id;
    f->width = w, f->height = h;
    f->image = srv_image_new(w, h);
    for (unsigned y = 0; y < h; y++)
        for (unsigned x = 0; x < w; x++) {
            uint8_t *p = f->image->data + ((size_t)y * w + x) * 4;
            p[0] = (uint8_t)(x * 3 + id * 5), p[1] = (uint8_t)(y * 4), p[2] = (uint8_t)(x + y);
            p[3] = 255;
        }
    return f;
}

/* Waits up to 5 s for a packet. */
static srv_video_out *take(srv_video_stream *s)
{
    for (int i = 0; i < 500; i++) {
        srv_video_out *o = srv_video_stream_take(s);
        if (o) return o;
        nanosleep(&(struct timespec){0, 10000000}, NULL);
    }
    return NULL;
}

static bool decodes(video_decoder *d, const srv_video_out *o)
{
    video_picture pic;
    char err[256];
    return o && video_decoder_decode(d, o->data, o->size, &pic, err, sizeof err) &&
           pic.width == o->frame->width && pic.height == o->frame->height && pic.key == o->key;
}

static void test_rate_rule(void)
{
    CHECK(srv_video_next_kbps(4000, 3000, false, 0) == 5000); /* keeps up: a quarter more */
    CHECK(srv_video_next_kbps(4000, 0, false, 0) == 4000);    /* no acks: unchanged */
    CHECK(srv_video_next_kbps(4000, 1000, true, 0) == 850);   /* lags: 85 % of what got through */
    CHECK(srv_video_next_kbps(4000, 9000, true, 0) == 3400);  /* at most 85 % of the target */
    CHECK(srv_video_next_kbps(1800, 1500, false, 2000) == 2000); /* the viewer's cap */
    CHECK(srv_video_next_kbps(19000, 9000, false, 0) == SRV_VIDEO_DEFAULT_MAX_KBPS);
    CHECK(srv_video_next_kbps(60, 10, true, 0) == SRV_VIDEO_MIN_KBPS);
}

int main(void)
{
    test_rate_rule();
    srv_video_stream *s = srv_video_stream_create(SRV_VIDEO_VP9, 500, on_ready, NULL);
    video_decoder *d = NULL;
    char err[256];
    CHECK(s && video_decoder_open(&d, SRV_VIDEO_VP9, err, sizeof err));
    if (!s || !d) return test_finish();
    CHECK(srv_video_stream_idle(s) && srv_video_stream_kbps(s) == 500);

    /* the first packet is a key frame; the next is not */
    srv_frame *f = make_frame(1, 64, 48);
    CHECK(srv_video_stream_submit(s, f));
    srv_frame_unref(f);
    srv_video_out *o = take(s);
    CHECK(o && o->key && o->frame->info.frame_id == 1 && o->kbps == 500 && decodes(d, o));
    srv_video_out_free(o);
    CHECK(srv_video_stream_idle(s));
    f = make_frame(2, 64, 48);
    srv_video_stream_submit(s, f);
    srv_frame_unref(f);
    o = take(s);
    CHECK(o && !o->key && decodes(d, o));
    srv_video_out_free(o);

    /* latest wins while waiting: 3 is encoded (not taken), 4 is replaced by 5; 3 then 5 decode */
    f = make_frame(3, 64, 48);
    srv_video_stream_submit(s, f);
    srv_frame_unref(f);
    for (int i = 0; i < 500 && srv_video_stream_idle(s) == false && atomic_load(&ready_calls) < 3;
         i++)
        nanosleep(&(struct timespec){0, 10000000}, NULL);
    CHECK(atomic_load(&ready_calls) >= 3 && !srv_video_stream_idle(s)); /* 3 is ready */
    for (uint64_t id = 4; id <= 5; id++) {
        f = make_frame(id, 64, 48);
        srv_video_stream_submit(s, f);
        srv_frame_unref(f);
    }
    o = take(s);
    CHECK(o && o->frame->info.frame_id == 3 && !o->key && decodes(d, o));
    srv_video_out_free(o);
    o = take(s);
    CHECK(o && o->frame->info.frame_id == 5 && !o->key && decodes(d, o));
    srv_video_out_free(o);

    /* a forced key frame; a new size starts with a key frame; a new bitrate applies */
    srv_video_stream_force_key(s);
    srv_video_stream_set_kbps(s, 800);
    f = make_frame(6, 64, 48);
    srv_video_stream_submit(s, f);
    srv_frame_unref(f);
    o = take(s);
    CHECK(o && o->key && o->kbps == 800 && decodes(d, o));
    srv_video_out_free(o);
    f = make_frame(7, 80, 60);
    srv_video_stream_submit(s, f);
    srv_frame_unref(f);
    o = take(s);
    CHECK(o && o->key && o->frame->width == 80 && decodes(d, o));
    srv_video_out_free(o);

    /* no RGBA8 pixels (the GPU JPEG path's coefficients): refused */
    f = make_frame(8, 64, 48);
    f->image->coef_sets = 1;
    CHECK(!srv_video_stream_submit(s, f));
    srv_image_unref(f->image);
    f->image = NULL;
    CHECK(!srv_video_stream_submit(s, f));
    srv_frame_unref(f);
    CHECK(srv_video_stream_idle(s) && !srv_video_stream_failed(s));

    /* a frame left waiting is freed with the stream */
    f = make_frame(9, 64, 48);
    srv_video_stream_submit(s, f);
    srv_frame_unref(f);
    srv_video_stream_destroy(s);
    video_decoder_close(d);
    srv_image_pool_drain();
    return test_finish();
}
