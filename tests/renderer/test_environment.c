/* test_environment.c: the environment models against analytic values: the Radiance .hdr reader
 * (flat and run-length scanlines decode to the written values; broken files are refused with a
 * message, and random mutations never crash it), the OpenEXR reader (files written by
 * OpenEXRCore's writer decode to exactly the values written, broken ones are refused with a
 * message), the reduction as they decode (bit for bit a full decode reduced by
 * rd_env_image_limit, for odd sizes, tiles and windows; a 32768-wide file holds tens of MiB, not
 * the GiB of its declared size) and the SH9 irradiance (exact for uniform and gradient skies,
 * within 1-2% for images of the same functions). */
#include <math.h>
#include <stdio.h>
#include <sys/resource.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/environment.h"
#include "renderer/exr_writer.h"
#include "test_util.h"

#define PI_F 3.14159265358979323846f

/* RGBE of a float colour (Ward's encoding). */
static void to_rgbe(const float c[3], uint8_t out[4])
{
    float m = fmaxf(c[0], fmaxf(c[1], c[2]));
    if (m < 1e-32f) {
        memset(out, 0, 4);
        return;
    }
    int e;
    float f = frexpf(m, &e) * 256.0f / m;
    for (int i = 0; i < 3; i++)
        out[i] = (uint8_t)(c[i] * f);
    out[3] = (uint8_t)(e + 128);
}

/* The test image's texel colour. */
static void texel(unsigned x, unsigned y, float c[3])
{
    c[0] = 0.25f + 0.5f * (float)x;
    c[1] = 1.0f / (1.0f + (float)y);
    c[2] = (x + y) % 3 == 0 ? 0.0f : 4.0f;
}

typedef struct buf {
    uint8_t *d;
    size_t n, cap;
} buf;

static void put(buf *b, const void *p, size_t n)
{
    if (b->n + n > b->cap) {
        b->cap = (b->n + n) * 2;
        b->d = realloc(b->d, b->cap);
        if (!b->d) abort();
    }
    memcpy(b->d + b->n, p, n);
    b->n += n;
}

/* Texels of many magnitudes and full mantissas, whose 2x2 sums round: a reduction that adds
 * in another order than rd_env_image_limit gives other floats. */
static uint32_t noise(uint32_t x, uint32_t y, uint32_t c)
{
    uint32_t h = x * 0x9e3779b1u ^ y * 0x85ebca77u ^ c * 0xc2b2ae3du;
    h ^= h >> 15;
    h *= 0x2c1b3c6du;
    h ^= h >> 12;
    return h;
}

static void noisy_texel(unsigned x, unsigned y, float c[3])
{
    for (uint32_t i = 0; i < 3; i++) {
        uint32_t h = noise(x, y, i);
        c[i] = ldexpf(1.0f + (float)(h & 0xffffff) / 16777216.0f, (int)(h >> 24) % 16 - 8);
    }
}

/* A .hdr of w x h texels (texel() unless given); rle: new-style run-length scanlines (runs of
 * equal bytes are written as runs, others as literals). */
static buf make_hdr_of(unsigned w, unsigned h, bool rle, void (*tex)(unsigned, unsigned, float[3]));

static buf make_hdr(unsigned w, unsigned h, bool rle)
{
    return make_hdr_of(w, h, rle, texel);
}

static buf make_hdr_of(unsigned w, unsigned h, bool rle, void (*tex)(unsigned, unsigned, float[3]))
{
    buf b = {0};
    char head[128];
    int k = snprintf(head, sizeof head,
                     "#?RADIANCE\n# a comment\nFORMAT=32-bit_rle_rgbe\nEXPOSURE=1\n\n-Y %u +X %u\n",
                     h, w);
    put(&b, head, (size_t)k);
    uint8_t *line = malloc((size_t)w * 4);
    for (unsigned y = 0; y < h; y++) {
        for (unsigned x = 0; x < w; x++) {
            float c[3];
            tex(x, y, c);
            to_rgbe(c, line + x * 4);
        }
        if (!rle) {
            put(&b, line, (size_t)w * 4);
            continue;
        }
        uint8_t mark[4] = {2, 2, (uint8_t)(w >> 8), (uint8_t)(w & 255)};
        put(&b, mark, 4);
        for (int c = 0; c < 4; c++) {
            unsigned x = 0;
            while (x < w) {
                unsigned run = 1;
                while (x + run < w && run < 127 && line[(x + run) * 4 + c] == line[x * 4 + c])
                    run++;
                if (run >= 3) {
                    uint8_t r[2] = {(uint8_t)(128 + run), line[x * 4 + c]};
                    put(&b, r, 2);
                    x += run;
                } else {
                    unsigned lit = 0;
                    while (x + lit < w && lit < 128) {
                        unsigned same = 1;
                        while (x + lit + same < w && same < 3 &&
                               line[(x + lit + same) * 4 + c] == line[(x + lit) * 4 + c])
                            same++;
                        if (same >= 3) break;
                        lit++;
                    }
                    uint8_t n = (uint8_t)lit;
                    put(&b, &n, 1);
                    for (unsigned i = 0; i < lit; i++)
                        put(&b, &line[(x + i) * 4 + c], 1);
                    x += lit;
                }
            }
        }
    }
    free(line);
    return b;
}

