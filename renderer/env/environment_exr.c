/* environment_exr.c: the OpenEXR reader of environment images, through OpenEXRCore (the C API
 * of OpenEXR 3) reading the uploaded bytes in memory. Each chunk (a block of scanlines or a
 * tile) is decoded to float planes of its own and copied with explicit bounds into a stripe of
 * full-width display rows (the block's rows, or a row of tiles), so nothing the file declares
 * can write outside it; each finished stripe goes row by row into the reduction
 * (environment_reduce.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <openexr.h>

#include "renderer/env/environment.h"
#include "renderer/env/environment_reduce.h"

/* OpenEXRCore's allocations, counted into the reading thread's decode (its hooks take no user
 * pointer). */
static _Thread_local rd_env_mem *exr_mem;

static void *exr_alloc(size_t bytes)
{
    return rd_env_mem_alloc(exr_mem, bytes, false);
}

static void exr_free(void *p)
{
    rd_env_mem_free(exr_mem, p);
}

/* The uploaded bytes as an OpenEXR stream, and the library's first error message. */
typedef struct exr_source {
    const uint8_t *data;
    size_t len;
    char message[160];
} exr_source;

static int64_t source_read(exr_const_context_t ctxt, void *user, void *buffer, uint64_t size,
                           uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
    (void)ctxt;
    (void)error_cb;
    const exr_source *s = user;
    if (offset >= s->len) return 0; /* a short read: the library reports the truncation */
    uint64_t n = s->len - offset < size ? s->len - offset : size;
    memcpy(buffer, s->data + offset, (size_t)n);
    return (int64_t)n;
}

static int64_t source_size(exr_const_context_t ctxt, void *user)
{
    (void)ctxt;
    return (int64_t)((const exr_source *)user)->len;
}

/* Keeps the first message (the cause; later ones wrap it) instead of printing to stderr. */
static void source_error(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    void *user = NULL;
    if (exr_get_user_data(ctxt, &user) != EXR_ERR_SUCCESS || !user) return;
    exr_source *s = user;
    if (!s->message[0])
        snprintf(s->message, sizeof s->message, "%s",
                 msg ? msg : exr_get_error_code_as_string(code));
}

static bool fail_lib(const exr_source *s, exr_result_t rv, const char *what, char *err,
                     size_t errlen)
{
    snprintf(err, errlen, "the EXR file's %s cannot be read (%s)", what,
             s->message[0]           ? s->message
             : rv != EXR_ERR_SUCCESS ? exr_get_default_error_message(rv)
                                     : "it is inconsistent");
    return false;
}

/* Where the decoded colour comes from: channel[c] is the index (in the header's channel list) of
 * R, G and B, or all three that of Y for a luminance image. */
typedef struct exr_layout {
    int channel[3];
} exr_layout;

/* Chooses the colour channels, or explains in err why the image has none we read. */
static bool choose_channels(const exr_attr_chlist_t *chl, exr_layout *lay, char *err, size_t errlen)
{
    static const char *const rgb[3] = {"R", "G", "B"};
    int y = -1, chroma = -1;
    for (int c = 0; c < 3; c++)
        lay->channel[c] = -1;
    for (int i = 0; i < chl->num_channels; i++) {
        const char *name = chl->entries[i].name.str;
        for (int c = 0; c < 3; c++)
            if (strcmp(name, rgb[c]) == 0) lay->channel[c] = i;
        if (strcmp(name, "Y") == 0) y = i;
        if (strcmp(name, "RY") == 0 || strcmp(name, "BY") == 0) chroma = i;
    }
    int found = (lay->channel[0] >= 0) + (lay->channel[1] >= 0) + (lay->channel[2] >= 0);
    if (found == 0 && y >= 0 && chroma < 0) {
        lay->channel[0] = lay->channel[1] = lay->channel[2] = y; /* grey */
    } else if (found == 0 && chroma >= 0) {
        snprintf(err, errlen,
                 "the EXR image is stored as luminance and chroma (Y, RY, BY), which is not "
                 "read; save it with R, G and B channels");
        return false;
    } else if (found < 3) {
        char names[96] = "";
        for (int i = 0; i < chl->num_channels && strlen(names) < 60; i++)
            snprintf(names + strlen(names), sizeof names - strlen(names), "%s%.20s", i ? ", " : "",
                     chl->entries[i].name.str);
        snprintf(err, errlen,
                 "the EXR image has no R, G and B channels (nor a lone Y) in its default layer; "
                 "it has %s",
                 chl->num_channels ? names : "no channels");
        return false;
    }
    for (int c = 0; c < 3; c++) {
        const exr_attr_chlist_entry_t *e = &chl->entries[lay->channel[c]];
        if (e->x_sampling != 1 || e->y_sampling != 1) {
            snprintf(err, errlen,
                     "the EXR channel %.20s is subsampled (%dx%d); only full-resolution channels "
                     "are read",
                     e->name.str, e->x_sampling, e->y_sampling);
            return false;
        }
    }
    return true;
}

