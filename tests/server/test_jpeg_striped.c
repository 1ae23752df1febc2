/* Striped JPEG (server/encode/jpeg_striped.h): plans, joined files that decode to the full image with
 * the pixels of one tjCompress2 encode, restart markers in order, byte identity with a whole-image
 * encode at the same restart interval, and joins that must fail (and checks that would notice a
 * wrong stripe order or offset). */
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <turbojpeg.h>

#include "server/encode/jpeg_striped.h"
#include "test_util.h"

#define QUALITY 80
/* Mean absolute difference per channel allowed between the decoded striped JPEG and the decoded
 * tjCompress2 JPEG. Measured: exactly 0 at every size and stripe count (the same coefficients); a
 * swapped pair of stripes gives 32 and one stripe shifted by one MCU row 3.0 (on 640x360 in 3
 * stripes, see test_failures_noticed), so 0.05 separates them by far. */
#define MEAN_TOL 0.05

static double worst_mean; /* the largest mean |diff| of a correct join (printed) */

/* A smooth image with noise (a rendered frame's gradients plus path-tracing grain), RGBA. */
static uint8_t *make_image(unsigned w, unsigned h, uint32_t seed)
{
    uint8_t *p = malloc((size_t)w * h * 4);
    uint32_t s = seed * 2654435761u + 1;
    for (unsigned y = 0; y < h; y++) {
        for (unsigned x = 0; x < w; x++) {
            uint8_t *px = p + ((size_t)y * w + x) * 4;
            double base[3] = {128 + 90 * sin(x * 0.011 + y * 0.004),
                              128 + 90 * cos(y * 0.013 - x * 0.003),
                              64 + 60 * sin((x + y) * 0.007) + 0.1 * (y % 256)};
            for (int c = 0; c < 3; c++) {
                s = s * 1664525u + 1013904223u;
                double v = base[c] + (double)((s >> 24) % 17) - 8.0;
                px[c] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
            }
            px[3] = 255;
        }
    }
    return p;
}

static unsigned char *tj_encode(const uint8_t *rgba, unsigned w, unsigned h, int q,
                                unsigned long *size)
{
    tjhandle tj = tjInitCompress();
    unsigned char *out = NULL;
    *size = 0;
    int rc = tjCompress2(tj, rgba, (int)w, 0, (int)h, TJPF_RGBA, &out, size, TJSAMP_420, q,
                         TJFLAG_FASTDCT);
    CHECK(rc == 0);
    tjDestroy(tj);
    return out;
}

/* Decodes to RGB; NULL (and a failed check) when it does not decode or has another size. */
static uint8_t *decode(const uint8_t *jpeg, size_t size, unsigned w, unsigned h)
{
    tjhandle tj = tjInitDecompress();
    int dw = 0, dh = 0, sub = 0, cs = 0;
    uint8_t *rgb = NULL;
    if (tjDecompressHeader3(tj, jpeg, (unsigned long)size, &dw, &dh, &sub, &cs) == 0 &&
        dw == (int)w && dh == (int)h) {
        rgb = malloc((size_t)w * h * 3);
        if (tjDecompress2(tj, jpeg, (unsigned long)size, rgb, dw, 0, dh, TJPF_RGB, 0) != 0) {
            fprintf(stderr, "decode: %s\n", tjGetErrorStr2(tj));
            free(rgb);
            rgb = NULL;
        }
    }
    CHECKF(rgb != NULL, "%ux%u: decoded %dx%d", w, h, dw, dh);
    tjDestroy(tj);
    return rgb;
}

static double mean_abs_diff(const uint8_t *a, const uint8_t *b, size_t n, int *max_diff)
{
    double sum = 0;
    int mx = 0;
    for (size_t i = 0; i < n; i++) {
        int d = abs((int)a[i] - (int)b[i]);
        sum += d;
        if (d > mx) mx = d;
    }
    if (max_diff) *max_diff = mx;
    return sum / (double)n;
}

