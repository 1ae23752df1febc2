/* jpeg_coefs.c: entropy coding of GPU coefficients with libjpeg's transcoding API. */
#include "server/encode/jpeg_coefs.h"

#include <stdio.h> /* jpeglib.h needs FILE and size_t first */
#include <stdlib.h>
#include <string.h>

#include <jpeglib.h>

_Static_assert(sizeof(JCOEF) == 2 && sizeof(JBLOCK) == RD_JPEG_BLOCK_BYTES,
               "libjpeg blocks of 64 int16");
_Static_assert(RD_JPEG_MCU == SRV_JPEG_MCU, "one MCU size");

void srv_jpeg_quant_tables(unsigned quality, uint16_t tables[2][64])
{
    struct jpeg_compress_struct c;
    struct jpeg_error_mgr e;
    c.err = jpeg_std_error(&e);
    jpeg_create_compress(&c);
    c.in_color_space = JCS_RGB;
    c.input_components = 3;
    jpeg_set_defaults(&c);
    jpeg_set_quality(&c, (int)quality, TRUE); /* what tjCompress2 and srv_jpeg_encode do */
    for (int t = 0; t < 2; t++)
        for (int k = 0; k < 64; k++)
            tables[t][k] = c.quant_tbl_ptrs[t]->quantval[k]; /* natural order */
    jpeg_destroy_compress(&c);
}

rd_vk_result srv_jpeg_dct_create(rd_vk *vk, rd_jpeg_dct *d, char *err, size_t errlen)
{
    rd_jpeg_tables *tables = malloc(sizeof *tables); /* 25 KiB: not on the stack */
    if (!tables) abort();
    for (unsigned q = 1; q <= RD_JPEG_QUALITIES; q++)
        srv_jpeg_quant_tables(q, (*tables)[q - 1]);
    rd_vk_result r = rd_jpeg_dct_create(vk, d, tables, err, errlen);
    free(tables);
    return r;
}

/* What feed_rows encodes: image rows [y0, y0 + rows) (y0 a multiple of 16) of the frame's
 * coefficient planes. */
typedef struct rows_job {
    unsigned width, mcu_cols; /* the frame's */
    const JBLOCK *planes[3];
    unsigned y0, rows, quality, restart;
} rows_job;

/* libjpeg's coefficient arrays for the rows are requested and realised as jpegtran's are, then
 * their block-row pointers are pointed at the planes (whose layout is the arrays'):
 * access_virt_barray of an array held in memory returns the array's own row-pointer table, so
 * jpeg_write_coefficients reads the blocks where they lie, without a copy. libjpeg writes dummy
 * blocks past the image's last block column and row itself. */
static void feed_rows(struct jpeg_compress_struct *ci, void *user)
{
    const rows_job *job = user;
    ci->image_width = job->width;
    ci->image_height = job->rows;
    ci->input_components = 3;
    ci->in_color_space = JCS_RGB;
    jpeg_set_defaults(ci); /* YCbCr 4:2:0, JFIF, standard Huffman tables, no optimize_coding */
    jpeg_set_quality(ci, (int)job->quality, TRUE);
    ci->restart_interval = job->restart;

    unsigned mcu_y0 = job->y0 / SRV_JPEG_MCU, mcu_n = (job->rows + SRV_JPEG_MCU - 1) / SRV_JPEG_MCU;
    jvirt_barray_ptr arrays[3];
    for (int k = 0; k < 3; k++) {
        unsigned s = k == 0 ? 2 : 1; /* blocks an MCU across and down */
        arrays[k] = ci->mem->request_virt_barray((j_common_ptr)ci, JPOOL_IMAGE, FALSE,
                                                 job->mcu_cols * s, mcu_n * s, mcu_n * s);
    }
    ci->mem->realize_virt_arrays((j_common_ptr)ci);
    for (int k = 0; k < 3; k++) {
        unsigned s = k == 0 ? 2 : 1, across = job->mcu_cols * s;
        JBLOCKARRAY r =
            ci->mem->access_virt_barray((j_common_ptr)ci, arrays[k], 0, mcu_n * s, TRUE);
        for (unsigned i = 0; i < mcu_n * s; i++)
            r[i] = (JBLOCKROW)(job->planes[k] + (size_t)(mcu_y0 * s + i) * across);
    }
    jpeg_write_coefficients(ci, arrays);
    jpeg_finish_compress(ci);
}

srv_jpeg_result srv_jpeg_encode_coefs(srv_jpeg_encoder *e, const srv_jpeg_plan *plan,
                                      const srv_jpeg_coefs *coefs, unsigned index,
                                      srv_jpeg_buf *out)
{
    unsigned rows = srv_jpeg_stripe_rows(plan, index);
    if (rows == 0 || coefs->quality < 1 || coefs->quality > 100 || plan->width != coefs->width ||
        plan->height != coefs->height)
        return SRV_JPEG_ERR_ARGS;
    unsigned cols = rd_jpeg_mcu_cols(coefs->width);
    size_t chroma = (size_t)cols * rd_jpeg_mcu_rows(coefs->height); /* blocks in a plane */
    const JBLOCK *all = (const JBLOCK *)coefs->blocks;
    rows_job job = {.width = coefs->width,
                    .mcu_cols = cols,
                    .planes = {all, all + 4 * chroma, all + 5 * chroma},
                    .y0 = srv_jpeg_stripe_y(plan, index),
                    .rows = rows,
                    .quality = coefs->quality,
                    .restart = plan->restart_interval};
    return srv_jpeg_encoder_run(e, out, (size_t)coefs->width * rows / 2 + 2048, feed_rows, &job);
}