/* The reading of one part, the size of its display window, into the reduction. */
typedef struct exr_reader {
    exr_context_t ctxt;
    exr_source *src;
    exr_layout lay;
    exr_attr_box2i_t display;
    uint32_t width, height; /* of the display window */
    rd_env_mem *mem;
    rd_env_reducer red;
    exr_decode_pipeline_t dec;
    bool dec_ready;
    float *planes; /* scratch: three planes of the chunk */
    size_t planes_cap;
    float *stripe; /* full-width display rows: those of one block of scanlines or row of tiles */
    size_t stripe_cap;
    int64_t stripe_y; /* the file row of the stripe's first row */
    uint32_t stripe_rows;
    float *black; /* one row of zeros: display rows the data window misses */
} exr_reader;

/* Makes the stripe rows [y, y + rows) of the file (zeroed: black where no chunk lands); false
 * with a sentence in err when they would take more than RD_ENV_MAX_STRIPE_BYTES. */
static bool stripe_begin(exr_reader *r, int64_t y, uint64_t rows, const char *what, char *err,
                         size_t errlen)
{
    uint64_t n = rows * r->width * 3;
    if (n * sizeof(float) > RD_ENV_MAX_STRIPE_BYTES) {
        snprintf(err, errlen,
                 "the EXR file's %s spans %llu rows of %u pixels, more than %llu MiB decoded; "
                 "save it with smaller tiles or chunks",
                 what, (unsigned long long)rows, r->width,
                 (unsigned long long)(RD_ENV_MAX_STRIPE_BYTES >> 20));
        return false;
    }
    if (n > r->stripe_cap) {
        rd_env_mem_free(r->mem, r->stripe);
        r->stripe_cap = (size_t)n;
        r->stripe = rd_env_mem_alloc(r->mem, r->stripe_cap * sizeof *r->stripe, false);
    }
    if (n) memset(r->stripe, 0, (size_t)n * sizeof *r->stripe);
    r->stripe_y = y;
    r->stripe_rows = (uint32_t)rows;
    return true;
}

/* Pushes the display rows before the stripe (black: the data window misses them) and the
 * stripe's rows inside the display window; rows already pushed are not pushed again. */
static void stripe_end(exr_reader *r)
{
    int64_t first = r->stripe_y - r->display.min.y;
    for (int64_t i = 0; i < r->stripe_rows; i++) {
        int64_t iy = first + i;
        if (iy < 0 || iy >= (int64_t)r->height) continue;
        while ((int64_t)r->red.rows < iy) /* black rows before the stripe */
            rd_env_reducer_push(&r->red, r->black);
        if ((int64_t)r->red.rows == iy)
            rd_env_reducer_push(&r->red, r->stripe + (size_t)i * r->width * 3);
    }
}

/* Decodes one chunk whose top-left pixel is (x0, y0) in the file's pixel space and copies the
 * part of it inside the display window's columns and the stripe's rows. */
