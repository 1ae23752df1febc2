/* test_environment_reduce.c: environment images are reduced while they are decoded
 * (renderer/env/environment_reduce.c): bit for bit a full decode reduced by rd_env_image_limit, for
 * .hdr and .exr files of odd sizes, tiles and windows; the largest files a client may send hold
 * tens of MiB while they are read, not the GiB of their declared size. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "renderer/env/environment.h"
#include "renderer/exr_writer.h"
#include "renderer/hdr_writer.h"
#include "test_util.h"

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
            pc_bytes b = pc_hdr_write(hdr[i].w, hdr[i].h, rle && hdr[i].w >= 8, pc_noisy_texel);
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
            pc_noisy_texel(x, y, px + (y * 75 + x) * 3);
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
    float *px = pc_exr_test_pixels(16384, 16, 3);
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
    pc_bytes b = pc_hdr_constant(hw, hh, rgbe);
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

int main(void)
{
    test_bounded_memory(); /* first: the peak RSS it measures is its own */
    test_striped_reduction();
    return test_finish();
}