static bool close_rel(float a, float b, float rel)
{
    return fabsf(a - b) <= rel * fmaxf(fabsf(b), 1e-6f);
}

static void check_decoded(const rd_env_image *img, unsigned w, unsigned h, const char *what)
{
    CHECKF(img->width == w && img->height == h, "%s: %ux%u", what, img->width, img->height);
    unsigned bad = 0;
    for (unsigned y = 0; y < h && img->rgb; y++)
        for (unsigned x = 0; x < w; x++) {
            float c[3];
            texel(x, y, c);
            /* one exponent for the pixel: 8 bits relative to its largest channel */
            float step = fmaxf(c[0], fmaxf(c[1], c[2])) / 128;
            for (int i = 0; i < 3; i++)
                bad += fabsf(img->rgb[((size_t)y * w + x) * 3 + (size_t)i] - c[i]) > step;
        }
    CHECKF(bad == 0, "%s: %u channels off by more than 1/128 of the pixel's largest (RGBE)", what,
           bad);
}

static void test_hdr_reader(void)
{
    char err[256];
    rd_env_image img;
    for (int rle = 0; rle < 2; rle++) {
        buf b = make_hdr(37, 5, rle);
        CHECKF(rd_env_image_parse_hdr(b.d, b.n, NULL, &img, err, sizeof err), "%s", err);
        check_decoded(&img, 37, 5, rle ? "run-length" : "flat");
        rd_env_image_free(&img);
        free(b.d);
    }
    /* small images are always flat (width < 8) */
    buf b = make_hdr(4, 3, false);
    CHECK(rd_env_image_parse_hdr(b.d, b.n, NULL, &img, err, sizeof err));
    check_decoded(&img, 4, 3, "narrow");
    rd_env_image_free(&img);
    free(b.d);

    /* broken files: refused with a message */
    buf good = make_hdr(16, 4, true);
    struct {
        const char *what;
        const char *text; /* replaces the whole file when set */
        size_t cut;       /* else: the good file cut to this many bytes */
    } bad[] = {
        {"empty", "", 0},
        {"not hdr", "P6\n16 4\n255\n", 0},
        {"no blank line", "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n", 0},
        {"xyze", "#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 2\n", 0},
        {"flipped", "#?RADIANCE\n\n+Y 1 +X 2\n\x01\x01\x01\x80\x01\x01\x01\x80", 0},
        {"zero size", "#?RADIANCE\n\n-Y 0 +X 2\n", 0},
        {"huge size", "#?RADIANCE\n\n-Y 100000 +X 100000\n", 0},
        {"no pixels", "#?RADIANCE\n\n-Y 2 +X 2\n", 0},
        {"truncated", NULL, 60},
        {"header only", NULL, 50},
    };
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        const uint8_t *d = bad[i].text ? (const uint8_t *)bad[i].text : good.d;
        size_t n = bad[i].text ? strlen(bad[i].text) : bad[i].cut;
        err[0] = 0;
        bool ok = rd_env_image_parse_hdr(d, n, NULL, &img, err, sizeof err);
        CHECKF(!ok && err[0], "%s: accepted or no message", bad[i].what);
        if (ok) rd_env_image_free(&img);
    }
    /* a run that overflows its scanline */
    buf over = make_hdr(16, 1, true);
    size_t at = over.n - 1;
    while (at > 0 && over.d[at - 1] != 0x02)
        at--;
    over.d[over.n - 2] = 128 + 100; /* last run: far longer than the line */
    CHECK(!rd_env_image_parse_hdr(over.d, over.n, NULL, &img, err, sizeof err));
    free(over.d);

    /* mutations: never a crash (ASan watches), and any accepted image has its size */
    srand(7);
    unsigned accepted = 0;
    for (int m = 0; m < 3000; m++) {
        uint8_t *d = malloc(good.n);
        memcpy(d, good.d, good.n);
        int flips = 1 + rand() % 4;
        for (int f = 0; f < flips; f++)
            d[(size_t)rand() % good.n] = (uint8_t)rand();
        size_t n = rand() % 4 == 0 ? (size_t)rand() % good.n : good.n;
        if (rd_env_image_parse_hdr(d, n, NULL, &img, err, sizeof err)) {
            accepted++;
            CHECK(img.width >= 2 && img.height >= 1 && img.rgb);
            rd_env_image_free(&img);
        }
        free(d);
    }
    printf("hdr mutations: %u of 3000 still valid files\n", accepted);
    free(good.d);
}

/* ---- OpenEXR ------------------------------------------------------------------------------- */

/* The EXR test texel: quarters, small integers and powers of two, exact in HALF. */
static float exr_texel(unsigned x, unsigned y, int c)
{
    return c == 0   ? 0.25f * (float)x + 0.125f
           : c == 1 ? 2.0f + (float)y
                    : 1.0f / (float)(1u << ((x + y) % 8));
}

/* w x h interleaved pixels of channels channels (exr_texel for the first three, 7 after). */
static float *exr_pixels(unsigned w, unsigned h, int channels)
{
    float *p = malloc((size_t)w * h * (size_t)channels * sizeof *p);
    if (!p) abort();
    for (unsigned y = 0; y < h; y++)
        for (unsigned x = 0; x < w; x++)
            for (int c = 0; c < channels; c++)
                p[((size_t)y * w + x) * (size_t)channels + (size_t)c] =
                    c < 3 ? exr_texel(x, y, c) : 7.0f;
    return p;
}

