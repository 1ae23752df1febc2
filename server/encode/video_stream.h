/* video_stream.h: one viewer's frames as video (issue 26), encoded on a thread of its own.
 *
 * The stream's sender hands it published frames (encoder_pool.h) whose RGBA8 pixels they still
 * hold; the thread encodes them with video_encoder.h and leaves one packet ready for the sender.
 * Latest frame wins, but only before encoding: a frame waiting to be encoded is replaced by a
 * newer one, while every packet the encoder makes is taken by the sender (the thread waits
 * until it is), so a viewer never misses an inter frame and never needs a key frame after a
 * drop. Key frames: the first frame, a new size (the encoder is made again), and
 * srv_video_stream_force_key (a request). One frame in the encoder, one ready, one pending at
 * most; the render thread is never involved.
 */
#ifndef SRV_VIDEO_STREAM_H
#define SRV_VIDEO_STREAM_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "server/encode/encoder_pool.h"
#include "server/encode/video_encoder.h"

/* One encoded frame, owned by whoever took it (srv_video_out_free). */
typedef struct srv_video_out {
    srv_frame *frame; /* the frame it encodes (a reference) */
    uint8_t *data;
    size_t size;
    bool key;
    unsigned kbps;      /* the target it was encoded at */
    uint64_t encode_us; /* Unix time when its encoding finished */
    double encode_ms;
} srv_video_out;

void srv_video_out_free(srv_video_out *o); /* NULL is fine */

typedef struct srv_video_stream srv_video_stream;

/* Starts the thread; ready(user) is called from it after each packet (quick, thread-safe).
 * NULL when the thread cannot be started. */
srv_video_stream *srv_video_stream_create(srv_video_codec codec, unsigned kbps,
                                          void (*ready)(void *user), void *user);
/* The encoder's speed and threads (srv_video_desc; 0: defaults), from the next encoder it
 * makes on (set before the first frame). */
void srv_video_stream_tune(srv_video_stream *s, unsigned speed, unsigned threads);
/* Encoder threads when none are set: one a million pixels, 1 to 4 (1080p: 2). On the H200
 * host's cores ten 1080p VP9 viewers got 53 fps each with 2 threads against 40 with 1
 * (tests/bench/results/h200/video_load_stop41.txt); a thread pool per viewer would share the
 * cores better, but libvpx's threads are its own. */
unsigned srv_video_threads_for(unsigned width, unsigned height);
/* Stops and joins the thread, frees what it holds (NULL is fine). */
void srv_video_stream_destroy(srv_video_stream *s);
/* Queues f (a reference is taken) in place of any frame waiting. false (nothing queued) when f
 * has no RGBA8 pixels (the GPU JPEG path keeps only coefficients). */
bool srv_video_stream_submit(srv_video_stream *s, srv_frame *f);
/* The packet ready, or NULL. */
srv_video_out *srv_video_stream_take(srv_video_stream *s);
/* Nothing waiting, encoding or ready: a frame sent another way now cannot overtake a packet. */
bool srv_video_stream_idle(srv_video_stream *s);
/* The encoder failed (the reason is logged); the stream makes no more packets. */
bool srv_video_stream_failed(srv_video_stream *s);
void srv_video_stream_force_key(srv_video_stream *s);
/* The target bitrate from the next frame on (clamped to SRV_VIDEO_MIN_KBPS..SRV_VIDEO_MAX_KBPS). */
void srv_video_stream_set_kbps(srv_video_stream *s, unsigned kbps);
unsigned srv_video_stream_kbps(srv_video_stream *s);

/* Rate control, once a second (a pure rule, unit-tested): the next target from the current
 * one, the payload kbit/s the viewer acknowledged over that second, whether its acks lag (the
 * JPEG path's lag signal, server/stream/ws_stream.c), and the cap (0: none; then
 * SRV_VIDEO_DEFAULT_MAX_KBPS). Lagging: 85 % of what got through (at most the current target);
 * keeping up with frames acknowledged: a quarter more; no acks: unchanged. Clamped to
 * SRV_VIDEO_MIN_KBPS..cap. */
#define SRV_VIDEO_DEFAULT_MAX_KBPS 20000u
unsigned srv_video_next_kbps(unsigned cur, double acked_kbps, bool lagging, unsigned cap);

#endif
