/* stream.h: the binary frame message of the WebSocket stream (/v1/stream), versions 1 and 2.
 *
 * Every binary message the server sends is one frame: a little-endian header of
 * header_size bytes (64) followed by exactly jpeg_size bytes of payload: baseline JPEG, or one
 * VP9/VP8 packet (format) for a version-2 viewer that asked for video. Versions 1 and 2
 * share the layout; the version is the connection's protocol version (2: each connection owns a
 * view and view_id says which one a frame shows; 1: everybody shares view 0).
 * Readers skip header_size bytes, so later versions may append fields without breaking them;
 * the version changes only when a field's meaning does. protocol/stream.md is the prose spec.
 *
 *   offset size field
 *        0    4 magic        "PCFR" (0x50 0x43 0x46 0x52)
 *        4    2 version      1 or 2
 *        6    2 header_size  64
 *        8    8 frame_id     increases with every frame the server produces (over all views)
 *       16    8 capture_us   when rendering of the frame began (Unix time, microseconds)
 *       24    8 encode_us    when its JPEG encoding finished (Unix time, microseconds)
 *       32    8 send_us      when the server began sending it (Unix time, microseconds)
 *       40    4 view_id      the view the frame shows (0: the default view)
 *       44    4 width        pixels
 *       48    4 height       pixels
 *       52    4 input_seq    the last "seq" of this client's camera messages that the frame
 *                            reflects (0 before the first one)
 *       56    4 jpeg_size    bytes of the payload (JPEG, or one video packet) after the header
 *       60    1 quality      JPEG quality 1..100 (0 for a video packet)
 *       61    1 flags        bit 0: still (full quality, input has stopped);
 *                            bit 1: key frame (a video packet decodable on its own)
 *       62    1 format       0 JPEG, 1 VP8, 2 VP9 (version 2; never other than 0 for a viewer
 *                            that did not ask for video, so version 1 and JPEG-only viewers
 *                            see the same bytes as before)
 *       63    1 reserved     0
 */
#ifndef PROTO_STREAM_H
#define PROTO_STREAM_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define PROTO_STREAM_MAGIC "PCFR"
#define PROTO_STREAM_VERSION 2u     /* the newest version */
#define PROTO_STREAM_VERSION_MIN 1u /* the oldest still spoken */
#define PROTO_STREAM_HEADER_SIZE 64u
#define PROTO_STREAM_FLAG_STILL 1u
#define PROTO_STREAM_FLAG_KEY 2u

/* The payload's format (byte 62). AV1 is left out of the live stream: SVT-AV1 1.4.1 holds each
 * packet back a frame and cannot force key frames in low-delay mode (video_encoder.h). */
typedef enum proto_format {
    PROTO_FORMAT_JPEG = 0,
    PROTO_FORMAT_VP8 = 1,
    PROTO_FORMAT_VP9 = 2,
} proto_format;
#define PROTO_FORMAT_COUNT 3u

/* "jpeg", "vp8", "vp9" (NULL for anything else). */
const char *proto_format_name(unsigned format);

typedef struct proto_frame_header {
    uint16_t version;
    uint16_t header_size;
    uint64_t frame_id;
    uint64_t capture_us, encode_us, send_us;
    uint32_t view_id;
    uint32_t width, height;
    uint32_t input_seq;
    uint32_t jpeg_size; /* payload bytes (JPEG or video packet) */
    uint8_t quality;
    uint8_t flags;
    uint8_t format; /* proto_format */
} proto_frame_header;

typedef enum proto_result {
    PROTO_OK = 0,
    PROTO_ERR_SHORT,       /* fewer bytes than the header (or than header + jpeg_size) */
    PROTO_ERR_MAGIC,       /* not a probecast frame */
    PROTO_ERR_VERSION,     /* a version this code does not read */
    PROTO_ERR_HEADER_SIZE, /* header_size smaller than version 1's */
    PROTO_ERR_FORMAT,      /* a payload format this code does not read */
} proto_result;

const char *proto_strerror(proto_result r);

/* Writes the header (PROTO_STREAM_HEADER_SIZE bytes) for h into out with h->version (1 or 2;
 * anything else writes PROTO_STREAM_VERSION); header_size is always 64. */
void proto_frame_header_pack(const proto_frame_header *h, uint8_t out[PROTO_STREAM_HEADER_SIZE]);

/* Reads a frame message of len bytes. On success fills h and points *jpeg at the JPEG bytes
 * inside msg (h->jpeg_size of them). jpeg may be NULL. */
proto_result proto_frame_header_unpack(const uint8_t *msg, size_t len, proto_frame_header *h,
                                       const uint8_t **jpeg);

#endif
