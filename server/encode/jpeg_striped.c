/* jpeg_striped.c: stripes encoded with libjpeg(-turbo), joined with restart markers. */
#include "server/encode/jpeg_striped.h"

#include <setjmp.h>
#include <stdbool.h>
#include <stdio.h> /* jpeglib.h needs FILE and size_t first */
#include <stdlib.h>
#include <string.h>

#include <jerror.h>
#include <jpeglib.h>

const char *srv_jpeg_strerror(srv_jpeg_result r)
{
    switch (r) {
    case SRV_JPEG_OK:
        return "ok";
    case SRV_JPEG_ERR_ARGS:
        return "invalid image size, stripe or quality";
    case SRV_JPEG_ERR_ENCODE:
        return "JPEG encoding failed";
    case SRV_JPEG_ERR_FORMAT:
        return "a stripe is not the baseline JPEG its plan expects";
    case SRV_JPEG_ERR_MISMATCH:
        return "stripes were encoded with different tables";
    case SRV_JPEG_ERR_SPACE:
        return "output buffer too small";
    }
    return "unknown JPEG error";
}

/* ---- the plan ------------------------------------------------------------------------------- */

srv_jpeg_result srv_jpeg_plan_make(srv_jpeg_plan *plan, unsigned width, unsigned height,
                                   unsigned stripes, unsigned min_mcu_rows)
{
    memset(plan, 0, sizeof *plan);
    if (width == 0 || height == 0 || width > SRV_JPEG_MAX_SIDE || height > SRV_JPEG_MAX_SIDE)
        return SRV_JPEG_ERR_ARGS;
    unsigned mcu_cols = (width + SRV_JPEG_MCU - 1) / SRV_JPEG_MCU;
    unsigned mcu_rows = (height + SRV_JPEG_MCU - 1) / SRV_JPEG_MCU;
    unsigned n = stripes ? stripes : 1;
    unsigned most = mcu_rows / (min_mcu_rows ? min_mcu_rows : 1);
    if (n > most) n = most ? most : 1;
    unsigned rows_per = (mcu_rows + n - 1) / n; /* MCU rows in a stripe */
    unsigned rows_max = 65535u / mcu_cols;      /* a restart interval counts at most 65535 MCUs */
    if (rows_per > rows_max) rows_per = rows_max;
    n = (mcu_rows + rows_per - 1) / rows_per;

    plan->width = width;
    plan->height = height;
    plan->stripe_count = n;
    plan->stripe_height = n == 1 ? height : rows_per * SRV_JPEG_MCU;
    plan->restart_interval = n == 1 ? 0 : rows_per * mcu_cols;
    return SRV_JPEG_OK;
}

unsigned srv_jpeg_stripe_y(const srv_jpeg_plan *plan, unsigned i)
{
    return i * plan->stripe_height;
}

unsigned srv_jpeg_stripe_rows(const srv_jpeg_plan *plan, unsigned i)
{
    unsigned y = i * plan->stripe_height;
    if (i >= plan->stripe_count || y >= plan->height) return 0;
    return plan->height - y < plan->stripe_height ? plan->height - y : plan->stripe_height;
}

void srv_jpeg_buf_free(srv_jpeg_buf *b)
{
    free(b->data);
    memset(b, 0, sizeof *b);
}

/* ---- the encoder ---------------------------------------------------------------------------- */

struct srv_jpeg_encoder {
    struct jpeg_compress_struct cinfo;
    struct jpeg_error_mgr jerr;
    struct jpeg_destination_mgr dest;
    jmp_buf jmp;
    srv_jpeg_buf *out; /* the buffer of the encode under way */
    char message[JMSG_LENGTH_MAX];
};

static void on_error_exit(j_common_ptr cinfo)
{
    srv_jpeg_encoder *e = cinfo->client_data;
    cinfo->err->format_message(cinfo, e->message);
    longjmp(e->jmp, 1);
}

static void on_output_message(j_common_ptr cinfo)
{
    (void)cinfo; /* warnings (corrupt-data notes) concern decoders; never print to stderr */
}

