/* video_encoder.h: one view's frames as a low-latency video stream (issue 26): VP8 and VP9
 * with libvpx (realtime), AV1 with SVT-AV1 (low delay). One frame in, one packet out: no
 * B-frames, no look-ahead, no alt-ref, so each packet can be sent as soon as its frame is
 * encoded: VP8 and VP9 return each frame's packet from the call that encodes it. AV1 cannot:
 * SVT-AV1 1.4.1's low-delay mode (which its authors call a work in progress) releases a frame's
 * packet only when the next frame arrives, so an AV1 encoder returns the previous frame's packet
 * (srv_video_delay is 1) and srv_video_flush gets the last one out (ending the stream). That is
 * a frame of latency, and a still frame stuck until flushed: AV1 is here to be measured
 * (tests/bench/video_encode.c), not yet for the live stream.
 * Key frames come first, when the caller forces one (a viewer joins, a resize, a loss, a
 * request) and, for AV1, after a bitrate change or a flush; never on a timer.
 *
 * Colour: the encoders take I420 in BT.601 limited range (Y 16..235, Cb/Cr 16..240) converted
 * here from the renderer's RGBA8 (sRGB). That is what a VP8 decoder assumes (VP8 has no colour
 * signalling; Chromium's WebCodecs gives VP8 frames the BT.601 "smpte170m" matrix, limited
 * range); VP9 and AV1 streams say so in their headers (VP9 colour_space BT.601, studio range;
 * AV1 CICP primaries BT.709, transfer sRGB, matrix BT.601, studio range), so a browser draws
 * the three alike. JPEG (JFIF) uses the same matrix at full range.
 *
 * Sizes: VP8 and VP9 code any size (odd ones too). SVT-AV1 1.4.1 codes at least 64 x 64 pixels
 * and an even width and height, so a smaller or odd AV1 frame is padded on the right and bottom
 * with copies of its last column and row; srv_video_coded_size says what the decoder will see,
 * and the viewer shows its top-left width x height pixels.
 *
 * An encoder is used by one thread at a time (the caller serialises encode and set_bitrate).
 */
#ifndef SRV_VIDEO_ENCODER_H
#define SRV_VIDEO_ENCODER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef enum srv_video_codec {
    SRV_VIDEO_VP8 = 1,
    SRV_VIDEO_VP9 = 2,
    SRV_VIDEO_AV1 = 3,
} srv_video_codec;

typedef enum srv_video_result {
    SRV_VIDEO_OK = 0,
    SRV_VIDEO_BAD_CODEC,   /* not one of srv_video_codec */
    SRV_VIDEO_BAD_SIZE,    /* width or height outside [SRV_VIDEO_MIN_SIDE, SRV_VIDEO_MAX_SIDE] */
    SRV_VIDEO_BAD_BITRATE, /* outside [SRV_VIDEO_MIN_KBPS, SRV_VIDEO_MAX_KBPS] */
    SRV_VIDEO_BAD_ARG,     /* threads, fps or speed out of range, a NULL pointer, a short stride */
    SRV_VIDEO_LIBRARY,     /* the codec library refused (the detail names its error) */
    SRV_VIDEO_NO_MEMORY,
} srv_video_result;

const char *srv_video_strerror(srv_video_result r);
const char *srv_video_codec_name(srv_video_codec c); /* "vp8", "vp9", "av1"; NULL if unknown */

/* The protocol clamps a view to 16..4096 pixels a side. */
#define SRV_VIDEO_MIN_SIDE 16u
#define SRV_VIDEO_MAX_SIDE 4096u
/* 50 kbit/s is a thumbnail; 100 Mbit/s is more than uncapped JPEG at 1080p took (issue 26). */
#define SRV_VIDEO_MIN_KBPS 50u
#define SRV_VIDEO_MAX_KBPS 100000u
#define SRV_VIDEO_MAX_THREADS 64u
/* Default speeds. VP8 cpu-used -6 is the speed WebRTC's VP8 encoder uses on desktop CPUs; AV1
 * preset 10 sits in the fast half of SVT-AV1's 0..13. VP9 9, the fastest of libvpx's realtime
 * range (5..9), by measurement (tests/bench/results/h200/video_load_stop41.txt, the H200 host's
 * 16 Xeon cores): ten 1080p viewers got 39.8 fps each at 9 against 26.1 at 7 (probecast_loadtest,
 * closed loop), for 0.4-0.9 dB less PSNR at equal bits (probecast_videobench). */
#define SRV_VIDEO_VP8_SPEED 6u
#define SRV_VIDEO_VP9_SPEED 9u
#define SRV_VIDEO_AV1_SPEED 10u

