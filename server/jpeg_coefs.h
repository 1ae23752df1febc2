/* jpeg_coefs.h: JPEGs entropy-coded from DCT coefficients the GPU computed.
 *
 * renderer/jpeg_dct.h runs colour conversion, chroma subsampling, the DCT and quantisation on
 * the GPU; what is left for the CPU is libjpeg's entropy coder (its transcoding API,
 * jpeg_write_coefficients, with the standard Huffman tables): about half the CPU time of a whole
 * libjpeg-turbo encode of the pixels (tests/bench/results/h100/jpeg_gpu.txt). Stripes work as in
 * jpeg_striped.h: each stripe of a plan is encoded on its own with a restart interval of one
 * stripe and srv_jpeg_join makes them one JPEG.
 *
 * A frame's coefficients are quantised at one quality; another quality (the lag-driven lower
 * variants, encoder_pool.h) requantises them on the CPU first: each coefficient c becomes
 * round(c * Q1 / Q2), half away from zero. That rounds twice, so such a variant can differ from
 * a direct encode at its quality by one step in some coefficients (tested: PSNR within 0.5 dB).
 */
#ifndef SRV_JPEG_COEFS_H
#define SRV_JPEG_COEFS_H

#include <stdint.h>

#include "jpeg_striped.h"
#include "renderer/jpeg_dct.h"

/* The quantisation tables libjpeg uses at quality (jpeg_set_quality, baseline), natural order:
 * tables[0] luma, tables[1] chroma. */
void srv_jpeg_quant_tables(unsigned quality, uint16_t tables[2][64]);
/* The same for every quality 1-100 (for rd_jpeg_dct_create). */
void srv_jpeg_quant_tables_all(rd_jpeg_tables *tables);

/* One frame's coefficients in renderer/jpeg_dct.h's layout (rd_jpeg_coef_bytes bytes). */
typedef struct srv_jpeg_coefs {
    const int16_t *blocks;
    unsigned width, height;
    unsigned quality; /* the quality they were quantised at */
} srv_jpeg_coefs;

/* Entropy-codes stripe `index` of the plan (made for coefs' width and height; one stripe: the
 * whole frame without restart markers) at quality (1-100) into out (grown as needed, out->size
 * set). A quality other than coefs->quality requantises the stripe's blocks into scratch
 * (grown as needed; reuse it). */
srv_jpeg_result srv_jpeg_encode_coefs(srv_jpeg_encoder *e, const srv_jpeg_plan *plan,
                                      const srv_jpeg_coefs *coefs, unsigned quality,
                                      unsigned index, srv_jpeg_buf *scratch, srv_jpeg_buf *out);

#endif