/* Encodes every stripe of plan (one encoder, in order) into bufs. */
static void encode_stripes(srv_jpeg_encoder *e, const srv_jpeg_plan *plan, const uint8_t *rgba,
                           unsigned q, srv_jpeg_buf *bufs)
{
    for (unsigned i = 0; i < plan->stripe_count; i++)
        CHECK(srv_jpeg_encode_stripe(e, plan, rgba, q, i, &bufs[i]) == SRV_JPEG_OK);
}

static uint8_t *join(const srv_jpeg_plan *plan, const srv_jpeg_buf *bufs, size_t *size,
                     srv_jpeg_result *res)
{
    size_t cap = srv_jpeg_join_bound(plan, bufs);
    uint8_t *out = malloc(cap ? cap : 1);
    *res = srv_jpeg_join(plan, bufs, out, cap, size);
    return out;
}

/* The restart markers after SOS, in order: checks they are RST0, RST1, ... (mod 8) and returns
 * how many there are; the DRI value goes to *dri (0 if none), the SOF0 height to *sof_h. */
static unsigned scan_markers(const uint8_t *b, size_t n, unsigned *dri, unsigned *sof_h,
                             bool *in_order)
{
    size_t pos = 2;
    *dri = 0;
    *sof_h = 0;
    *in_order = true;
    while (pos + 4 <= n) {
        unsigned m = b[pos + 1], len = (unsigned)b[pos + 2] << 8 | b[pos + 3];
        if (m == 0xDD) *dri = (unsigned)b[pos + 4] << 8 | b[pos + 5];
        if (m == 0xC0) *sof_h = (unsigned)b[pos + 5] << 8 | b[pos + 6];
        pos += 2 + len;
        if (m == 0xDA) break;
    }
    unsigned rst = 0;
    for (; pos + 1 < n; pos++) {
        if (b[pos] != 0xFF || b[pos + 1] == 0x00) continue;
        unsigned m = b[pos + 1];
        if (m >= 0xD0 && m <= 0xD7) {
            if (m != 0xD0 + (rst & 7)) *in_order = false;
            rst++;
        } else if (m == 0xD9) {
            CHECK(pos + 2 == n); /* EOI ends the file */
        }
        pos++;
    }
    return rst;
}

static void check_plan(unsigned w, unsigned h, unsigned want)
{
    srv_jpeg_plan plan;
    CHECK(srv_jpeg_plan_make(&plan, w, h, want, 1) == SRV_JPEG_OK);
    unsigned mcu_rows = (h + 15) / 16, mcu_cols = (w + 15) / 16;
    CHECKF(plan.stripe_count >= 1 && plan.stripe_count <= want && plan.stripe_count <= mcu_rows,
           "%ux%u / %u: %u stripes", w, h, want, plan.stripe_count);
    unsigned rows = 0;
    for (unsigned i = 0; i < plan.stripe_count; i++) {
        unsigned r = srv_jpeg_stripe_rows(&plan, i);
        CHECK(srv_jpeg_stripe_y(&plan, i) == rows);
        CHECK(r > 0);
        if (i + 1 < plan.stripe_count) CHECK(r % 16 == 0 && r == plan.stripe_height);
        rows += r;
    }
    CHECKF(rows == h, "%ux%u / %u: rows %u", w, h, want, rows);
    CHECK(srv_jpeg_stripe_rows(&plan, plan.stripe_count) == 0);
    if (plan.stripe_count > 1)
        CHECK(plan.restart_interval == plan.stripe_height / 16 * mcu_cols);
    else
        CHECK(plan.restart_interval == 0 && plan.stripe_height == h);
}