/* Every texel of img equals the test texel of (x - ox, y - oy) inside the w x h data, else 0;
 * grey: all channels hold channel 0. */
static unsigned exr_mismatches(const rd_env_image *img, unsigned w, unsigned h, int ox, int oy,
                               bool grey)
{
    unsigned bad = 0;
    for (unsigned y = 0; y < img->height; y++)
        for (unsigned x = 0; x < img->width; x++) {
            int dx = (int)x - ox, dy = (int)y - oy;
            bool in = dx >= 0 && dy >= 0 && dx < (int)w && dy < (int)h;
            for (int c = 0; c < 3; c++) {
                float want = in ? exr_texel((unsigned)dx, (unsigned)dy, grey ? 0 : c) : 0.0f;
                bad += img->rgb[((size_t)y * img->width + x) * 3 + (size_t)c] != want;
            }
        }
    return bad;
}

/* Writes d, reads it back through the format sniffer; false (and a failed check) when either
 * step fails. */
static bool exr_roundtrip(const pc_exr_desc *d, rd_env_image *img, const char *what)
{
    size_t n = 0;
    uint8_t *file = pc_exr_write(d, &n);
    CHECKF(file != NULL, "%s: the writer failed", what);
    if (!file) return false;
    char err[256] = "";
    CHECK(rd_env_image_format(file, n) == RD_ENV_FORMAT_EXR);
    bool ok = rd_env_image_parse(file, n, NULL, img, err, sizeof err);
    CHECKF(ok, "%s: %s", what, err);
    free(file);
    return ok;
}

