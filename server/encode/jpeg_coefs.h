/* jpeg_coefs.h: JPEGs entropy-coded from DCT coefficients the GPU computed.
 *
 * renderer/encode/jpeg_dct.h runs colour conversion, chroma subsampling, the DCT and quantisation on
 * the GPU; what is left for the CPU is libjpeg's entropy coder (its transcoding API,
 * jpeg_write_coefficients, with the standard Huffman tables): about half the CPU time of a whole
 * libjpeg-turbo encode of the pixels (tests/bench/results/h100/jpeg_gpu.txt). Stripes work as in
 * jpeg_striped.h: each stripe of a plan is encoded on its own with a restart interval of one
 * stripe and srv_jpeg_join makes them one JPEG.
 *
 * Coefficients are quantised at one quality: every quality a frame is sent at (the lag-driven
 * lower variants of encoder_pool.h) is its own GPU pass. Requantising one set on the CPU was
 * tried and dropped: rounding twice cost up to 1.2 dB and made JPEGs up to a third larger than a
 * direct encode at the lower quality (test_gpu_jpeg, tables one step apart: q80 -> q60).
 */
#ifndef SRV_JPEG_COEFS_H
#define SRV_JPEG_COEFS_H

#include <stdint.h>

#include "server/encode/jpeg_striped.h"
#include "renderer/encode/jpeg_dct.h"

/* The quantisation tables libjpeg uses at quality (jpeg_set_quality, baseline), natural order:
 * tables[0] luma, tables[1] chroma. */
void srv_jpeg_quant_tables(unsigned quality, uint16_t tables[2][64]);
/* The JPEG pass (rd_jpeg_dct_create) with these tables for every quality 1-100. */
rd_vk_result srv_jpeg_dct_create(rd_vk *vk, rd_jpeg_dct *d, char *err, size_t errlen);

/* One frame's coefficients in renderer/encode/jpeg_dct.h's layout (rd_jpeg_coef_bytes bytes). */
typedef struct srv_jpeg_coefs {
    const int16_t *blocks;
    unsigned width, height;
    unsigned quality; /* the quality they were quantised at */
} srv_jpeg_coefs;

/* Entropy-codes stripe `index` of the plan (made for coefs' width and height; one stripe: the
 * whole frame without restart markers) at coefs->quality into out (grown as needed, out->size
 * set). The blocks are read where they lie (no copy). */
srv_jpeg_result srv_jpeg_encode_coefs(srv_jpeg_encoder *e, const srv_jpeg_plan *plan,
                                      const srv_jpeg_coefs *coefs, unsigned index,
                                      srv_jpeg_buf *out);

#endif