void srv_jpeg_buf_reserve(srv_jpeg_buf *b, size_t need)
{
    if (b->cap >= need) return;
    size_t cap = b->cap ? b->cap : 4096;
    while (cap < need)
        cap *= 2;
    uint8_t *p = realloc(b->data, cap);
    if (!p) abort(); /* out of memory */
    b->data = p;
    b->cap = cap;
}

static void dest_init(j_compress_ptr cinfo)
{
    srv_jpeg_encoder *e = cinfo->client_data;
    e->dest.next_output_byte = e->out->data;
    e->dest.free_in_buffer = e->out->cap;
}

/* libjpeg calls this with the whole buffer full: double it and go on after the old end. */
static boolean dest_empty(j_compress_ptr cinfo)
{
    srv_jpeg_encoder *e = cinfo->client_data;
    size_t used = e->out->cap;
    srv_jpeg_buf_reserve(e->out, 2 * used);
    e->dest.next_output_byte = e->out->data + used;
    e->dest.free_in_buffer = e->out->cap - used;
    return TRUE;
}

static void dest_term(j_compress_ptr cinfo)
{
    srv_jpeg_encoder *e = cinfo->client_data;
    e->out->size = e->out->cap - e->dest.free_in_buffer;
}

srv_jpeg_encoder *srv_jpeg_encoder_create(void)
{
    srv_jpeg_encoder *e = calloc(1, sizeof *e);
    if (!e) abort();
    e->cinfo.err = jpeg_std_error(&e->jerr);
    e->jerr.error_exit = on_error_exit;
    e->jerr.output_message = on_output_message;
    e->cinfo.client_data = e;
    if (setjmp(e->jmp)) abort(); /* jpeg_create_compress fails only when out of memory */
    jpeg_create_compress(&e->cinfo);
    e->dest.init_destination = dest_init;
    e->dest.empty_output_buffer = dest_empty;
    e->dest.term_destination = dest_term;
    e->cinfo.dest = &e->dest;
    return e;
}

void srv_jpeg_encoder_destroy(srv_jpeg_encoder *e)
{
    if (!e) return;
    jpeg_destroy_compress(&e->cinfo);
    free(e);
}

const char *srv_jpeg_encoder_error(const srv_jpeg_encoder *e)
{
    return e->message;
}

typedef struct rgba_job {
    const uint8_t *rgba;
    unsigned width, height, quality, restart_interval;
    size_t stride;
} rgba_job;

/* RGBA rows in, with tjCompress2's TJSAMP_420 | TJFLAG_FASTDCT settings. */
static void feed_rgba(struct jpeg_compress_struct *c, void *user)
{
    const rgba_job *j = user;
    c->image_width = j->width;
    c->image_height = j->height;
    c->input_components = 4;
    c->in_color_space = JCS_EXT_RGBA;
    jpeg_set_defaults(c); /* YCbCr, JFIF, standard Huffman tables, no optimize_coding */
    jpeg_set_quality(c, (int)j->quality, TRUE);
    /* what tjCompress2 picks for TJFLAG_FASTDCT (it switches to the accurate DCT from q96 on) */
    c->dct_method = j->quality >= 96 ? JDCT_ISLOW : JDCT_IFAST;
    c->comp_info[0].h_samp_factor = 2;
    c->comp_info[0].v_samp_factor = 2;
    for (int i = 1; i < 3; i++)
        c->comp_info[i].h_samp_factor = c->comp_info[i].v_samp_factor = 1;
    c->restart_interval = j->restart_interval;
    jpeg_start_compress(c, TRUE);
    while (c->next_scanline < c->image_height) {
        JSAMPROW rows[32];
        unsigned n = c->image_height - c->next_scanline;
        if (n > 32) n = 32;
        for (unsigned k = 0; k < n; k++)
            rows[k] = (JSAMPROW)(j->rgba + (size_t)(c->next_scanline + k) * j->stride);
        jpeg_write_scanlines(c, rows, n);
    }
    jpeg_finish_compress(c);
}