static void test_plans(void)
{
    check_plan(1, 1, 16);
    check_plan(17, 9, 7);
    check_plan(1920, 1080, 16); /* 68 MCU rows: 5 a stripe, 14 stripes */
    check_plan(1000, 1001, 3);
    srv_jpeg_plan plan;
    CHECK(srv_jpeg_plan_make(&plan, 1920, 1080, 16, 1) == SRV_JPEG_OK && plan.stripe_count == 14);
    CHECK(srv_jpeg_plan_make(&plan, 1920, 1080, 2, 1) == SRV_JPEG_OK && plan.stripe_count == 2 &&
          plan.stripe_height == 544 && plan.restart_interval == 34 * 120);
    /* at least min_mcu_rows MCU rows a stripe */
    CHECK(srv_jpeg_plan_make(&plan, 640, 64, 16, 2) == SRV_JPEG_OK && plan.stripe_count == 2);
    CHECK(srv_jpeg_plan_make(&plan, 640, 48, 16, 2) == SRV_JPEG_OK && plan.stripe_count == 1);
    /* 65500 wide: 4094 MCUs a row, so a restart interval holds at most 16 MCU rows */
    CHECK(srv_jpeg_plan_make(&plan, 65500, 4096, 1, 1) == SRV_JPEG_OK);
    CHECK(plan.stripe_count == 16 && plan.restart_interval == 16 * 4094);
    CHECK(srv_jpeg_plan_make(&plan, 0, 10, 2, 1) == SRV_JPEG_ERR_ARGS);
    CHECK(srv_jpeg_plan_make(&plan, 10, 65501, 2, 1) == SRV_JPEG_ERR_ARGS);
}

/* One size and stripe count against a single tjCompress2 encode of the same image. */
static void check_striped(srv_jpeg_encoder *e, unsigned w, unsigned h, unsigned want,
                          const uint8_t *rgba, const uint8_t *ref_rgb, size_t ref_size)
{
    srv_jpeg_plan plan;
    CHECK(srv_jpeg_plan_make(&plan, w, h, want, 1) == SRV_JPEG_OK);
    srv_jpeg_buf *bufs = calloc(plan.stripe_count, sizeof *bufs);
    encode_stripes(e, &plan, rgba, QUALITY, bufs);
    size_t size = 0;
    srv_jpeg_result r;
    uint8_t *jpeg = join(&plan, bufs, &size, &r);
    CHECKF(r == SRV_JPEG_OK, "%ux%u / %u: %s", w, h, want, srv_jpeg_strerror(r));

    unsigned dri, sof_h;
    bool in_order;
    unsigned rst = scan_markers(jpeg, size, &dri, &sof_h, &in_order);
    CHECKF(rst == plan.stripe_count - 1 && in_order, "%ux%u / %u: %u RST markers", w, h, want, rst);
    CHECK(dri == plan.restart_interval && sof_h == h);

    /* byte for byte one whole-image encode with that restart interval */
    srv_jpeg_buf whole = {0};
    CHECK(srv_jpeg_encode(e, rgba, w, h, (size_t)w * 4, QUALITY, plan.restart_interval, &whole) ==
          SRV_JPEG_OK);
    CHECKF(whole.size == size && memcmp(whole.data, jpeg, size) == 0,
           "%ux%u / %u: %zu bytes joined, %zu whole", w, h, want, size, whole.size);
    srv_jpeg_buf_free(&whole);

    uint8_t *rgb = decode(jpeg, size, w, h);
    if (rgb && ref_rgb) {
        int mx;
        double mean = mean_abs_diff(rgb, ref_rgb, (size_t)w * h * 3, &mx);
        if (mean > worst_mean) worst_mean = mean;
        CHECKF(mean < MEAN_TOL, "%ux%u / %u stripes: mean |diff| %.4f (max %d)", w, h,
               plan.stripe_count, mean, mx);
    }
    /* restart markers and the first stripe's headers cost a few bytes a stripe */
    double ratio = (double)size / (double)ref_size;
    if (w * h >= 1000000)
        CHECKF(fabs(ratio - 1) < 0.05, "%ux%u: %zu bytes striped, %zu single", w, h, size,
               ref_size);
    else
        CHECKF(size <= ref_size + 8 * plan.stripe_count, "%ux%u: %zu bytes striped, %zu single", w,
               h, size, ref_size);
    free(rgb);
    free(jpeg);
    for (unsigned i = 0; i < plan.stripe_count; i++)
        srv_jpeg_buf_free(&bufs[i]);
    free(bufs);
}

