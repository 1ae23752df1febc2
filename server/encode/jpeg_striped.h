/* jpeg_striped.h: one baseline JPEG encoded in horizontal stripes, on as many threads as stripes.
 *
 * The image is cut into stripes whose heights are a multiple of the 4:2:0 MCU height (16 rows),
 * except the last. Each stripe is encoded on its own with the libjpeg API (libjpeg-turbo) at the
 * same quality, 4:2:0, the fast DCT and the standard Huffman tables, with a restart interval of
 * exactly one stripe. Joining keeps the first stripe's headers (its SOF0 given the full height),
 * then every stripe's entropy-coded data with RSTm markers between them, then EOI: the result is
 * byte for byte what one encode of the whole image with that restart interval gives, and it
 * decodes to the same pixels as tjCompress2(TJSAMP_420, TJFLAG_FASTDCT) of the image.
 *
 * Use: srv_jpeg_plan_make, then srv_jpeg_encode_stripe for each index (any thread, any order,
 * each into its own buffer, one encoder per thread), then srv_jpeg_join once all are done.
 */
#ifndef SRV_JPEG_STRIPED_H
#define SRV_JPEG_STRIPED_H

#include <stddef.h>
#include <stdint.h>

#define SRV_JPEG_MCU 16u         /* rows (and columns) of a 4:2:0 MCU */
#define SRV_JPEG_MAX_SIDE 65500u /* the largest width or height libjpeg accepts */

typedef enum srv_jpeg_result {
    SRV_JPEG_OK = 0,
    SRV_JPEG_ERR_ARGS,     /* empty or oversized image, stripe index out of range, bad quality */
    SRV_JPEG_ERR_ENCODE,   /* libjpeg reported an error (srv_jpeg_encoder_error says which) */
    SRV_JPEG_ERR_FORMAT,   /* a stripe is not the JPEG its plan promises */
    SRV_JPEG_ERR_MISMATCH, /* stripes differ in their tables (encoded at other settings) */
    SRV_JPEG_ERR_SPACE,    /* the output buffer is too small (see srv_jpeg_join_bound) */
} srv_jpeg_result;

const char *srv_jpeg_strerror(srv_jpeg_result r);

/* How an image is cut. Stripe i covers rows [i * stripe_height, min(h, (i + 1) * stripe_height)).
 */
typedef struct srv_jpeg_plan {
    unsigned width, height;
    unsigned stripe_count;
    unsigned stripe_height;    /* rows of every stripe but the last (a multiple of 16 when > 1) */
    unsigned restart_interval; /* MCUs in one full stripe; 0 with a single stripe */
} srv_jpeg_plan;

/* Cuts width x height into at most `stripes` stripes (0 = 1) of equal height in whole MCU rows,
 * the last one shorter. Fewer stripes come out when the image has fewer MCU rows, or when an even
 * split would leave a stripe with fewer than min_mcu_rows MCU rows (0 = 1); more when a stripe
 * would exceed the 65535 MCUs a restart interval can hold. */
srv_jpeg_result srv_jpeg_plan_make(srv_jpeg_plan *plan, unsigned width, unsigned height,
                                   unsigned stripes, unsigned min_mcu_rows);
/* First row and row count of stripe i. */
unsigned srv_jpeg_stripe_y(const srv_jpeg_plan *plan, unsigned i);
unsigned srv_jpeg_stripe_rows(const srv_jpeg_plan *plan, unsigned i);

/* A growable output buffer (malloc'd; data may be NULL while cap is 0). Reuse it across encodes. */
typedef struct srv_jpeg_buf {
    uint8_t *data;
    size_t size, cap;
} srv_jpeg_buf;

void srv_jpeg_buf_free(srv_jpeg_buf *b); /* frees data, zeroes b */
/* Grows b's capacity to at least need bytes (doubling; aborts when out of memory). */
void srv_jpeg_buf_reserve(srv_jpeg_buf *b, size_t need);

/* A libjpeg compressor, reused from encode to encode. Not thread-safe: one per thread. */
typedef struct srv_jpeg_encoder srv_jpeg_encoder;

srv_jpeg_encoder *srv_jpeg_encoder_create(void);    /* aborts when out of memory */
void srv_jpeg_encoder_destroy(srv_jpeg_encoder *e); /* NULL is fine */
/* libjpeg's message for the encoder's last SRV_JPEG_ERR_ENCODE ("" if none). */
const char *srv_jpeg_encoder_error(const srv_jpeg_encoder *e);

/* Encodes width x height RGBA8 pixels (rows `stride` bytes apart, top row first) as a baseline
 * 4:2:0 JPEG into out (grown as needed, out->size set) with the given restart interval in MCUs
 * (0: none). The settings are tjCompress2's for TJSAMP_420 | TJFLAG_FASTDCT: the fast integer
 * DCT below quality 96, the accurate one from 96 on, standard Huffman tables, a JFIF header. */
srv_jpeg_result srv_jpeg_encode(srv_jpeg_encoder *e, const uint8_t *rgba, unsigned width,
                                unsigned height, size_t stride, unsigned quality,
                                unsigned restart_interval, srv_jpeg_buf *out);
/* Runs feed(cinfo, user) with e's libjpeg compressor writing into out (grown as needed from
 * `reserve` bytes, out->size set): feed sets the image up and drives libjpeg from
 * jpeg_set_defaults to jpeg_finish_compress, for input other than RGBA rows (the GPU JPEG
 * benchmark's coefficients, tests/bench/jpeg_gpu.c). A libjpeg error inside feed ends it and
 * gives SRV_JPEG_ERR_ENCODE (srv_jpeg_encoder_error says which). */
struct jpeg_compress_struct;
srv_jpeg_result srv_jpeg_encoder_run(srv_jpeg_encoder *e, srv_jpeg_buf *out, size_t reserve,
                                     void (*feed)(struct jpeg_compress_struct *cinfo, void *user),
                                     void *user);
/* Encodes stripe `index` of the plan; rgba is the whole image (plan->width * 4 bytes a row). */
srv_jpeg_result srv_jpeg_encode_stripe(srv_jpeg_encoder *e, const srv_jpeg_plan *plan,
                                       const uint8_t *rgba, unsigned quality, unsigned index,
                                       srv_jpeg_buf *out);

/* Bytes that srv_jpeg_join needs at most for these stripes (the sum of their sizes). */
size_t srv_jpeg_join_bound(const srv_jpeg_plan *plan, const srv_jpeg_buf *stripes);
/* Joins plan->stripe_count encoded stripes, in order, into one JPEG in dst (cap bytes); *size is
 * its length. Checks that every stripe is a baseline JPEG of its stripe's size and restart
 * interval with the same tables as the first, and that its entropy-coded data holds no marker. */
srv_jpeg_result srv_jpeg_join(const srv_jpeg_plan *plan, const srv_jpeg_buf *stripes, uint8_t *dst,
                              size_t cap, size_t *size);

#endif