static void test_exr_reader(void)
{
    rd_env_image img;
    const exr_compression_t comps[] = {EXR_COMPRESSION_NONE, EXR_COMPRESSION_RLE,
                                       EXR_COMPRESSION_ZIPS, EXR_COMPRESSION_ZIP,
                                       EXR_COMPRESSION_PIZ};
    const char *const comp_names[] = {"none", "rle", "zips", "zip", "piz"};
    /* scanlines, HALF and FLOAT, each lossless compression; 37 x 40 spans several chunks of
     * every kind (1, 16 and 32 lines) */
    float *px = exr_pixels(37, 40, 3);
    for (int t = 0; t < 2; t++)
        for (size_t k = 0; k < sizeof comps / sizeof *comps; k++) {
            char what[64];
            snprintf(what, sizeof what, "%s scanlines, %s", t ? "float" : "half", comp_names[k]);
            pc_exr_desc d = {.width = 37,
                             .height = 40,
                             .pixels = px,
                             .type = t ? EXR_PIXEL_FLOAT : EXR_PIXEL_HALF,
                             .compression = comps[k]};
            if (!exr_roundtrip(&d, &img, what)) continue;
            CHECKF(img.width == 37 && img.height == 40, "%s: %ux%u", what, img.width, img.height);
            unsigned bad = exr_mismatches(&img, 37, 40, 0, 0, false);
            CHECKF(bad == 0, "%s: %u channels differ from the written values", what, bad);
            rd_env_image_free(&img);
        }
    /* tiled (8 x 8 tiles, the last ones partial), HALF with ZIP and FLOAT with PIZ */
    for (int t = 0; t < 2; t++) {
        pc_exr_desc d = {.width = 37,
                         .height = 21,
                         .pixels = px,
                         .tile = 8,
                         .type = t ? EXR_PIXEL_FLOAT : EXR_PIXEL_HALF,
                         .compression = t ? EXR_COMPRESSION_PIZ : EXR_COMPRESSION_ZIP};
        if (!exr_roundtrip(&d, &img, "tiled")) continue;
        CHECK(img.width == 37 && img.height == 21);
        CHECKF(exr_mismatches(&img, 37, 21, 0, 0, false) == 0, "tiled %s differs",
               t ? "float" : "half");
        rd_env_image_free(&img);
    }
    /* UINT channels */
    pc_exr_desc u = {.width = 9, .height = 3, .pixels = px, .type = EXR_PIXEL_UINT};
    float *ints = exr_pixels(9, 3, 3);
    for (size_t i = 0; i < 9 * 3 * 3; i++)
        ints[i] = (float)(i % 50);
    u.pixels = ints;
    if (exr_roundtrip(&u, &img, "uint")) {
        unsigned bad = 0;
        for (size_t i = 0; i < 9 * 3 * 3; i++)
            bad += img.rgb[i] != (float)(i % 50);
        CHECKF(bad == 0, "uint: %u channels differ", bad);
        rd_env_image_free(&img);
    }
    free(ints);
    /* a data window inside a larger display window, and hanging over its right edge: the
     * image is the display window, black where no data is */
    float *px8 = exr_pixels(8, 2, 3), *px6 = exr_pixels(6, 3, 3);
    pc_exr_desc off = {.width = 8,
                       .height = 2,
                       .x = 3,
                       .y = 1,
                       .display_width = 8,
                       .display_height = 4,
                       .pixels = px8,
                       .type = EXR_PIXEL_HALF,
                       .compression = EXR_COMPRESSION_ZIP};
    if (exr_roundtrip(&off, &img, "data window offset")) {
        CHECK(img.width == 8 && img.height == 4);
        CHECKF(exr_mismatches(&img, 8, 2, 3, 1, false) == 0, "offset data window differs");
        rd_env_image_free(&img);
    }
    /* both windows away from the origin (the same box): the image is exactly the data */
    pc_exr_desc moved = {.width = 6,
                         .height = 3,
                         .x = -5,
                         .y = 7,
                         .pixels = px6,
                         .type = EXR_PIXEL_FLOAT,
                         .tile = 4};
    if (exr_roundtrip(&moved, &img, "moved windows")) {
        CHECK(img.width == 6 && img.height == 3);
        CHECKF(exr_mismatches(&img, 6, 3, 0, 0, false) == 0, "moved windows differ");
        rd_env_image_free(&img);
    }
    free(px8);
    free(px6);
    /* alpha and other channels are ignored (channels stored in any order) */
    static const char *const abgr[] = {"A", "B", "G", "R", "Z"};
    float *five = exr_pixels(5, 4, 5);
    for (size_t i = 0; i < 5 * 4; i++) { /* the writer's order: A, B, G, R, Z */
        float r = five[i * 5], g = five[i * 5 + 1], b = five[i * 5 + 2];
        five[i * 5] = 0.5f, five[i * 5 + 1] = b, five[i * 5 + 2] = g, five[i * 5 + 3] = r;
        five[i * 5 + 4] = 9.0f;
    }
    pc_exr_desc rgba = {.width = 5,
                        .height = 4,
                        .pixels = five,
                        .type = EXR_PIXEL_HALF,
                        .channel_count = 5,
                        .channels = abgr};
    if (exr_roundtrip(&rgba, &img, "with alpha")) {
        CHECKF(exr_mismatches(&img, 5, 4, 0, 0, false) == 0, "RGBA (and Z) differs");
        rd_env_image_free(&img);
    }
    free(five);
    /* a lone Y is grey */
    static const char *const y_only[] = {"Y"};
    float *lum = exr_pixels(4, 2, 1);
    pc_exr_desc grey = {.width = 4,
                        .height = 2,
                        .pixels = lum,
                        .type = EXR_PIXEL_HALF,
                        .channel_count = 1,
                        .channels = y_only};
    if (exr_roundtrip(&grey, &img, "luminance")) {
        CHECKF(exr_mismatches(&img, 4, 2, 0, 0, true) == 0, "Y is not read as grey");
        rd_env_image_free(&img);
    }
    free(lum);
    /* negative, NaN and infinite values become 0 */
    float odd[2 * 1 * 3] = {-1.0f, NAN, INFINITY, 3.0f, -INFINITY, -0.0f};
    pc_exr_desc special = {.width = 2, .height = 1, .pixels = odd, .type = EXR_PIXEL_FLOAT};
    if (exr_roundtrip(&special, &img, "special values")) {
        const float want[6] = {0, 0, 0, 3.0f, 0, 0};
        CHECKF(memcmp(img.rgb, want, sizeof want) == 0, "%g %g %g %g %g %g", (double)img.rgb[0],
               (double)img.rgb[1], (double)img.rgb[2], (double)img.rgb[3], (double)img.rgb[4],
               (double)img.rgb[5]);
        rd_env_image_free(&img);
    }

    /* refused with a message, never a crash */
    char err[256];
    static const char *const no_rgb[] = {"Z"};
    static const char *const yc[] = {"BY", "RY", "Y"};
    static const char *const rg[] = {"G", "R"};
    struct {
        const char *what, *expect; /* expect: a phrase of the message */
        pc_exr_desc d;
    } refused[] = {
        {"no colour",
         "R, G and B",
         {.width = 4,
          .height = 2,
          .pixels = px,
          .type = EXR_PIXEL_HALF,
          .channel_count = 1,
          .channels = no_rgb}},
        {"R and G only",
         "R, G and B",
         {.width = 4,
          .height = 2,
          .pixels = px,
          .type = EXR_PIXEL_HALF,
          .channel_count = 2,
          .channels = rg}},
        {"luminance-chroma",
         "chroma",
         {.width = 4,
          .height = 2,
          .pixels = px,
          .type = EXR_PIXEL_HALF,
          .channel_count = 3,
          .channels = yc}},
        {"display too wide",
         "out of range",
         {.width = 4,
          .height = 2,
          .pixels = px,
          .type = EXR_PIXEL_HALF,
          .display_width = 40000,
          .display_height = 2}},
        {"display too large",
         "MiB",
         {.width = 4,
          .height = 2,
          .pixels = px,
          .type = EXR_PIXEL_HALF,
          .display_width = 32768,
          .display_height = 32768}},
        {"one pixel wide",
         "out of range",
         {.width = 1, .height = 2, .pixels = px, .type = EXR_PIXEL_HALF}},
        /* a row of 256-high tiles across a 32768-wide display window: 96 MiB decoded */
        {"a row of tiles over RD_ENV_MAX_STRIPE_BYTES",
         "smaller tiles",
         {.width = 2,
          .height = 256,
          .tile = 256,
          .pixels = px,
          .type = EXR_PIXEL_HALF,
          .display_width = 32768,
          .display_height = 256}},
    };
    for (size_t i = 0; i < sizeof refused / sizeof *refused; i++) {
        size_t n = 0;
        uint8_t *file = pc_exr_write(&refused[i].d, &n);
        CHECKF(file != NULL, "%s: the writer failed", refused[i].what);
        if (!file) continue;
        err[0] = 0;
        bool ok = rd_env_image_parse(file, n, NULL, &img, err, sizeof err);
        CHECKF(!ok && strstr(err, refused[i].expect), "%s: %s", refused[i].what,
               ok ? "accepted" : err);
        if (ok) rd_env_image_free(&img);
        free(file);
    }
    /* a data window wider than RD_ENV_MAX_DIM (the writer makes it; 40000 x 1 halves) */
    float *wide = calloc(40000 * 3, sizeof *wide);
    pc_exr_desc too_wide = {.width = 40000, .height = 1, .pixels = wide, .type = EXR_PIXEL_HALF};
    size_t wn = 0;
    uint8_t *wf = pc_exr_write(&too_wide, &wn);
    CHECK(wf != NULL);
    if (wf) {
        err[0] = 0;
        CHECKF(!rd_env_image_parse(wf, wn, NULL, &img, err, sizeof err) && err[0], "40000 wide: %s",
               err);
        free(wf);
    }
    free(wide);

    /* truncated and garbage files */
    pc_exr_desc zd = {.width = 37,
                      .height = 40,
                      .pixels = px,
                      .type = EXR_PIXEL_HALF,
                      .compression = EXR_COMPRESSION_ZIP};
    size_t n = 0;
    uint8_t *good = pc_exr_write(&zd, &n);
    CHECK(good != NULL && n > 400);
    if (!good) {
        free(px);
        return;
    }
    const size_t cuts[] = {4, 8, 60, n / 3, n / 2, n - 40, n - 1};
    for (size_t i = 0; i < sizeof cuts / sizeof *cuts; i++) {
        err[0] = 0;
        bool ok = rd_env_image_parse(good, cuts[i], NULL, &img, err, sizeof err);
        CHECKF(!ok && err[0], "cut to %zu of %zu bytes: %s", cuts[i], n, ok ? "accepted" : "");
        if (ok) rd_env_image_free(&img);
    }
    printf("exr cut to %zu bytes: %s\n", n / 2, err);
    uint8_t garbage[300];
    srand(11);
    for (int g = 0; g < 50; g++) {
        memcpy(garbage, good, 4); /* the magic number, then noise */
        for (size_t i = 4; i < sizeof garbage; i++)
            garbage[i] = (uint8_t)rand();
        if (g == 0) memset(garbage + 4, 0, sizeof garbage - 4);
        err[0] = 0;
        bool ok = rd_env_image_parse(garbage, sizeof garbage, NULL, &img, err, sizeof err);
        CHECKF(!ok && err[0], "garbage after the magic number %s", ok ? "accepted" : "");
        if (ok) rd_env_image_free(&img);
    }
    printf("exr garbage: %s\n", err);
    err[0] = 0;
    CHECK(!rd_env_image_parse((const uint8_t *)"P6\n", 3, NULL, &img, err, sizeof err) &&
          strstr(err, "neither"));

    /* mutations of a valid file: never a crash (ASan watches), any accepted image has its size */
    unsigned accepted = 0;
    for (int m = 0; m < 1500; m++) {
        uint8_t *d = malloc(n);
        memcpy(d, good, n);
        int flips = 1 + rand() % 4;
        for (int f = 0; f < flips; f++)
            d[(size_t)rand() % n] = (uint8_t)rand();
        size_t len = rand() % 4 == 0 ? (size_t)rand() % n : n;
        if (rd_env_image_parse(d, len, NULL, &img, err, sizeof err)) {
            accepted++;
            CHECK(img.width >= 2 && img.height >= 1 && img.rgb);
            rd_env_image_free(&img);
        }
        free(d);
    }
    printf("exr mutations: %u of 1500 still read\n", accepted);
    free(good);
    free(px);
}