srv_jpeg_result srv_jpeg_encode(srv_jpeg_encoder *e, const uint8_t *rgba, unsigned width,
                                unsigned height, size_t stride, unsigned quality,
                                unsigned restart_interval, srv_jpeg_buf *out)
{
    e->message[0] = '\0';
    if (width == 0 || height == 0 || width > SRV_JPEG_MAX_SIDE || height > SRV_JPEG_MAX_SIDE ||
        quality < 1 || quality > 100 || restart_interval > 65535u || stride < (size_t)width * 4)
        return SRV_JPEG_ERR_ARGS;
    rgba_job j = {.rgba = rgba,
                  .width = width,
                  .height = height,
                  .quality = quality,
                  .restart_interval = restart_interval,
                  .stride = stride};
    /* a first guess that fits most frames (JPEG at q90 is well under a byte a pixel) */
    return srv_jpeg_encoder_run(e, out, (size_t)width * height / 2 + 2048, feed_rgba, &j);
}

srv_jpeg_result srv_jpeg_encoder_run(srv_jpeg_encoder *e, srv_jpeg_buf *out, size_t reserve,
                                     void (*feed)(struct jpeg_compress_struct *cinfo, void *user),
                                     void *user)
{
    e->message[0] = '\0';
    srv_jpeg_buf_reserve(out, reserve);
    out->size = 0;
    e->out = out;
    if (setjmp(e->jmp)) {
        jpeg_abort_compress(&e->cinfo);
        e->out = NULL;
        return SRV_JPEG_ERR_ENCODE;
    }
    feed(&e->cinfo, user);
    e->out = NULL;
    return SRV_JPEG_OK;
}

srv_jpeg_result srv_jpeg_encode_stripe(srv_jpeg_encoder *e, const srv_jpeg_plan *plan,
                                       const uint8_t *rgba, unsigned quality, unsigned index,
                                       srv_jpeg_buf *out)
{
    unsigned rows = srv_jpeg_stripe_rows(plan, index);
    if (rows == 0) return SRV_JPEG_ERR_ARGS;
    size_t stride = (size_t)plan->width * 4;
    return srv_jpeg_encode(e, rgba + srv_jpeg_stripe_y(plan, index) * stride, plan->width, rows,
                           stride, quality, plan->restart_interval, out);
}

/* ---- joining -------------------------------------------------------------------------------- */

/* Where the parts of one stripe lie. */
typedef struct stripe_parts {
    size_t header_end; /* just after the SOS segment: the entropy-coded data starts here */
    size_t data_end;   /* the EOI marker */
    size_t sof_height; /* offset of the SOF0 height field */
} stripe_parts;

static unsigned be16(const uint8_t *p)
{
    return (unsigned)p[0] << 8 | p[1];
}

/* Walks the marker segments of a stripe up to SOS (APPn, COM and table segments are skipped by
 * their lengths), checks that it is a 3-component baseline frame of width x rows with the plan's
 * restart interval, then finds the EOI that ends its entropy-coded data (0xFF00 is a stuffed
 * byte and 0xFFFF fill; any other marker there means the stripe was more than one interval). */