static void test_sizes(srv_jpeg_encoder *e)
{
    static const unsigned sizes[][2] = {{1, 1}, {17, 9}, {640, 360}, {1920, 1080}, {1000, 1001}};
    static const unsigned counts[] = {1, 2, 3, 7, 16};
    for (unsigned s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        unsigned w = sizes[s][0], h = sizes[s][1];
        uint8_t *rgba = make_image(w, h, s);
        unsigned long ref_size;
        unsigned char *ref = tj_encode(rgba, w, h, QUALITY, &ref_size);
        uint8_t *ref_rgb = decode(ref, ref_size, w, h);
        for (unsigned c = 0; c < sizeof counts / sizeof counts[0]; c++)
            check_striped(e, w, h, counts[c], rgba, ref_rgb, ref_size);
        free(ref_rgb);
        tjFree(ref);
        free(rgba);
    }
}

/* Without restarts the encoder is tjCompress2 byte for byte, fast and accurate DCT alike. */
static void test_same_as_turbojpeg(srv_jpeg_encoder *e)
{
    unsigned w = 333, h = 171;
    uint8_t *rgba = make_image(w, h, 9);
    static const int qualities[] = {1, 30, 50, 80, 90, 95, 96, 100};
    for (unsigned i = 0; i < sizeof qualities / sizeof qualities[0]; i++) {
        unsigned long ref_size;
        unsigned char *ref = tj_encode(rgba, w, h, qualities[i], &ref_size);
        srv_jpeg_buf b = {0};
        CHECK(srv_jpeg_encode(e, rgba, w, h, (size_t)w * 4, (unsigned)qualities[i], 0, &b) ==
              SRV_JPEG_OK);
        CHECKF(b.size == ref_size && memcmp(b.data, ref, ref_size) == 0, "q%d: %zu vs %lu bytes",
               qualities[i], b.size, ref_size);
        srv_jpeg_buf_free(&b);
        tjFree(ref);
    }
    free(rgba);
}