/* ---- reduction while decoding -------------------------------------------------------------- */

/* Reads file twice: at full size then rd_env_image_limit (the reference: the whole image in
 * memory), and reduced while decoding; both must agree bit for bit. */
static void check_striped(const uint8_t *file, size_t n, uint32_t max_width, uint32_t want_w,
                          uint32_t want_h, const char *what)
{
    char err[256] = "";
    rd_env_image full, striped;
    rd_env_read_desc fd = {.max_width = RD_ENV_MAX_DIM}, sd = {.max_width = max_width};
    bool ok = rd_env_image_parse(file, n, &fd, &full, err, sizeof err);
    CHECKF(ok, "%s: full decode: %s", what, err);
    if (!ok) return;
    ok = rd_env_image_parse(file, n, &sd, &striped, err, sizeof err);
    CHECKF(ok, "%s: striped decode: %s", what, err);
    if (!ok) {
        rd_env_image_free(&full);
        return;
    }
    bool reduces = full.width > max_width || full.height > max_width;
    rd_env_image_limit(&full, max_width);
    CHECKF(full.width == want_w && full.height == want_h, "%s: reference %ux%u, want %ux%u", what,
           full.width, full.height, want_w, want_h);
    CHECKF(striped.width == full.width && striped.height == full.height,
           "%s: striped %ux%u, reference %ux%u", what, striped.width, striped.height, full.width,
           full.height);
    if (striped.width == full.width && striped.height == full.height) {
        size_t count = (size_t)full.width * full.height * 3, bad = 0;
        for (size_t i = 0; i < count; i++)
            bad += memcmp(&striped.rgb[i], &full.rgb[i], sizeof(float)) != 0;
        CHECKF(bad == 0, "%s: %zu of %zu floats differ from the reference", what, bad, count);
    }
    /* the reduced read never holds the full image (unless there is nothing to reduce) */
    if (reduces)
        CHECKF(sd.peak_bytes < fd.peak_bytes, "%s: peak %zu bytes reduced, %zu full", what,
               sd.peak_bytes, fd.peak_bytes);
    rd_env_image_free(&full);
    rd_env_image_free(&striped);
}

