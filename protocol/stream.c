/* stream.c: packing of the frame header of protocol/stream.h (explicit little-endian, so the
 * layout does not depend on the host or on struct padding). */
#include "protocol/stream.h"

#include <string.h>

const char *proto_strerror(proto_result r)
{
    switch (r) {
    case PROTO_OK:
        return "ok";
    case PROTO_ERR_SHORT:
        return "message shorter than its header or declared JPEG size";
    case PROTO_ERR_MAGIC:
        return "not a probecast frame (bad magic)";
    case PROTO_ERR_VERSION:
        return "unsupported frame header version";
    case PROTO_ERR_HEADER_SIZE:
        return "frame header size too small";
    case PROTO_ERR_FORMAT:
        return "unknown payload format";
    }
    return "unknown error";
}

const char *proto_format_name(unsigned format)
{
    static const char *const names[PROTO_FORMAT_COUNT] = {"jpeg", "vp8", "vp9"};
    return format < PROTO_FORMAT_COUNT ? names[format] : NULL;
}

static void put16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}

static void put32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static void put64(uint8_t *p, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static uint16_t get16(const uint8_t *p)
{
    return (uint16_t)(p[0] | (p[1] << 8));
}

static uint32_t get32(const uint8_t *p)
{
    uint32_t v = 0;
    for (int i = 3; i >= 0; i--)
        v = (v << 8) | p[i];
    return v;
}

static uint64_t get64(const uint8_t *p)
{
    uint64_t v = 0;
    for (int i = 7; i >= 0; i--)
        v = (v << 8) | p[i];
    return v;
}

void proto_frame_header_pack(const proto_frame_header *h, uint8_t out[PROTO_STREAM_HEADER_SIZE])
{
    memset(out, 0, PROTO_STREAM_HEADER_SIZE);
    memcpy(out, PROTO_STREAM_MAGIC, 4);
    put16(out + 4, h->version >= PROTO_STREAM_VERSION_MIN && h->version <= PROTO_STREAM_VERSION
                       ? h->version
                       : PROTO_STREAM_VERSION);
    put16(out + 6, PROTO_STREAM_HEADER_SIZE);
    put64(out + 8, h->frame_id);
    put64(out + 16, h->capture_us);
    put64(out + 24, h->encode_us);
    put64(out + 32, h->send_us);
    put32(out + 40, h->view_id);
    put32(out + 44, h->width);
    put32(out + 48, h->height);
    put32(out + 52, h->input_seq);
    put32(out + 56, h->jpeg_size);
    out[60] = h->quality;
    out[61] = h->flags;
    out[62] = h->format;
}

proto_result proto_frame_header_unpack(const uint8_t *msg, size_t len, proto_frame_header *h,
                                       const uint8_t **jpeg)
{
    memset(h, 0, sizeof *h);
    if (len < 8) return PROTO_ERR_SHORT;
    if (memcmp(msg, PROTO_STREAM_MAGIC, 4) != 0) return PROTO_ERR_MAGIC;
    h->version = get16(msg + 4);
    h->header_size = get16(msg + 6);
    if (h->version < PROTO_STREAM_VERSION_MIN || h->version > PROTO_STREAM_VERSION)
        return PROTO_ERR_VERSION;
    if (h->header_size < PROTO_STREAM_HEADER_SIZE) return PROTO_ERR_HEADER_SIZE;
    if (len < h->header_size) return PROTO_ERR_SHORT;
    h->frame_id = get64(msg + 8);
    h->capture_us = get64(msg + 16);
    h->encode_us = get64(msg + 24);
    h->send_us = get64(msg + 32);
    h->view_id = get32(msg + 40);
    h->width = get32(msg + 44);
    h->height = get32(msg + 48);
    h->input_seq = get32(msg + 52);
    h->jpeg_size = get32(msg + 56);
    h->quality = msg[60];
    h->flags = msg[61];
    h->format = msg[62];
    if (h->format >= PROTO_FORMAT_COUNT) return PROTO_ERR_FORMAT;
    if (len - h->header_size < h->jpeg_size) return PROTO_ERR_SHORT;
    if (jpeg) *jpeg = msg + h->header_size;
    return PROTO_OK;
}