/* Wrong order, wrong offset, other tables, broken stripes: what the checks above must notice. */
static void test_failures_noticed(srv_jpeg_encoder *e)
{
    unsigned w = 640, h = 360;
    uint8_t *rgba = make_image(w, h, 2);
    unsigned long ref_size;
    unsigned char *ref = tj_encode(rgba, w, h, QUALITY, &ref_size);
    uint8_t *ref_rgb = decode(ref, ref_size, w, h);
    srv_jpeg_plan plan;
    CHECK(srv_jpeg_plan_make(&plan, w, h, 3, 1) == SRV_JPEG_OK && plan.stripe_count == 3);
    srv_jpeg_buf bufs[3] = {{0}};
    encode_stripes(e, &plan, rgba, QUALITY, bufs);
    size_t size;
    srv_jpeg_result r;

    /* stripes 0 and 1 swapped: a valid file (same heights) with the wrong pixels */
    srv_jpeg_buf swapped[3] = {bufs[1], bufs[0], bufs[2]};
    uint8_t *jpeg = join(&plan, swapped, &size, &r);
    CHECK(r == SRV_JPEG_OK);
    uint8_t *rgb = decode(jpeg, size, w, h);
    if (rgb && ref_rgb) {
        double mean = mean_abs_diff(rgb, ref_rgb, (size_t)w * h * 3, NULL);
        CHECKF(mean > 20 * MEAN_TOL, "swapped stripes: mean |diff| %.3f", mean);
        fprintf(stderr, "swapped stripes: mean |diff| %.3f\n", mean);
    }
    free(rgb);
    free(jpeg);

    /* stripe 1 taken one MCU row too low */
    srv_jpeg_buf shifted = {0};
    size_t stride = (size_t)w * 4;
    unsigned y1 = srv_jpeg_stripe_y(&plan, 1) + 16;
    CHECK(srv_jpeg_encode(e, rgba + y1 * stride, w, srv_jpeg_stripe_rows(&plan, 1), stride, QUALITY,
                          plan.restart_interval, &shifted) == SRV_JPEG_OK);
    srv_jpeg_buf off[3] = {bufs[0], shifted, bufs[2]};
    jpeg = join(&plan, off, &size, &r);
    CHECK(r == SRV_JPEG_OK);
    rgb = decode(jpeg, size, w, h);
    if (rgb && ref_rgb) {
        double mean = mean_abs_diff(rgb, ref_rgb, (size_t)w * h * 3, NULL);
        CHECKF(mean > 20 * MEAN_TOL, "shifted stripe: mean |diff| %.3f", mean);
        fprintf(stderr, "stripe shifted by 16 rows: mean |diff| %.3f\n", mean);
    }
    free(rgb);
    free(jpeg);
    srv_jpeg_buf_free(&shifted);

    /* a stripe at another quality: other quantisation tables */
    srv_jpeg_buf other = {0};
    CHECK(srv_jpeg_encode_stripe(e, &plan, rgba, QUALITY - 10, 1, &other) == SRV_JPEG_OK);
    srv_jpeg_buf mixed[3] = {bufs[0], other, bufs[2]};
    free(join(&plan, mixed, &size, &r));
    CHECK(r == SRV_JPEG_ERR_MISMATCH);
    srv_jpeg_buf_free(&other);

    /* a stripe holding two restart intervals (its DRI and its RST marker do not fit the plan) */
    srv_jpeg_buf two = {0};
    CHECK(srv_jpeg_encode(e, rgba + srv_jpeg_stripe_y(&plan, 1) * stride, w,
                          srv_jpeg_stripe_rows(&plan, 1), stride, QUALITY,
                          plan.restart_interval / 2, &two) == SRV_JPEG_OK);
    srv_jpeg_buf split[3] = {bufs[0], two, bufs[2]};
    free(join(&plan, split, &size, &r));
    CHECK(r == SRV_JPEG_ERR_FORMAT);
    srv_jpeg_buf_free(&two);

    /* truncated (no EOI), not a JPEG, stripe of the wrong height */
    srv_jpeg_buf cut = bufs[2];
    cut.size -= 2;
    srv_jpeg_buf truncated[3] = {bufs[0], bufs[1], cut};
    free(join(&plan, truncated, &size, &r));
    CHECK(r == SRV_JPEG_ERR_FORMAT);
    uint8_t junk[64] = {0xFF, 0xD8, 0xFF, 0xE0, 0x00, 0x70};
    srv_jpeg_buf bad = {junk, sizeof junk, sizeof junk};
    srv_jpeg_buf garbage[3] = {bufs[0], bad, bufs[2]};
    free(join(&plan, garbage, &size, &r));
    CHECK(r == SRV_JPEG_ERR_FORMAT);
    srv_jpeg_buf last_first[3] = {bufs[2], bufs[1], bufs[0]}; /* the last stripe is shorter */
    free(join(&plan, last_first, &size, &r));
    CHECK(r == SRV_JPEG_ERR_FORMAT);

    /* too little room */
    uint8_t small[100];
    CHECK(srv_jpeg_join(&plan, bufs, small, sizeof small, &size) == SRV_JPEG_ERR_SPACE);

    /* bad arguments */
    srv_jpeg_buf b = {0};
    CHECK(srv_jpeg_encode_stripe(e, &plan, rgba, QUALITY, 3, &b) == SRV_JPEG_ERR_ARGS);
    CHECK(srv_jpeg_encode(e, rgba, w, h, stride, 0, 0, &b) == SRV_JPEG_ERR_ARGS);
    CHECK(srv_jpeg_encode(e, rgba, w, h, stride, 101, 0, &b) == SRV_JPEG_ERR_ARGS);
    srv_jpeg_buf_free(&b);

    for (int i = 0; i < 3; i++)
        srv_jpeg_buf_free(&bufs[i]);
    free(ref_rgb);
    tjFree(ref);
    free(rgba);
}

int main(void)
{
    srv_jpeg_encoder *e = srv_jpeg_encoder_create();
    test_plans();
    test_same_as_turbojpeg(e);
    test_sizes(e);
    fprintf(stderr, "correct joins: largest mean |diff| %.4f\n", worst_mean);
    test_failures_noticed(e);
    srv_jpeg_encoder_destroy(e);
    return test_finish();
}