static bool read_chunk(exr_reader *r, const exr_chunk_info_t *ci, int64_t x0, int64_t y0,
                       const char *what, char *err, size_t errlen)
{
    exr_result_t rv;
    uint64_t cw = ci->width > 0 ? (uint64_t)ci->width : 0;
    uint64_t ch = ci->height > 0 ? (uint64_t)ci->height : 0;
    if (cw == 0 || ch == 0 || cw > RD_ENV_MAX_DIM || ch > RD_ENV_MAX_DIM ||
        cw * ch * 3 * sizeof(float) > RD_ENV_MAX_BYTES) {
        snprintf(err, errlen, "the EXR file's %s has an impossible size (%dx%d)", what, ci->width,
                 ci->height);
        return false;
    }
    if (cw * ch * 3 * sizeof(float) > RD_ENV_MAX_STRIPE_BYTES ||
        ci->unpacked_size > RD_ENV_MAX_CHUNK_BYTES) {
        snprintf(err, errlen,
                 "the EXR file's %s (%dx%d pixels, %llu MiB unpacked) is too large to decode "
                 "(at most %llu MiB of colour or %llu MiB unpacked); save it with smaller tiles "
                 "or chunks",
                 what, ci->width, ci->height, (unsigned long long)(ci->unpacked_size >> 20),
                 (unsigned long long)(RD_ENV_MAX_STRIPE_BYTES >> 20),
                 (unsigned long long)(RD_ENV_MAX_CHUNK_BYTES >> 20));
        return false;
    }
    size_t pixels = (size_t)(cw * ch);
    if (pixels * 3 > r->planes_cap) {
        rd_env_mem_free(r->mem, r->planes);
        r->planes_cap = pixels * 3;
        r->planes = rd_env_mem_alloc(r->mem, r->planes_cap * sizeof *r->planes, false);
    }
    if (!r->dec_ready) {
        rv = exr_decoding_initialize(r->ctxt, 0, ci, &r->dec);
        if (rv != EXR_ERR_SUCCESS) return fail_lib(r->src, rv, what, err, errlen);
        r->dec_ready = true;
    } else {
        rv = exr_decoding_update(r->ctxt, 0, ci, &r->dec);
        if (rv != EXR_ERR_SUCCESS) return fail_lib(r->src, rv, what, err, errlen);
    }
    /* each wanted channel into its own float plane; the others are skipped */
    unsigned planes = 0;
    for (int i = 0; i < r->dec.channel_count; i++) {
        exr_coding_channel_info_t *c = &r->dec.channels[i];
        c->decode_to_ptr = NULL;
        for (int p = 0; p < 3; p++)
            if (r->lay.channel[p] == i && !c->decode_to_ptr) {
                if ((uint64_t)c->width != cw || (uint64_t)c->height != ch) {
                    snprintf(err, errlen, "the EXR file's %s has a channel of another size", what);
                    return false;
                }
                c->decode_to_ptr = (uint8_t *)(r->planes + (size_t)p * pixels);
                c->user_data_type = EXR_PIXEL_FLOAT;
                c->user_bytes_per_element = (int16_t)sizeof(float);
                c->user_pixel_stride = (int32_t)sizeof(float);
                c->user_line_stride = (int32_t)(cw * sizeof(float));
                planes |= 1u << p;
            }
    }
    /* a grey image decodes Y into plane 0 only */
    int plane_of[3] = {0, r->lay.channel[1] == r->lay.channel[0] ? 0 : 1,
                       r->lay.channel[2] == r->lay.channel[0] ? 0 : 2};
    for (int c = 0; c < 3; c++)
        if (!(planes & (1u << plane_of[c]))) {
            snprintf(err, errlen, "the EXR file's %s lacks a colour channel of its header", what);
            return false;
        }
    rv = exr_decoding_choose_default_routines(r->ctxt, 0, &r->dec);
    if (rv == EXR_ERR_SUCCESS) rv = exr_decoding_run(r->ctxt, 0, &r->dec);
    if (rv != EXR_ERR_SUCCESS) return fail_lib(r->src, rv, what, err, errlen);

    for (uint64_t y = 0; y < ch; y++) {
        int64_t sy = y0 + (int64_t)y - r->stripe_y;
        if (sy < 0 || sy >= (int64_t)r->stripe_rows) continue;
        for (uint64_t x = 0; x < cw; x++) {
            int64_t ix = x0 + (int64_t)x - r->display.min.x;
            if (ix < 0 || ix >= (int64_t)r->width) continue;
            float *t = r->stripe + ((size_t)sy * r->width + (size_t)ix) * 3;
            for (int c = 0; c < 3; c++) {
                float v = r->planes[(size_t)plane_of[c] * pixels + y * cw + x];
                t[c] = v > 0.0f && isfinite(v) ? v : 0.0f; /* NaN, infinities, negatives */
            }
        }
    }
    return true;
}