static void test_striped_reduction(void)
{
    /* .hdr of noisy texels, flat and run-length, reduced to 16: exact halvings, odd widths and
     * heights (an odd last row or column of a level is dropped), taller than wide (halved for its
     * height), too flat to halve twice, nothing to reduce */
    const struct {
        unsigned w, h, rw, rh;
    } hdr[] = {{64, 32, 16, 8}, {75, 37, 9, 4},  {37, 90, 4, 11}, {100, 3, 50, 1},
               {15, 7, 15, 7},  {33, 17, 16, 8}, {9, 40, 2, 10},  {257, 130, 16, 8}};
    for (size_t i = 0; i < sizeof hdr / sizeof *hdr; i++)
        for (int rle = 0; rle < 2; rle++) {
            char what[64];
            snprintf(what, sizeof what, "hdr %ux%u %s", hdr[i].w, hdr[i].h, rle ? "rle" : "flat");
            buf b = make_hdr_of(hdr[i].w, hdr[i].h, rle && hdr[i].w >= 8, noisy_texel);
            check_striped(b.d, b.n, 16, hdr[i].rw, hdr[i].rh, what);
            free(b.d);
        }

    /* .exr: scanline chunks of 1, 16 and 32 lines and tiles (odd sizes, partial tiles), with
     * display windows that crop the data window and leave black borders; FLOAT keeps the noisy
     * texels' full mantissas */
    float *px = malloc(75 * 61 * 3 * sizeof *px);
    if (!px) abort();
    for (unsigned y = 0; y < 61; y++)
        for (unsigned x = 0; x < 75; x++)
            noisy_texel(x, y, px + (y * 75 + x) * 3);
    const struct {
        const char *what;
        pc_exr_desc d;
        unsigned rw, rh;
    } exr[] = {
        {"exr scanlines, none",
         {.width = 75, .height = 61, .type = EXR_PIXEL_FLOAT, .compression = EXR_COMPRESSION_NONE},
         9,
         7},
        {"exr scanlines, zip",
         {.width = 75, .height = 61, .type = EXR_PIXEL_HALF, .compression = EXR_COMPRESSION_ZIP},
         9,
         7},
        {"exr scanlines, piz",
         {.width = 75, .height = 61, .type = EXR_PIXEL_FLOAT, .compression = EXR_COMPRESSION_PIZ},
         9,
         7},
        {"exr tiles 8",
         {.width = 75,
          .height = 61,
          .type = EXR_PIXEL_HALF,
          .tile = 8,
          .compression = EXR_COMPRESSION_ZIP},
         9,
         7},
        {"exr tiles 5",
         {.width = 75,
          .height = 61,
          .type = EXR_PIXEL_FLOAT,
          .tile = 5,
          .compression = EXR_COMPRESSION_NONE},
         9,
         7},
        {"exr tall tiles 7",
         {.width = 31,
          .height = 61,
          .type = EXR_PIXEL_HALF,
          .tile = 7,
          .compression = EXR_COMPRESSION_ZIPS},
         7,
         15},
        {"exr scanlines in a larger display window",
         {.width = 75,
          .height = 61,
          .x = 5,
          .y = 3,
          .display_width = 90,
          .display_height = 77,
          .type = EXR_PIXEL_HALF,
          .compression = EXR_COMPRESSION_ZIP},
         11,
         9},
        {"exr tiles in a larger display window",
         {.width = 75,
          .height = 61,
          .x = 5,
          .y = 9,
          .display_width = 90,
          .display_height = 77,
          .type = EXR_PIXEL_HALF,
          .tile = 6,
          .compression = EXR_COMPRESSION_RLE},
         11,
         9},
        {"exr scanlines cropped by the display window",
         {.width = 75,
          .height = 61,
          .x = -4,
          .y = -7,
          .display_width = 66,
          .display_height = 50,
          .type = EXR_PIXEL_FLOAT,
          .compression = EXR_COMPRESSION_ZIP},
         16,
         12},
        {"exr tiles cropped by the display window",
         {.width = 75,
          .height = 61,
          .x = -4,
          .y = -7,
          .display_width = 66,
          .display_height = 50,
          .type = EXR_PIXEL_HALF,
          .tile = 8,
          .compression = EXR_COMPRESSION_PIZ},
         16,
         12},
    };
    for (size_t i = 0; i < sizeof exr / sizeof *exr; i++) {
        pc_exr_desc d = exr[i].d;
        d.pixels = px;
        size_t n = 0;
        uint8_t *file = pc_exr_write(&d, &n);
        CHECKF(file != NULL, "%s: the writer failed", exr[i].what);
        if (!file) continue;
        check_striped(file, n, 16, exr[i].rw, exr[i].rh, exr[i].what);
        free(file);
    }
    free(px);
}

