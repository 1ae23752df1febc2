/* image_pool.h: a frame's image on the CPU between the render thread and the encoders
 * (encoder_pool.h), reference counted, and the pool of pixel buffers it recycles.
 *
 * The render thread allocates an image for each frame it reads back (or wraps a leased readback
 * slot) and hands it to the encoders; whichever thread drops the last reference returns its
 * buffer to the pool, where the next image of about the same size takes it. Any thread may
 * allocate and release images.
 */
#ifndef SRV_IMAGE_POOL_H
#define SRV_IMAGE_POOL_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

/* The most qualities a frame is encoded at (an image carries at most this many coefficient
 * sets). */
#define SRV_MAX_VARIANTS 8

/* A frame's image on the CPU, shared read-only (reference counted): its tone-mapped RGBA8
 * pixels, or what the GPU computed of them: JPEG coefficients (renderer/encode/jpeg_dct.h), I420 planes
 * (renderer/encode/video_i420.h), or both. */
typedef struct srv_image {
    atomic_int refs;
    unsigned width, height;
    /* coef_sets 0: width * height * 4 bytes of RGBA8, top row first; else coef_sets sets of
     * coefficients end to end (rd_jpeg_coef_bytes each), set i quantised at coef_quality[i],
     * ascending: the qualities its frame is encoded at */
    uint8_t *data;
    unsigned coef_sets;
    unsigned coef_quality[SRV_MAX_VARIANTS];
    /* the frame as I420 for the video encoders too (GPU path, a view with video viewers:
     * renderer/encode/video_i420.h): Y at data + i420_at, i420_y_stride bytes a row, then Cb and Cr,
     * i420_c_stride bytes a row and (height + 1) / 2 rows each; i420_y_stride 0: none */
    size_t i420_at;
    unsigned i420_y_stride, i420_c_stride;
    size_t cap; /* bytes allocated (buffers are recycled) */
    /* pixels the image does not own (srv_image_wrap): release(ctx, token) when the last reference
     * goes */
    void (*release)(void *ctx, unsigned token);
    void *release_ctx;
    unsigned release_token;
} srv_image;

srv_image *srv_image_new(unsigned width, unsigned height); /* RGBA8 */
srv_image *srv_image_alloc(unsigned width, unsigned height, size_t bytes);
/* An image over bytes owned elsewhere (a leased readback slot): release(ctx, token) runs, on
 * whichever thread drops the last reference, when nobody reads them any more. */
srv_image *srv_image_wrap(unsigned width, unsigned height, uint8_t *data,
                          void (*release)(void *ctx, unsigned token), void *ctx, unsigned token);
srv_image *srv_image_ref(srv_image *img);
void srv_image_unref(srv_image *img); /* NULL is fine */
/* Frees the recycled pixel buffers (srv_encoder_pool_destroy does this). */
void srv_image_pool_drain(void);

#endif
