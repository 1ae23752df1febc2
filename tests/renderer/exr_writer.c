/* exr_writer.c: see exr_writer.h. */
#include "exr_writer.h"

#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct membuf {
    uint8_t *d;
    size_t n, cap;
} membuf;

/* pwrite into the growing buffer */
static int64_t mem_write(exr_const_context_t ctxt, void *user, const void *buffer, uint64_t size,
                         uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
    (void)ctxt;
    (void)error_cb;
    membuf *m = user;
    size_t end = (size_t)(offset + size);
    if (end > m->cap) {
        m->cap = end * 2;
        m->d = realloc(m->d, m->cap);
        if (!m->d) abort();
    }
    if (offset > m->n) memset(m->d + m->n, 0, (size_t)offset - m->n);
    memcpy(m->d + offset, buffer, (size_t)size);
    if (end > m->n) m->n = end;
    return (int64_t)size;
}

/* IEEE binary16 bits of f, rounded to nearest even (exact for representable values). */
static uint16_t half_bits(float f)
{
    uint32_t x;
    memcpy(&x, &f, sizeof x);
    uint32_t sign = (x >> 16) & 0x8000u, exp = (x >> 23) & 0xffu, mant = x & 0x7fffffu;
    if (exp == 255) return (uint16_t)(sign | 0x7c00u | (mant ? 0x200u : 0));
    int e = (int)exp - 127 + 15;
    if (e >= 31) return (uint16_t)(sign | 0x7c00u);
    if (e <= 0) { /* subnormal: units of 2^-24 */
        if (e < -10) return (uint16_t)sign;
        uint32_t m = mant | 0x800000u, shift = (uint32_t)(14 - e);
        uint32_t h = m >> shift, rem = m & ((1u << shift) - 1), mid = 1u << (shift - 1);
        if (rem > mid || (rem == mid && (h & 1))) h++;
        return (uint16_t)(sign | h);
    }
    uint32_t h = sign | ((uint32_t)e << 10) | (mant >> 13), rem = mant & 0x1fffu;
    if (rem > 0x1000u || (rem == 0x1000u && (h & 1))) h++;
    return (uint16_t)h;
}

static bool ok(exr_result_t rv, const char *what)
{
    if (rv != EXR_ERR_SUCCESS)
        fprintf(stderr, "exr_writer: %s: %s\n", what, exr_get_default_error_message(rv));
    return rv == EXR_ERR_SUCCESS;
}

/* Encodes the chunk ci whose top-left pixel is (x0, y0) of the data window. */
static bool encode(exr_context_t ctxt, exr_encode_pipeline_t *enc, bool *ready,
                   const exr_chunk_info_t *ci, const pc_exr_desc *d, const char *const *names,
                   int nch, const uint8_t *planes, size_t bpe, uint32_t x0, uint32_t y0)
{
    size_t npix = (size_t)d->width * d->height;
    if (!ok(*ready ? exr_encoding_update(ctxt, 0, ci, enc)
                   : exr_encoding_initialize(ctxt, 0, ci, enc),
            "encoding setup"))
        return false;
    *ready = true;
    for (int i = 0; i < enc->channel_count; i++) {
        exr_coding_channel_info_t *c = &enc->channels[i];
        int k = 0;
        while (k < nch && strcmp(names[k], c->channel_name) != 0)
            k++;
        if (k == nch) return ok(EXR_ERR_INVALID_ARGUMENT, "channel lookup");
        c->encode_from_ptr = planes + ((size_t)k * npix + (size_t)y0 * d->width + x0) * bpe;
        c->user_pixel_stride = (int32_t)bpe;
        c->user_line_stride = (int32_t)(d->width * bpe);
        c->user_bytes_per_element = (int16_t)bpe;
        c->user_data_type = (uint16_t)d->type;
    }
    return ok(exr_encoding_choose_default_routines(ctxt, 0, enc), "encoding routines") &&
           ok(exr_encoding_run(ctxt, 0, enc), "encoding");
}