/* The process's peak resident set, bytes (Linux reports KiB). */
static size_t peak_rss(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return (size_t)ru.ru_maxrss * 1024;
}

/* A run-length .hdr of one colour: a few KiB a scanline whatever its width. */
static buf make_constant_hdr(unsigned w, unsigned h, const uint8_t rgbe[4])
{
    buf b = {0};
    char head[96];
    int k =
        snprintf(head, sizeof head, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %u +X %u\n", h, w);
    put(&b, head, (size_t)k);
    for (unsigned y = 0; y < h; y++) {
        uint8_t mark[4] = {2, 2, (uint8_t)(w >> 8), (uint8_t)(w & 255)};
        put(&b, mark, 4);
        for (int c = 0; c < 4; c++)
            for (unsigned x = 0; x < w;) {
                unsigned run = w - x < 127 ? w - x : 127;
                uint8_t r[2] = {(uint8_t)(128 + run), rgbe[c]};
                put(&b, r, 2);
                x += run;
            }
    }
    return b;
}

/* The largest files a client may send hold tens of MiB while they are read, not the GiB their
 * texels would take at full size (which the readers once allocated before reducing). Counted
 * twice: by the readers' own tally (their buffers, the image, OpenEXRCore's allocations) and
 * by the growth of the process's peak RSS, which sees every allocation. Runs first, so that
 * the RSS peak is this test's (the smaller .exr first: the old reader's calloc'd image grew the
 * RSS by 112 MiB, only what it touched). */
static void test_bounded_memory(void)
{
    char err[256] = "";
    rd_env_image img;
    /* .exr: a 16384 x 16 ZIP band in a 16384 x 2048 display window (the rest is black; 384
     * MiB at full size), reduced to 4096 x 512 (24 MiB) */
    float *px = exr_pixels(16384, 16, 3);
    pc_exr_desc d = {.width = 16384,
                     .height = 16,
                     .y = 1000,
                     .display_width = 16384,
                     .display_height = 2048,
                     .pixels = px,
                     .type = EXR_PIXEL_HALF,
                     .compression = EXR_COMPRESSION_ZIP};
    size_t n = 0;
    uint8_t *file = pc_exr_write(&d, &n);
    free(px);
    CHECK(file != NULL);
    if (!file) return;
    size_t rss0 = peak_rss();
    rd_env_read_desc desc = {0};
    bool ok = rd_env_image_parse(file, n, &desc, &img, err, sizeof err);
    size_t rss1 = peak_rss();
    CHECKF(ok, "exr: %s", err);
    if (ok) {
        size_t image = (size_t)img.width * img.height * 3 * sizeof(float);
        CHECKF(img.width == 4096 && img.height == 512, "exr reduced to %ux%u", img.width,
               img.height);
        CHECKF(desc.peak_bytes >= image && desc.peak_bytes < image + ((size_t)16 << 20),
               "exr peak %zu bytes for a %zu-byte image", desc.peak_bytes, image);
        CHECKF(rss1 - rss0 < ((size_t)64 << 20), "exr: the peak RSS grew by %zu MiB",
               (rss1 - rss0) >> 20);
        printf("exr 16384x2048 (%zu KiB file, 384 MiB at full size): peak %zu KiB counted, peak "
               "RSS +%zu MiB\n",
               n >> 10, desc.peak_bytes >> 10, (rss1 - rss0) >> 20);
        rd_env_image_free(&img);
    }
    free(file);

    /* .hdr: 32767 x 5461 (run-length scanlines are at most 32767 wide), about the most texels
     * RD_ENV_MAX_BYTES accepts (2 GiB as floats), one colour: an 11 MiB file; reduced to
     * 4095 x 682 (33 MiB) */
    const unsigned hw = 0x7fff, hh = (unsigned)(RD_ENV_MAX_BYTES / 12 / hw);
    const uint8_t rgbe[4] = {128, 64, 32, 129}; /* 1, 0.5, 0.25 (+ half a step) */
    buf b = make_constant_hdr(hw, hh, rgbe);
    rss0 = peak_rss();
    ok = rd_env_image_parse(b.d, b.n, &desc, &img, err, sizeof err);
    rss1 = peak_rss();
    CHECKF(ok, "hdr %ux%u: %s", hw, hh, err);
    if (ok) {
        size_t image = (size_t)img.width * img.height * 3 * sizeof(float);
        CHECKF(img.width == hw / 8 && img.height == hh / 8, "hdr reduced to %ux%u", img.width,
               img.height);
        CHECKF(desc.peak_bytes >= image && desc.peak_bytes < image + ((size_t)4 << 20),
               "hdr peak %zu bytes for a %zu-byte image", desc.peak_bytes, image);
        CHECKF(rss1 - rss0 < ((size_t)256 << 20), "hdr: the peak RSS grew by %zu MiB",
               (rss1 - rss0) >> 20);
        float want[3] = {128.5f / 128, 64.5f / 128, 32.5f / 128};
        bool same = true;
        for (size_t i = 0; i < (size_t)img.width * img.height * 3; i++)
            same = same && img.rgb[i] == want[i % 3];
        CHECK(same);
        printf("hdr %ux%u (%zu KiB file, %llu MiB at full size): peak %zu KiB counted, peak "
               "RSS +%zu MiB\n",
               hw, hh, b.n >> 10, (unsigned long long)((uint64_t)hw * hh * 12 >> 20),
               desc.peak_bytes >> 10, (rss1 - rss0) >> 20);
        rd_env_image_free(&img);
    }
    free(b.d);
}

static void test_irradiance(void)
{
    const float normals[][3] = {
        {0, 1, 0}, {0, -1, 0}, {1, 0, 0}, {0.6f, 0.8f, 0}, {0, 0.6f, -0.8f}};
    float sh[9][3], e[3];
    /* uniform: E = pi L in every direction */
    rd_environment u = {.mode = RD_ENV_UNIFORM, .sky = {0.5f, 1, 2}, .intensity = 1};
    rd_env_irradiance_sh(&u, sh);
    for (size_t i = 0; i < 5; i++) {
        rd_env_irradiance_eval(sh, normals[i], e);
        for (int c = 0; c < 3; c++)
            CHECKF(close_rel(e[c], PI_F * u.sky[c], 1e-4f), "uniform E %g", (double)e[c]);
    }
    /* gradient L = a + b y: E(n) = pi a + (2 pi / 3) b n.y */
    rd_environment g = {
        .mode = RD_ENV_GRADIENT, .sky = {2, 1, 0.5f}, .ground = {0.2f, 0.1f, 0}, .intensity = 1};
    rd_env_irradiance_sh(&g, sh);
    for (size_t i = 0; i < 5; i++) {
        rd_env_irradiance_eval(sh, normals[i], e);
        for (int c = 0; c < 3; c++) {
            float a = 0.5f * (g.sky[c] + g.ground[c]), b = 0.5f * (g.sky[c] - g.ground[c]);
            float want = PI_F * a + 2 * PI_F / 3 * b * normals[i][1];
            CHECKF(close_rel(e[c], want, 1e-4f), "gradient E %g want %g", (double)e[c],
                   (double)want);
        }
        float d[3], l[3];
        memcpy(d, normals[i], sizeof d);
        rd_env_radiance(&g, d, l);
        CHECK(
            close_rel(l[0], g.ground[0] + (g.sky[0] - g.ground[0]) * (0.5f + 0.5f * d[1]), 1e-5f));
    }
    /* the same gradient as an image (and rotated, which changes nothing for it): E within 1% */
    rd_env_image img = {.width = 256, .height = 128};
    img.rgb = malloc(256 * 128 * 3 * sizeof(float));
    for (unsigned y = 0; y < 128; y++)
        for (unsigned x = 0; x < 256; x++)
            for (int c = 0; c < 3; c++) {
                float theta = PI_F * ((float)y + 0.5f) / 128;
                img.rgb[(y * 256 + x) * 3 + (unsigned)c] =
                    g.ground[c] + (g.sky[c] - g.ground[c]) * (0.5f + 0.5f * cosf(theta));
            }
    rd_environment im = {.mode = RD_ENV_IMAGE, .intensity = 2, .rotation = 1.0f, .image = &img};
    rd_env_irradiance_sh(&im, sh);
    for (size_t i = 0; i < 5; i++) {
        rd_env_irradiance_eval(sh, normals[i], e);
        float a = 0.5f * (g.sky[0] + g.ground[0]), b = 0.5f * (g.sky[0] - g.ground[0]);
        float want = 2 * (PI_F * a + 2 * PI_F / 3 * b * normals[i][1]);
        CHECKF(close_rel(e[0], want, 0.01f), "image E %g want %g (n %zu)", (double)e[0],
               (double)want, i);
    }
    /* a lookup lands on the texel its direction names: the image's column u looks toward
     * atan2(x, -z) = (u - 1/2) 2 pi + rotation */
    for (unsigned y = 0; y < 128; y++)
        for (unsigned x = 0; x < 256; x++)
            img.rgb[(y * 256 + x) * 3] = (float)x, img.rgb[(y * 256 + x) * 3 + 1] = (float)y;
    float tu = (100 + 0.5f) / 256, tv = (40 + 0.5f) / 128;
    float phi = (tu - 0.5f) * 2 * PI_F + im.rotation, theta = tv * PI_F;
    float d[3] = {sinf(theta) * sinf(phi), cosf(theta), -sinf(theta) * cosf(phi)}, l[3];
    rd_env_radiance(&im, d, l);
    CHECKF(fabsf(l[0] - 200) < 0.5f && fabsf(l[1] - 80) < 0.5f, "lookup %g %g", (double)l[0],
           (double)l[1]);
    /* halving keeps the mean */
    rd_env_image_limit(&img, 64);
    CHECK(img.width == 64 && img.height == 32);
    rd_env_image_free(&img);
}

int main(void)
{
    test_bounded_memory();
    test_striped_reduction();
    test_hdr_reader();
    test_exr_reader();
    test_irradiance();
    return test_finish();
}