static bool read_scanlines(exr_reader *r, const exr_attr_box2i_t *dw, char *err, size_t errlen)
{
    int32_t lines = 0;
    exr_result_t rv = exr_get_scanlines_per_chunk(r->ctxt, 0, &lines);
    if (rv != EXR_ERR_SUCCESS || lines < 1) return fail_lib(r->src, rv, "layout", err, errlen);
    for (int64_t y = dw->min.y; y <= dw->max.y; y += lines) {
        char what[48];
        snprintf(what, sizeof what, "scanline %lld", (long long)y);
        exr_chunk_info_t ci;
        rv = exr_read_scanline_chunk_info(r->ctxt, 0, (int)y, &ci);
        if (rv != EXR_ERR_SUCCESS) return fail_lib(r->src, rv, what, err, errlen);
        if (!stripe_begin(r, ci.start_y, ci.height > 0 ? (uint64_t)ci.height : 0, what, err,
                          errlen) ||
            !read_chunk(r, &ci, dw->min.x, ci.start_y, what, err, errlen))
            return false;
        stripe_end(r);
    }
    return true;
}

/* Level 0 of a tiled part (the full resolution of a mipmap or ripmap). */
static bool read_tiles(exr_reader *r, const exr_attr_box2i_t *dw, char *err, size_t errlen)
{
    uint32_t tw = 0, th = 0;
    exr_tile_level_mode_t level;
    exr_tile_round_mode_t round;
    int32_t lw = 0, lh = 0;
    exr_result_t rv = exr_get_tile_descriptor(r->ctxt, 0, &tw, &th, &level, &round);
    if (rv == EXR_ERR_SUCCESS) rv = exr_get_level_sizes(r->ctxt, 0, 0, 0, &lw, &lh);
    if (rv != EXR_ERR_SUCCESS || tw == 0 || th == 0 || lw < 1 || lh < 1)
        return fail_lib(r->src, rv, "tile layout", err, errlen);
    uint32_t nx = (uint32_t)(((uint64_t)lw + tw - 1) / tw);
    uint32_t ny = (uint32_t)(((uint64_t)lh + th - 1) / th);
    for (uint32_t ty = 0; ty < ny; ty++) {
        char what[48];
        snprintf(what, sizeof what, "tile row %u", ty);
        int64_t y0 = dw->min.y + (int64_t)ty * th;
        uint64_t rows =
            (uint64_t)lh - (uint64_t)ty * th < th ? (uint64_t)lh - (uint64_t)ty * th : th;
        if (!stripe_begin(r, y0, rows, what, err, errlen)) return false;
        for (uint32_t tx = 0; tx < nx; tx++) {
            snprintf(what, sizeof what, "tile %u,%u", tx, ty);
            exr_chunk_info_t ci;
            rv = exr_read_tile_chunk_info(r->ctxt, 0, (int)tx, (int)ty, 0, 0, &ci);
            if (rv != EXR_ERR_SUCCESS) return fail_lib(r->src, rv, what, err, errlen);
            if (!read_chunk(r, &ci, dw->min.x + (int64_t)tx * tw, y0, what, err, errlen))
                return false;
        }
        stripe_end(r);
    }
    return true;
}

/* Checks what the header declares, then reads the pixels of part 0 into img, reduced under
 * max_width. */
