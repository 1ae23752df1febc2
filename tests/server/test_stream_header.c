/* The frame header of protocol/stream.h: byte layout, round trip and rejection of bad input. */
#include <string.h>

#include "protocol/stream.h"
#include "test_util.h"

int main(void)
{
    proto_frame_header h = {
        .frame_id = 0x0102030405060708ull,
        .capture_us = 1700000000123456ull,
        .encode_us = 1700000000123999ull,
        .send_us = 1700000000124500ull,
        .version = 1,
        .view_id = 7,
        .width = 1920,
        .height = 1080,
        .input_seq = 4000000000u,
        .jpeg_size = 5,
        .quality = 90,
        .flags = PROTO_STREAM_FLAG_STILL,
    };
    uint8_t msg[PROTO_STREAM_HEADER_SIZE + 5];
    proto_frame_header_pack(&h, msg);
    memcpy(msg + PROTO_STREAM_HEADER_SIZE, "\xff\xd8jpg", 5);

    /* the documented layout, byte by byte (little-endian) */
    CHECK(memcmp(msg, "PCFR", 4) == 0);
    CHECK(msg[4] == 1 && msg[5] == 0);        /* version */
    CHECK(msg[6] == 64 && msg[7] == 0);       /* header size */
    CHECK(msg[8] == 0x08 && msg[15] == 0x01); /* frame id, LSB first */
    CHECK(msg[44] == (1920 & 0xff) && msg[45] == (1920 >> 8));
    CHECK(msg[52] == 0x00 && msg[55] == 0xee); /* 4000000000 = 0xEE6B2800 */
    CHECK(msg[56] == 5);
    CHECK(msg[60] == 90 && msg[61] == 1 && msg[62] == 0 && msg[63] == 0);

    proto_frame_header r;
    const uint8_t *jpeg = NULL;
    CHECK(proto_frame_header_unpack(msg, sizeof msg, &r, &jpeg) == PROTO_OK);
    CHECK(r.frame_id == h.frame_id && r.capture_us == h.capture_us && r.encode_us == h.encode_us);
    CHECK(r.send_us == h.send_us && r.view_id == 7 && r.width == 1920 && r.height == 1080);
    CHECK(r.input_seq == 4000000000u && r.jpeg_size == 5 && r.quality == 90 && r.flags == 1);
    CHECK(jpeg == msg + 64 && memcmp(jpeg, "\xff\xd8", 2) == 0);

    /* short, wrong magic, wrong version, truncated JPEG, small header */
    CHECK(proto_frame_header_unpack(msg, 7, &r, NULL) == PROTO_ERR_SHORT);
    CHECK(proto_frame_header_unpack(msg, 63, &r, NULL) == PROTO_ERR_SHORT);
    CHECK(proto_frame_header_unpack(msg, sizeof msg - 1, &r, NULL) == PROTO_ERR_SHORT);
    uint8_t bad[sizeof msg];
    memcpy(bad, msg, sizeof msg);
    bad[0] = 'X';
    CHECK(proto_frame_header_unpack(bad, sizeof bad, &r, NULL) == PROTO_ERR_MAGIC);
    memcpy(bad, msg, sizeof msg);
    bad[4] = 3;
    CHECK(proto_frame_header_unpack(bad, sizeof bad, &r, NULL) == PROTO_ERR_VERSION);
    bad[4] = 0;
    CHECK(proto_frame_header_unpack(bad, sizeof bad, &r, NULL) == PROTO_ERR_VERSION);
    /* version 2 (a connection with its own view) has the same layout */
    memcpy(bad, msg, sizeof msg);
    bad[4] = 2;
    CHECK(proto_frame_header_unpack(bad, sizeof bad, &r, NULL) == PROTO_OK && r.version == 2 &&
          r.view_id == 7);
    h.version = 2;
    proto_frame_header_pack(&h, bad);
    CHECK(bad[4] == 2 && bad[5] == 0);
    memcpy(bad, msg, sizeof msg);
    bad[6] = 32;
    CHECK(proto_frame_header_unpack(bad, sizeof bad, &r, NULL) == PROTO_ERR_HEADER_SIZE);

    /* a longer header (a later minor addition) is skipped by header_size */
    uint8_t longer[80 + 5];
    memcpy(longer, msg, 64);
    memset(longer + 64, 0xab, 16);
    longer[6] = 80;
    memcpy(longer + 80, "\xff\xd8jpg", 5);
    CHECK(proto_frame_header_unpack(longer, sizeof longer, &r, &jpeg) == PROTO_OK);
    CHECK(jpeg == longer + 80);
    CHECK(strcmp(proto_strerror(PROTO_ERR_MAGIC), "ok") != 0);

    /* a VP9 key frame (byte 62: format; flag bit 1: key); an unknown format is refused */
    h.version = 2;
    h.format = PROTO_FORMAT_VP9;
    h.quality = 0;
    h.flags = PROTO_STREAM_FLAG_KEY;
    proto_frame_header_pack(&h, msg);
    CHECK(msg[61] == 2 && msg[62] == 2 && msg[63] == 0);
    CHECK(proto_frame_header_unpack(msg, sizeof msg, &r, NULL) == PROTO_OK);
    CHECK(r.format == PROTO_FORMAT_VP9 && (r.flags & PROTO_STREAM_FLAG_KEY) && r.quality == 0);
    msg[62] = PROTO_FORMAT_COUNT;
    CHECK(proto_frame_header_unpack(msg, sizeof msg, &r, NULL) == PROTO_ERR_FORMAT);
    CHECK(strcmp(proto_format_name(PROTO_FORMAT_VP9), "vp9") == 0 && !proto_format_name(3));
    return test_finish();
}