uint8_t *pc_exr_write(const pc_exr_desc *d, size_t *size)
{
    static const char *const rgb[3] = {"R", "G", "B"};
    int nch = d->channel_count ? d->channel_count : 3;
    const char *const *names = d->channel_count ? d->channels : rgb;
    size_t bpe = d->type == EXR_PIXEL_HALF ? 2 : 4, npix = (size_t)d->width * d->height;
    /* one plane per channel in the file's pixel type */
    uint8_t *planes = malloc(npix * bpe * (size_t)nch);
    if (!planes) abort();
    for (int c = 0; c < nch; c++)
        for (size_t i = 0; i < npix; i++) {
            float v = d->pixels[i * (size_t)nch + (size_t)c];
            uint8_t *p = planes + ((size_t)c * npix + i) * bpe;
            if (d->type == EXR_PIXEL_HALF) {
                uint16_t h = half_bits(v);
                memcpy(p, &h, 2);
            } else if (d->type == EXR_PIXEL_UINT) {
                uint32_t u = (uint32_t)v;
                memcpy(p, &u, 4);
            } else {
                memcpy(p, &v, 4);
            }
        }

    membuf m = {0};
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.user_data = &m;
    init.write_fn = mem_write;
    exr_context_t ctxt = NULL;
    int part = 0;
    bool good =
        ok(exr_start_write(&ctxt, "test.exr", EXR_WRITE_FILE_DIRECTLY, &init), "start") &&
        ok(exr_add_part(ctxt, NULL, d->tile ? EXR_STORAGE_TILED : EXR_STORAGE_SCANLINE, &part),
           "part");
    exr_attr_box2i_t dw, disp;
    dw.min.x = d->x;
    dw.min.y = d->y;
    dw.max.x = d->x + (int32_t)d->width - 1;
    dw.max.y = d->y + (int32_t)d->height - 1;
    disp = dw;
    if (d->display_width) {
        disp.min.x = d->display_x;
        disp.min.y = d->display_y;
        disp.max.x = d->display_x + (int32_t)d->display_width - 1;
        disp.max.y = d->display_y + (int32_t)d->display_height - 1;
    }
    exr_attr_v2f_t centre;
    centre.x = centre.y = 0;
    good = good && ok(exr_initialize_required_attr(ctxt, part, &disp, &dw, 1.0f, &centre, 1.0f,
                                                   EXR_LINEORDER_INCREASING_Y, d->compression),
                      "required attributes");
    if (good && d->tile)
        good = ok(exr_set_tile_descriptor(ctxt, part, d->tile, d->tile, EXR_TILE_ONE_LEVEL,
                                          EXR_TILE_ROUND_DOWN),
                  "tiles");
    for (int c = 0; good && c < nch; c++)
        good =
            ok(exr_add_channel(ctxt, part, names[c], d->type, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1),
               "channel");
    good = good && ok(exr_write_header(ctxt), "header");

    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    bool ready = false;
    exr_chunk_info_t ci;
    if (good && d->tile) {
        for (uint32_t ty = 0; good && ty * d->tile < d->height; ty++)
            for (uint32_t tx = 0; good && tx * d->tile < d->width; tx++)
                good = ok(exr_write_tile_chunk_info(ctxt, part, (int)tx, (int)ty, 0, 0, &ci),
                          "tile") &&
                       encode(ctxt, &enc, &ready, &ci, d, names, nch, planes, bpe, tx * d->tile,
                              ty * d->tile);
    } else if (good) {
        int32_t lines = 1;
        good = ok(exr_get_scanlines_per_chunk(ctxt, part, &lines), "lines");
        for (uint32_t y = 0; good && y < d->height; y += (uint32_t)lines)
            good = ok(exr_write_scanline_chunk_info(ctxt, part, d->y + (int)y, &ci), "scanline") &&
                   encode(ctxt, &enc, &ready, &ci, d, names, nch, planes, bpe, 0, y);
    }
    if (ready) exr_encoding_destroy(ctxt, &enc);
    if (ctxt) good = ok(exr_finish(&ctxt), "finish") && good;
    free(planes);
    if (!good) {
        free(m.d);
        return NULL;
    }
    *size = m.n;
    return m.d;
}

float pc_exr_test_texel(unsigned x, unsigned y, int c)
{
    return c == 0   ? 0.25f * (float)x + 0.125f
           : c == 1 ? 2.0f + (float)y
                    : 1.0f / (float)(1u << ((x + y) % 8));
}

float *pc_exr_test_pixels(unsigned w, unsigned h, int channels)
{
    float *p = malloc((size_t)w * h * (size_t)channels * sizeof *p);
    if (!p) abort();
    for (unsigned y = 0; y < h; y++)
        for (unsigned x = 0; x < w; x++)
            for (int c = 0; c < channels; c++)
                p[((size_t)y * w + x) * (size_t)channels + (size_t)c] =
                    c < 3 ? pc_exr_test_texel(x, y, c) : 7.0f;
    return p;
}