static bool read_part(exr_reader *r, uint32_t max_width, rd_env_image *img, char *err,
                      size_t errlen)
{
    int parts = 0;
    exr_storage_t storage;
    exr_result_t rv = exr_get_count(r->ctxt, &parts);
    if (rv != EXR_ERR_SUCCESS) return fail_lib(r->src, rv, "header", err, errlen);
    if (parts != 1) {
        snprintf(err, errlen,
                 "the EXR file has %d parts; only single-part images are read (save one part)",
                 parts);
        return false;
    }
    rv = exr_get_storage(r->ctxt, 0, &storage);
    if (rv != EXR_ERR_SUCCESS) return fail_lib(r->src, rv, "header", err, errlen);
    if (storage != EXR_STORAGE_SCANLINE && storage != EXR_STORAGE_TILED) {
        snprintf(err, errlen, "the EXR image holds deep data; only flat images are read");
        return false;
    }
    const exr_attr_chlist_t *chl = NULL;
    exr_attr_box2i_t dw;
    rv = exr_get_channels(r->ctxt, 0, &chl);
    if (rv == EXR_ERR_SUCCESS) rv = exr_get_data_window(r->ctxt, 0, &dw);
    if (rv == EXR_ERR_SUCCESS) rv = exr_get_display_window(r->ctxt, 0, &r->display);
    if (rv != EXR_ERR_SUCCESS) return fail_lib(r->src, rv, "header", err, errlen);
    if (!choose_channels(chl, &r->lay, err, errlen)) return false;
    int64_t w = (int64_t)r->display.max.x - r->display.min.x + 1;
    int64_t h = (int64_t)r->display.max.y - r->display.min.y + 1;
    int64_t dw_w = (int64_t)dw.max.x - dw.min.x + 1, dw_h = (int64_t)dw.max.y - dw.min.y + 1;
    if (!rd_env_image_size_ok(w < 0 ? 0 : (uint64_t)w, h < 0 ? 0 : (uint64_t)h, "EXR", err, errlen))
        return false;
    if (dw_w < 1 || dw_h < 1 || dw_w > RD_ENV_MAX_DIM || dw_h > RD_ENV_MAX_DIM) {
        snprintf(err, errlen, "the EXR data window %lldx%lld is out of range (1..%u per side)",
                 (long long)dw_w, (long long)dw_h, RD_ENV_MAX_DIM);
        return false;
    }
    r->width = (uint32_t)w;
    r->height = (uint32_t)h;
    rd_env_reducer_init(&r->red, r->width, r->height, max_width, r->mem, img);
    r->black = rd_env_mem_alloc(r->mem, (size_t)r->width * 3 * sizeof *r->black, true);
    bool ok = storage == EXR_STORAGE_TILED ? read_tiles(r, &dw, err, errlen)
                                           : read_scanlines(r, &dw, err, errlen);
    while (ok && r->red.rows < r->height) /* black rows below the data window */
        rd_env_reducer_push(&r->red, r->black);
    return ok;
}

bool rd_env_image_parse_exr(const uint8_t *data, size_t len, rd_env_read_desc *desc,
                            rd_env_image *out, char *err, size_t errlen)
{
    memset(out, 0, sizeof *out);
    if (desc) desc->peak_bytes = 0;
    if (rd_env_image_format(data, len) != RD_ENV_FORMAT_EXR) {
        snprintf(err, errlen, "not an OpenEXR file (it must begin with the bytes 76 2f 31 01)");
        return false;
    }
    exr_source src = {.data = data, .len = len};
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = source_error;
    init.user_data = &src;
    init.read_fn = source_read;
    init.size_fn = source_size;
    init.max_image_width = init.max_image_height = (int)RD_ENV_MAX_DIM;
    init.max_tile_width = init.max_tile_height = (int)RD_ENV_MAX_DIM;
    /* a damaged chunk table is an error, not a search through the file for chunks */
    init.flags = EXR_CONTEXT_FLAG_DISABLE_CHUNK_RECONSTRUCTION;
    rd_env_mem mem = {0};
    init.alloc_fn = exr_alloc;
    init.free_fn = exr_free;
    exr_mem = &mem;
    exr_reader r = {.src = &src, .mem = &mem};
    exr_result_t rv = exr_start_read(&r.ctxt, "upload.exr", &init);
    bool ok = rv == EXR_ERR_SUCCESS ? read_part(&r, desc ? desc->max_width : 0, out, err, errlen)
                                    : fail_lib(&src, rv, "header", err, errlen);
    if (r.dec_ready) exr_decoding_destroy(r.ctxt, &r.dec);
    if (r.ctxt) exr_finish(&r.ctxt);
    exr_mem = NULL;
    rd_env_mem_free(&mem, r.planes);
    rd_env_mem_free(&mem, r.stripe);
    rd_env_mem_free(&mem, r.black);
    rd_env_reducer_dispose(&r.red);
    if (desc) desc->peak_bytes = mem.peak;
    if (!ok) rd_env_image_free(out);
    return ok;
}