static srv_jpeg_result parse_stripe(const uint8_t *b, size_t n, unsigned width, unsigned rows,
                                    unsigned restart, stripe_parts *out)
{
    if (n < 4 || b[0] != 0xFF || b[1] != 0xD8) return SRV_JPEG_ERR_FORMAT;
    size_t pos = 2;
    bool sof = false;
    unsigned dri = 0;
    for (;;) {
        if (pos >= n || b[pos] != 0xFF) return SRV_JPEG_ERR_FORMAT;
        while (pos < n && b[pos] == 0xFF)
            pos++;
        if (pos >= n) return SRV_JPEG_ERR_FORMAT;
        unsigned m = b[pos++];
        /* standalone markers (SOI, EOI, RSTn, TEM) have no place before SOS */
        if (m == 0x00 || m == 0x01 || (m >= 0xD0 && m <= 0xD9)) return SRV_JPEG_ERR_FORMAT;
        if (pos + 2 > n) return SRV_JPEG_ERR_FORMAT;
        size_t len = be16(b + pos);
        if (len < 2 || pos + len > n) return SRV_JPEG_ERR_FORMAT;
        const uint8_t *seg = b + pos + 2; /* the segment's payload, len - 2 bytes */
        if (m == 0xC0) {                  /* SOF0: P Y X Nf, then 3 bytes a component */
            if (sof || len != 8 + 3 * 3 || seg[0] != 8 || be16(seg + 1) != rows ||
                be16(seg + 3) != width || seg[5] != 3)
                return SRV_JPEG_ERR_FORMAT;
            sof = true;
            out->sof_height = pos + 3;
        } else if (m >= 0xC1 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC) {
            return SRV_JPEG_ERR_FORMAT; /* progressive, lossless, arithmetic...: not ours */
        } else if (m == 0xDD) {         /* DRI */
            if (len != 4) return SRV_JPEG_ERR_FORMAT;
            dri = be16(seg);
        } else if (m == 0xDA) { /* SOS */
            if (!sof || dri != restart) return SRV_JPEG_ERR_FORMAT;
            out->header_end = pos + len;
            break;
        }
        pos += len;
    }
    for (size_t p = out->header_end;;) {
        const uint8_t *ff = p < n ? memchr(b + p, 0xFF, n - p) : NULL;
        if (!ff || ff + 1 >= b + n) return SRV_JPEG_ERR_FORMAT; /* no EOI */
        size_t at = (size_t)(ff - b);
        if (ff[1] == 0x00) {
            p = at + 2;
        } else if (ff[1] == 0xFF) {
            p = at + 1;
        } else if (ff[1] == 0xD9) {
            out->data_end = at;
            return SRV_JPEG_OK;
        } else {
            return SRV_JPEG_ERR_FORMAT;
        }
    }
}

size_t srv_jpeg_join_bound(const srv_jpeg_plan *plan, const srv_jpeg_buf *stripes)
{
    /* the output holds the first header, every entropy segment and one 2-byte marker per stripe
     * (RSTm or EOI): never more than the stripes with their own SOI, headers and EOI */
    size_t sum = 0;
    for (unsigned i = 0; i < plan->stripe_count; i++)
        sum += stripes[i].size;
    return sum;
}

srv_jpeg_result srv_jpeg_join(const srv_jpeg_plan *plan, const srv_jpeg_buf *stripes, uint8_t *dst,
                              size_t cap, size_t *size)
{
    *size = 0;
    if (plan->stripe_count == 0) return SRV_JPEG_ERR_ARGS;
    stripe_parts first = {0};
    size_t pos = 0;
    for (unsigned i = 0; i < plan->stripe_count; i++) {
        const srv_jpeg_buf *s = &stripes[i];
        stripe_parts parts = {0};
        srv_jpeg_result r =
            parse_stripe(s->data, s->size, plan->width, srv_jpeg_stripe_rows(plan, i),
                         plan->restart_interval, &parts);
        if (r != SRV_JPEG_OK) return r;
        if (i == 0) {
            first = parts;
            if (cap < parts.header_end) return SRV_JPEG_ERR_SPACE;
            memcpy(dst, s->data, parts.header_end);
            dst[parts.sof_height] = (uint8_t)(plan->height >> 8);
            dst[parts.sof_height + 1] = (uint8_t)plan->height;
            pos = parts.header_end;
        } else {
            /* the same tables: headers equal but for the SOF0 height */
            const uint8_t *h0 = stripes[0].data;
            if (parts.header_end != first.header_end || parts.sof_height != first.sof_height ||
                memcmp(s->data, h0, parts.sof_height) != 0 ||
                memcmp(s->data + parts.sof_height + 2, h0 + parts.sof_height + 2,
                       parts.header_end - parts.sof_height - 2) != 0)
                return SRV_JPEG_ERR_MISMATCH;
            if (cap - pos < 2) return SRV_JPEG_ERR_SPACE;
            dst[pos++] = 0xFF;
            dst[pos++] = (uint8_t)(0xD0 + ((i - 1) & 7)); /* RST0 follows the first interval */
        }
        size_t len = parts.data_end - parts.header_end;
        if (cap - pos < len) return SRV_JPEG_ERR_SPACE;
        memcpy(dst + pos, s->data + parts.header_end, len);
        pos += len;
    }
    if (cap - pos < 2) return SRV_JPEG_ERR_SPACE;
    dst[pos++] = 0xFF;
    dst[pos++] = 0xD9;
    *size = pos;
    return SRV_JPEG_OK;
}