/* Zero means the default for every member but codec, width, height and bitrate_kbps. */
typedef struct srv_video_desc {
    srv_video_codec codec;
    unsigned width, height;
    unsigned bitrate_kbps; /* target (CBR) */
    unsigned threads;      /* encoder threads (0 = 1) */
    unsigned fps;          /* frame rate the rate control assumes (0 = 60; 1..240) */
    /* speed (0 = the default, see video_encoder.c): VP8 cpu-used 4..16, VP9 cpu-used 5..9,
     * AV1 preset 8..13; higher is faster and worse */
    unsigned speed;
} srv_video_desc;

/* One encoded frame; data belongs to the encoder and stays valid until its next encode, flush
 * or destroy. size 0: no packet this time (AV1's first frame of a stream, see the top); VP8 and
 * VP9 always give one (frame dropping is off). */
typedef struct srv_video_packet {
    const uint8_t *data;
    size_t size;
    bool key;       /* a key frame: decodable without any earlier packet */
    uint64_t frame; /* the frame it encodes: 0 for the first given to srv_video_encode */
} srv_video_packet;

typedef struct srv_video_encoder srv_video_encoder;

/* Creates an encoder; on failure *out is NULL and err (when err_size > 0) names the reason. */
srv_video_result srv_video_encoder_create(const srv_video_desc *desc, srv_video_encoder **out,
                                          char *err, size_t err_size);
/* Frees everything (NULL is fine). */
void srv_video_encoder_destroy(srv_video_encoder *e);

/* Encodes one frame: width x height RGBA8 pixels of desc's size, rows top first, stride bytes
 * apart (>= width * 4). The first frame, and one with force_key, is a key frame. out receives
 * the packet of the frame srv_video_delay frames back (see srv_video_packet). */
srv_video_result srv_video_encode(srv_video_encoder *e, const uint8_t *rgba, size_t stride,
                                  bool force_key, srv_video_packet *out, char *err,
                                  size_t err_size);
/* srv_video_encode of a frame already in I420 (BT.601 limited range, as srv_video_rgba_to_i420
 * writes it; e.g. by the GPU: renderer/encode/video_i420.h): the Y plane (width x height bytes, rows
 * y_stride apart), Cb and Cr ((width + 1) / 2 x (height + 1) / 2, rows c_stride apart). */
srv_video_result srv_video_encode_i420(srv_video_encoder *e, const uint8_t *y, size_t y_stride,
                                       const uint8_t *cb, const uint8_t *cr, size_t c_stride,
                                       bool force_key, srv_video_packet *out, char *err,
                                       size_t err_size);
/* The packet of the last frame still inside the encoder (AV1; size 0 when none, and always for
 * VP8 and VP9). AV1's stream ends: the next frame starts a new one with a key frame. */
srv_video_result srv_video_flush(srv_video_encoder *e, srv_video_packet *out, char *err,
                                 size_t err_size);
/* How many frames a packet comes after its frame: 0 (VP8, VP9) or 1 (AV1). */
unsigned srv_video_delay(const srv_video_encoder *e);
/* Changes the target bitrate from the next frame on. VP8 and VP9 change it in place (no key
 * frame; on failure they keep the old one). SVT-AV1 1.4.1 cannot change it in a running
 * encoder, so AV1's next encode starts a new stream at the new bitrate, with a key frame
 * (a library failure then shows there). */
srv_video_result srv_video_set_bitrate(srv_video_encoder *e, unsigned kbps, char *err,
                                       size_t err_size);
/* The size of the decoded pictures (>= desc's: see Sizes at the top). */
void srv_video_coded_size(const srv_video_encoder *e, unsigned *width, unsigned *height);
srv_video_codec srv_video_encoder_codec(const srv_video_encoder *e);

/* The conversions, shared with the tests and the benchmark so both sides agree: RGBA8 (alpha
 * ignored) to I420 in BT.601 limited range, with chroma the mean of each 2x2 block (an odd
 * last column or row averages what it has); and back, as a decoder shows it. Plane strides:
 * y_stride >= width, c_stride >= (width + 1) / 2; the Cb and Cr planes are (height + 1) / 2
 * rows. */
void srv_video_rgba_to_i420(const uint8_t *rgba, size_t stride, unsigned width, unsigned height,
                            uint8_t *y, size_t y_stride, uint8_t *cb, uint8_t *cr, size_t c_stride);
void srv_video_i420_to_rgba(const uint8_t *y, size_t y_stride, const uint8_t *cb, const uint8_t *cr,
                            size_t c_stride, unsigned width, unsigned height, uint8_t *rgba,
                            size_t stride);

#endif
