/* jpeg_dct.h: the lossy half of a baseline 4:2:0 JPEG encode on the GPU (shaders/jpeg_dct.comp).
 *
 * One compute pass turns a view's tone-mapped RGBA8 image into quantised DCT coefficients:
 * JFIF colour conversion and 2x2 chroma averaging bit exact with libjpeg, the 8x8 forward DCT in
 * float, quantisation by libjpeg's own tables for the quality (rounding half away from zero).
 * The encoders then only entropy-code (server/encode/jpeg_coefs.h), on the CPU, and the readback
 * carries 3 bytes a pixel instead of 4.
 *
 * Coefficient layout (the buffer, its host copy and libjpeg's coefficient arrays alike): three
 * planes of 8x8 blocks, 64 int16 a block in natural order (row = vertical frequency), rows of
 * blocks top to bottom: Y with 2 * mcu_cols x 2 * mcu_rows blocks, then Cb and Cr with
 * mcu_cols x mcu_rows blocks each, where an MCU is 16 x 16 pixels. Blocks past the image's last
 * block column or row are written too (libjpeg never encodes them).
 *
 * The tables come from the caller (the server asks libjpeg for them: one source of truth), for
 * every quality 1-100, uploaded once. Render thread only (this is Vulkan).
 */
#ifndef RD_JPEG_DCT_H
#define RD_JPEG_DCT_H

#include <stdbool.h>
#include <stdint.h>

#include "renderer/view.h"
#include "renderer/vk/vk_buffer.h"
#include "renderer/vk/vk_compute.h"

#define RD_JPEG_QUALITIES 100u /* qualities 1..100 */
#define RD_JPEG_MCU 16u        /* pixels across and down a 4:2:0 MCU */
#define RD_JPEG_BLOCK_BYTES 128u

/* tables[q - 1][0] luma, [1] chroma, natural order, for quality q */
typedef uint16_t rd_jpeg_tables[RD_JPEG_QUALITIES][2][64];

typedef struct rd_jpeg_dct {
    rd_pipeline pipeline;
    rd_buffer tables; /* RD_JPEG_QUALITIES x 128 uints */
} rd_jpeg_dct;

rd_vk_result rd_jpeg_dct_create(rd_vk *vk, rd_jpeg_dct *d, const rd_jpeg_tables *tables, char *err,
                                size_t errlen);
void rd_jpeg_dct_destroy(rd_vk *vk, rd_jpeg_dct *d); /* idempotent */

/* MCUs across and down, and bytes of the coefficients, of a width x height image. */
unsigned rd_jpeg_mcu_cols(unsigned width);
unsigned rd_jpeg_mcu_rows(unsigned height);
uint64_t rd_jpeg_coef_bytes(unsigned width, unsigned height);

#define RD_JPEG_MAX_SETS 8u /* qualities one pass quantises at */

/* Records the pass into c: rgba (width x height RGBA8, one uint a pixel, R in the low byte) to
 * coefs, transformed once and quantised at each of n qualities (1-100; n <= RD_JPEG_MAX_SETS):
 * set i at offset i * rd_jpeg_coef_bytes (coefs must hold n sets). A barrier before it orders
 * the pass after the commands that wrote rgba; the caller orders what reads coefs after it. */
void rd_jpeg_dct_record(const rd_jpeg_dct *d, rd_cmd *c, const rd_buffer *rgba, unsigned width,
                        unsigned height, const unsigned *qualities, unsigned n,
                        const rd_buffer *coefs);

/* Records the pass at n qualities (1..RD_JPEG_MAX_SETS) over view v's RGBA8 image (its last
 * frame, or the frame recorded before into c) into v->jpeg_coefs, set i at offset
 * i * rd_jpeg_coef_bytes; the buffer is created or grown first (waiting for the device when an
 * older one may still be read). timed: c holds the view's frame (rd_view_record), whose timer
 * then gets a "jpeg" section. */
rd_vk_result rd_jpeg_dct_record_view(const rd_jpeg_dct *d, rd_view *v, rd_cmd *c,
                                     const unsigned *qualities, unsigned n, bool timed, char *err,
                                     size_t errlen);

#endif
