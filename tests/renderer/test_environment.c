/* test_environment.c: the environment models against analytic values: the Radiance .hdr reader
 * (flat and run-length scanlines decode to the written values; broken files are refused with a
 * message, and random mutations never crash it), and the SH9 irradiance (exact for uniform and
 * gradient skies, within 1-2% for images of the same functions). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/environment.h"
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

/* A .hdr of w x h test texels; rle: new-style run-length scanlines (runs of equal bytes are
 * written as runs, others as literals). */
static buf make_hdr(unsigned w, unsigned h, bool rle)
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
            texel(x, y, c);
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
        CHECKF(rd_env_image_parse_hdr(b.d, b.n, &img, err, sizeof err), "%s", err);
        check_decoded(&img, 37, 5, rle ? "run-length" : "flat");
        rd_env_image_free(&img);
        free(b.d);
    }
    /* small images are always flat (width < 8) */
    buf b = make_hdr(4, 3, false);
    CHECK(rd_env_image_parse_hdr(b.d, b.n, &img, err, sizeof err));
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
        bool ok = rd_env_image_parse_hdr(d, n, &img, err, sizeof err);
        CHECKF(!ok && err[0], "%s: accepted or no message", bad[i].what);
        if (ok) rd_env_image_free(&img);
    }
    /* a run that overflows its scanline */
    buf over = make_hdr(16, 1, true);
    size_t at = over.n - 1;
    while (at > 0 && over.d[at - 1] != 0x02)
        at--;
    over.d[over.n - 2] = 128 + 100; /* last run: far longer than the line */
    CHECK(!rd_env_image_parse_hdr(over.d, over.n, &img, err, sizeof err));
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
        if (rd_env_image_parse_hdr(d, n, &img, err, sizeof err)) {
            accepted++;
            CHECK(img.width >= 2 && img.height >= 1 && img.rgb);
            rd_env_image_free(&img);
        }
        free(d);
    }
    printf("hdr mutations: %u of 3000 still valid files\n", accepted);
    free(good.d);
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
    test_hdr_reader();
    test_irradiance();
    return test_finish();
}
