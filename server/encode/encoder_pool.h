/* encoder_pool.h: JPEG encoder threads between the render thread and the senders.
 *
 * The render thread submits each read-back image with its frame info; the pool encodes it at
 * the frame's base quality and at the lower qualities the viewers' lag calls for (one job per
 * quality, spread over the threads): RGBA8 pixels with libjpeg-turbo, or the coefficients the
 * GPU computed (one set per quality) with libjpeg's entropy coder (jpeg_coefs.h), and publishes the
 * frame once all its variants are done and only if it is newer than its view's published one:
 * latest frame wins, per view. Jobs of a view's older frames that have not started are dropped when
 * a newer frame of that view arrives, so a slow encoder never builds a queue. Encoders see only CPU
 * memory: never a GPU object.
 *
 * Large images (at least the stripe threshold's pixels, with more than one thread) are encoded in
 * horizontal stripes (jpeg_striped.h): each variant becomes one job per stripe, spread over the
 * threads like any job, and the thread that finishes a variant's last stripe joins them into its
 * one JPEG. Small images are one job per variant. Both give the same decoded pixels.
 * A striped frame counts as started once its first stripe has: a newer frame of its view no longer
 * drops its other stripes (at most one frame a view in flight, one pending).
 */
#ifndef SRV_ENCODER_POOL_H
#define SRV_ENCODER_POOL_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "server/encode/image_pool.h"

/* Lag-driven quality caps are multiples of ten in [30, 90]: bit i of a cap mask is 30 + 10 i. */
#define SRV_CAP_MIN 30u
#define SRV_CAP_STEPS 7u

typedef struct srv_frame_info {
    uint64_t frame_id;
    uint32_t view_id;
    uint64_t capture_us;   /* Unix time when rendering began */
    uint64_t ready_us;     /* Unix time when its pixels reached the encoders */
    uint64_t input_ticket; /* every input command with a ticket up to this one is reflected */
    bool still;            /* produced after input stopped (full quality) */
    /* every watcher of its view takes it as video: published with no JPEG (variant_count 0),
     * for its image only */
    bool video_only;
} srv_frame_info;

typedef struct srv_jpeg {
    unsigned quality;
    uint8_t *data;
    size_t size;
} srv_jpeg;

/* One frame encoded at one or more qualities, shared read-only by the senders. */
typedef struct srv_frame {
    atomic_int refs;
    srv_frame_info info;
    unsigned width, height;
    uint64_t encode_us; /* Unix time when its last variant was done */
    unsigned variant_count;
    srv_jpeg variants[SRV_MAX_VARIANTS]; /* ascending quality */
    /* the RGBA8 pixels it was encoded from, kept once published for the video encoders
     * (video_stream.h); NULL when the GPU computed its coefficients */
    srv_image *image;
    /* encoder-private */
    unsigned remaining; /* jobs not finished or dropped */
    bool abandoned;
    struct srv_stripe_set *stripe_sets; /* one per variant when encoded in stripes, else NULL */
} srv_frame;

srv_frame *srv_frame_ref(srv_frame *f);
void srv_frame_unref(srv_frame *f); /* NULL is fine */
/* The variant of highest quality <= quality, else the lowest one. */
const srv_jpeg *srv_frame_pick(const srv_frame *f, unsigned quality);
/* The highest-quality variant. */
const srv_jpeg *srv_frame_best(const srv_frame *f);

typedef struct srv_encoder_stats {
    uint64_t frames_published, frames_dropped, jpegs_encoded, bytes_encoded;
    double encode_ms_avg; /* exponential moving average per JPEG (wall: first stripe to join) */
    double encode_ms_last;
    uint64_t jpegs_striped;     /* of jpegs_encoded, those encoded in stripes */
    uint64_t jpegs_from_gpu;    /* of jpegs_encoded, those entropy-coded from GPU coefficients */
    uint64_t frames_video_only; /* of frames_published, those without JPEG (video_only) */
} srv_encoder_stats;

/* Called (from an encoder thread) after a frame is published. Must be quick and thread-safe. */
typedef void (*srv_frame_listener)(void *user);

typedef struct srv_encoder_pool srv_encoder_pool;

/* Starts threads encoders (0 = 2). Returns NULL when a thread cannot be started. */
srv_encoder_pool *srv_encoder_pool_create(unsigned threads);

/* Stops and joins the threads, drops pending jobs, frees everything (NULL is fine). */
void srv_encoder_pool_destroy(srv_encoder_pool *p);
void srv_encoder_pool_set_listener(srv_encoder_pool *p, srv_frame_listener fn, void *user);
/* The qualities a frame of base_quality is encoded at now: base_quality and
 * min(base_quality, cap) for each cap in the current cap mask, ascending, unique. Returns how
 * many (1..SRV_MAX_VARIANTS). */
unsigned srv_encoder_qualities(srv_encoder_pool *p, unsigned base_quality,
                               unsigned q[SRV_MAX_VARIANTS]);
/* Encodes img (a reference is taken) as frame info: RGBA8 pixels at srv_encoder_qualities of
 * base_quality; coefficients at the qualities they were quantised at (base_quality unused). */
void srv_encoder_submit(srv_encoder_pool *p, srv_image *img, const srv_frame_info *info,
                        unsigned base_quality);
/* Images of at least this many pixels are encoded in stripes, one per thread (fewer for images
 * under SRV_STRIPE_MIN_MCU_ROWS MCU rows a stripe); see encoder_pool.c for the measurements. */
#define SRV_STRIPE_MIN_PIXELS 500000u
#define SRV_STRIPE_MIN_MCU_ROWS 2u
/* Sets the stripe threshold in pixels for frames submitted from now on (0: the default,
 * SRV_STRIPE_MIN_PIXELS; UINT_MAX: never). A pool of one thread never stripes. */
void srv_encoder_set_stripe_min_pixels(srv_encoder_pool *p, unsigned pixels);
/* Sets the lag-driven caps the viewers currently need (see SRV_CAP_*). */
void srv_encoder_set_caps(srv_encoder_pool *p, uint32_t mask);
/* The newest published frame of view view_id (a new reference) or NULL. A frame made for video
 * viewers only (srv_frame_info.video_only) has no JPEG: variant_count 0. */
srv_frame *srv_encoder_latest(srv_encoder_pool *p, uint32_t view_id);
/* Waits up to timeout_ms for a published frame of view_id newer than after_id, with JPEG (not
 * video only); returns it (a new reference) or NULL on timeout. */
srv_frame *srv_encoder_wait_frame(srv_encoder_pool *p, uint32_t view_id, uint64_t after_id,
                                  unsigned timeout_ms);
/* Drops the view's published frame (the view was freed). */
void srv_encoder_forget_view(srv_encoder_pool *p, uint32_t view_id);
void srv_encoder_get_stats(srv_encoder_pool *p, srv_encoder_stats *out);

#endif
