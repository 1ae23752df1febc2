/* video_decode.h: decodes the packets of server/encode/video_encoder.h for tests and benchmarks:
 * VP8 and VP9 with libvpx's decoder, AV1 with dav1d (when built with PROBECAST_HAVE_DAV1D; a test
 * dependency only, deploy/install-test-deps.sh). Pictures are I420, 8 bits, as a browser's
 * VideoDecoder would produce them. */
#ifndef PC_VIDEO_DECODE_H
#define PC_VIDEO_DECODE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "server/encode/video_encoder.h"

typedef struct video_picture {
    unsigned width, height; /* the coded size */
    const uint8_t *y, *cb, *cr;
    size_t y_stride, c_stride;
    bool key; /* the decoder saw a key frame */
} video_picture;

typedef struct video_decoder video_decoder;

/* false (with the reason in err) when the codec cannot be decoded here. */
bool video_decoder_open(video_decoder **out, srv_video_codec codec, char *err, size_t err_size);
void video_decoder_close(video_decoder *d); /* NULL is fine */
/* Decodes one packet; the picture stays valid until the next call. */
bool video_decoder_decode(video_decoder *d, const uint8_t *data, size_t size, video_picture *pic,
                          char *err, size_t err_size);

#endif
