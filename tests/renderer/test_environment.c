/* test_environment.c: the environment models against analytic values: the Radiance .hdr reader
 * (flat and run-length scanlines decode to the written values; broken files are refused with a
 * message, and random mutations never crash it), the OpenEXR reader (files written by
 * OpenEXRCore's writer decode to exactly the values written, broken ones are refused with a
 * message; test_environment_reduce.c checks their reduction while decoding) and the SH9 irradiance
 * (exact for uniform and gradient skies, within 1-2% for images of the same functions). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/env/environment.h"
#include "renderer/exr_writer.h"
#include "renderer/hdr_writer.h"
#include "test_util.h"

#define PI_F 3.14159265358979323846f

/* The test image's texel colour. */
static void texel(unsigned x, unsigned y, float c[3])
{
    c[0] = 0.25f + 0.5f * (float)x;
    c[1] = 1.0f / (1.0f + (float)y);
    c[2] = (x + y) % 3 == 0 ? 0.0f : 4.0f;
}

static pc_bytes make_hdr(unsigned w, unsigned h, bool rle)
{
    return pc_hdr_write(w, h, rle, texel);
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
        pc_bytes b = make_hdr(37, 5, rle);
        CHECKF(rd_env_image_parse_hdr(b.d, b.n, NULL, &img, err, sizeof err), "%s", err);
        check_decoded(&img, 37, 5, rle ? "run-length" : "flat");
        rd_env_image_free(&img);
        free(b.d);
    }
    /* small images are always flat (width < 8) */
    pc_bytes b = make_hdr(4, 3, false);
    CHECK(rd_env_image_parse_hdr(b.d, b.n, NULL, &img, err, sizeof err));
    check_decoded(&img, 4, 3, "narrow");
    rd_env_image_free(&img);
    free(b.d);

    /* broken files: refused with a message */
    pc_bytes good = make_hdr(16, 4, true);
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
    pc_bytes over = make_hdr(16, 1, true);
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
                float want =
                    in ? pc_exr_test_texel((unsigned)dx, (unsigned)dy, grey ? 0 : c) : 0.0f;
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
    float *px = pc_exr_test_pixels(37, 40, 3);
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
    float *ints = pc_exr_test_pixels(9, 3, 3);
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
    float *px8 = pc_exr_test_pixels(8, 2, 3), *px6 = pc_exr_test_pixels(6, 3, 3);
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
    float *five = pc_exr_test_pixels(5, 4, 5);
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
    float *lum = pc_exr_test_pixels(4, 2, 1);
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

/* rd_env_image_shrunk: a box-filtered copy at most max_width on both sides (the source only
 * read), equal to halving it as many times with rd_env_image_limit */
static void test_shrunk(void)
{
    rd_env_image img = {.width = 256, .height = 128};
    img.rgb = malloc((size_t)256 * 128 * 3 * sizeof(float));
    for (unsigned i = 0; i < 256 * 128 * 3; i++)
        img.rgb[i] = (float)((i * 37u) % 101u) * 0.25f;
    rd_env_image copy = {.width = 256, .height = 128};
    copy.rgb = malloc((size_t)256 * 128 * 3 * sizeof(float));
    memcpy(copy.rgb, img.rgb, (size_t)256 * 128 * 3 * sizeof(float));
    rd_env_image small;
    rd_env_image_shrunk(&img, 64, &small);
    CHECK(small.width == 64 && small.height == 32);
    CHECK(memcmp(img.rgb, copy.rgb, (size_t)256 * 128 * 3 * sizeof(float)) == 0);
    /* a 4 x 4 block's mean: texel (5, 3) averages rows 12-15, columns 20-23 */
    double want = 0;
    for (unsigned y = 12; y < 16; y++)
        for (unsigned x = 20; x < 24; x++)
            want += img.rgb[(y * 256 + x) * 3 + 1];
    want /= 16;
    float got = small.rgb[(3 * 64 + 5) * 3 + 1];
    CHECKF(fabs(got - want) < 1e-4 * want + 1e-6, "block mean %g, want %g", (double)got, want);
    rd_env_image_limit(&copy, 64);
    float worst = 0;
    for (unsigned i = 0; i < 64 * 32 * 3; i++) {
        float e = fabsf(copy.rgb[i] - small.rgb[i]);
        worst = e > worst ? e : worst;
    }
    CHECKF(worst < 1e-4f, "shrunk against halved twice: worst %g", (double)worst);
    rd_env_image_free(&small);
    /* small enough already: a plain copy */
    rd_env_image_shrunk(&img, 512, &small);
    CHECK(small.width == 256 && small.height == 128 &&
          memcmp(small.rgb, img.rgb, (size_t)256 * 128 * 3 * sizeof(float)) == 0);
    rd_env_image_free(&small);
    rd_env_image_free(&copy);
    rd_env_image_free(&img);
}

int main(void)
{
    test_shrunk();
    test_hdr_reader();
    test_exr_reader();
    test_irradiance();
    return test_finish();
}
