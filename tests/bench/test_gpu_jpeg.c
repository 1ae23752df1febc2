/* test_gpu_jpeg.c: the daemon's GPU JPEG path (renderer/encode/jpeg_dct.c, server/encode/jpeg_coefs.c, driven
 * by tests/bench/jpeg_gpu.c) against libjpeg-turbo at the same quality and 4:2:0 subsampling, at
 * tiny sizes (odd ones too): its coefficients are libjpeg's (accurate integer DCT) but for DCT
 * rounding (at most 1 apart, in at most 2% of them), its JPEG decodes, has the size of
 * tjCompress2's within 5% and decodes to nearly the same pixels; the striped entropy coding
 * decodes to exactly the pixels of the whole one. */
#include <math.h>
#include <stdio.h> /* jpeglib.h needs FILE and size_t first */
#include <stdlib.h>
#include <string.h>
#include <turbojpeg.h>

#include <jpeglib.h>

#include "bench/jpeg_gpu.h"
#include "test_render_util.h"
#include "test_util.h"

static char err[512];

/* Smooth colour gradients, a hard diagonal edge, a saturated disc and per-channel noise: chroma
 * that differs between neighbouring pixels (so skipped chroma averaging shows) and detail in
 * every frequency (so misplaced quantisation steps show). */
static uint8_t *make_image(unsigned w, unsigned h, uint32_t seed)
{
    uint8_t *p = malloc((size_t)w * h * 4);
    for (unsigned y = 0; y < h; y++)
        for (unsigned x = 0; x < w; x++) {
            uint8_t *px = p + ((size_t)y * w + x) * 4;
            double fx = (x + 0.5) / w, fy = (y + 0.5) / h;
            double c[3] = {40 + 180 * fx, 200 - 150 * fy, 90 + 100 * fx * fy};
            if (x + 2 * y < w) c[0] = 230, c[1] *= 0.4; /* the edge */
            double dx = fx - 0.6, dy = fy - 0.5;
            if (dx * dx + dy * dy < 0.05) c[0] = 30, c[1] = 60, c[2] = 240;
            for (int k = 0; k < 3; k++) {
                seed = seed * 1664525u + 1013904223u;
                double v = c[k] + (double)((seed >> 24) % 41) - 20.0;
                px[k] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
            }
            px[3] = 255;
        }
    return p;
}

static double psnr(const uint8_t *a, const uint8_t *b, size_t pixels, int *max_diff)
{
    double se = 0;
    *max_diff = 0;
    for (size_t i = 0; i < pixels; i++)
        for (int k = 0; k < 3; k++) {
            int d = (int)a[4 * i + k] - (int)b[4 * i + k];
            se += (double)d * d;
            if (abs(d) > *max_diff) *max_diff = abs(d);
        }
    double mse = se / (3.0 * (double)pixels);
    return mse > 0 ? 10 * log10(255.0 * 255.0 / mse) : 99.0;
}

/* Decodes a JPEG to RGBA; checks its size and 4:2:0 sampling. NULL on failure. */
static uint8_t *decode(const uint8_t *jpeg, size_t size, unsigned w, unsigned h)
{
    tjhandle tj = tjInitDecompress();
    int jw = 0, jh = 0, sub = -1, cs = -1;
    uint8_t *out = NULL;
    if (tjDecompressHeader3(tj, jpeg, (unsigned long)size, &jw, &jh, &sub, &cs) == 0 &&
        jw == (int)w && jh == (int)h && sub == TJSAMP_420) {
        out = malloc((size_t)w * h * 4);
        if (tjDecompress2(tj, jpeg, (unsigned long)size, out, (int)w, 0, (int)h, TJPF_RGBA, 0) !=
            0) {
            fprintf(stderr, "tjDecompress2: %s\n", tjGetErrorStr2(tj));
            free(out);
            out = NULL;
        }
    }
    tjDestroy(tj);
    return out;
}

/* Compares the GPU's coefficients of every real block with those of libjpeg's own JPEG:
 * returns the largest difference, counts the coefficients and those that differ. */
static int compare_coefs(const jpeg_gpu *g, const uint8_t *jpeg, size_t size, size_t *count,
                         size_t *differ)
{
    struct jpeg_decompress_struct d;
    struct jpeg_error_mgr e;
    d.err = jpeg_std_error(&e);
    jpeg_create_decompress(&d);
    jpeg_mem_src(&d, jpeg, (unsigned long)size);
    jpeg_read_header(&d, TRUE);
    jvirt_barray_ptr *arrays = jpeg_read_coefficients(&d);
    const JBLOCK *all = g->coefs_host.mapped;
    unsigned cols = rd_jpeg_mcu_cols(g->width);
    size_t plane = (size_t)cols * rd_jpeg_mcu_rows(g->height);
    int worst = 0;
    *count = *differ = 0;
    for (int ci = 0; ci < 3; ci++) {
        jpeg_component_info *c = &d.comp_info[ci];
        unsigned s = ci == 0 ? 2 : 1;
        const JBLOCK *base = all + (ci == 0 ? 0 : (size_t)(3 + ci) * plane);
        for (JDIMENSION r = 0; r < c->height_in_blocks; r++) {
            JBLOCKARRAY row = d.mem->access_virt_barray((j_common_ptr)&d, arrays[ci], r, 1, FALSE);
            for (JDIMENSION x = 0; x < c->width_in_blocks; x++)
                for (int k = 0; k < 64; k++) {
                    int a = base[(size_t)r * cols * s + x][k], b = row[0][x][k];
                    if (abs(a - b) > worst) worst = abs(a - b);
                    *differ += a != b;
                    ++*count;
                }
        }
    }
    jpeg_finish_decompress(&d);
    jpeg_destroy_decompress(&d);
    return worst;
}

static void check_size(jpeg_gpu *g, unsigned w, unsigned h, unsigned q)
{
    uint8_t *src = make_image(w, h, w * 131u + h * 7u + q);
    srv_jpeg_buf whole = {0}, joined = {0}, stripes[4] = {{0}};
    uint8_t *ref = NULL, *dec = NULL, *dec_striped = NULL;
    unsigned char *tj_jpeg = NULL;
    unsigned long tj_size = 0;
    tjhandle tj = tjInitCompress();
    VK_CHECK(jpeg_gpu_set_frame(g, src, w, h, q, err, sizeof err));
    VK_CHECK(jpeg_gpu_transform(g, NULL, err, sizeof err));
    CHECKF(jpeg_gpu_entropy(g, &whole, err, sizeof err), "%s", err);
    CHECK(tjCompress2(tj, src, (int)w, 0, (int)h, TJPF_RGBA, &tj_jpeg, &tj_size, TJSAMP_420, (int)q,
                      TJFLAG_ACCURATEDCT) == 0);

    /* the pass writing host memory itself gives the same coefficients */
    g->direct = true;
    srv_jpeg_buf direct = {0};
    VK_CHECK(jpeg_gpu_transform(g, NULL, err, sizeof err));
    CHECKF(jpeg_gpu_entropy(g, &direct, err, sizeof err), "%s", err);
    CHECK(direct.size == whole.size && memcmp(direct.data, whole.data, whole.size) == 0);
    srv_jpeg_buf_free(&direct);
    g->direct = false;

    size_t count = 0, differ = 0;
    int worst = compare_coefs(g, tj_jpeg, tj_size, &count, &differ);
    double ratio = (double)whole.size / (double)tj_size;
    ref = decode(tj_jpeg, tj_size, w, h);
    dec = decode(whole.data, whole.size, w, h);
    CHECKF(dec != NULL, "%ux%u q%u: the GPU path's JPEG does not decode", w, h, q);
    if (!ref || !dec) goto done;
    int max_ref = 0, max_src = 0, max_tj = 0;
    double p_ref = psnr(dec, ref, (size_t)w * h, &max_ref);
    double p_src = psnr(dec, src, (size_t)w * h, &max_src);
    double p_tj = psnr(ref, src, (size_t)w * h, &max_tj);
    printf("%3ux%-3u q%-3u bytes %5zu / %5lu (%.4f), coefficients differing %zu of %zu (max %d), "
           "PSNR vs libjpeg %.1f dB (max diff %d), vs source %.2f dB (libjpeg %.2f dB)\n",
           w, h, q, whole.size, tj_size, ratio, differ, count, worst, p_ref, max_ref, p_src, p_tj);
    CHECKF(fabs(ratio - 1.0) <= 0.05, "%ux%u q%u: %zu bytes against libjpeg's %lu", w, h, q,
           whole.size, tj_size);
    CHECKF(worst <= 1 && differ * 50 <= count, "%ux%u q%u: %zu of %zu coefficients differ", w, h, q,
           differ, count);
    CHECKF(p_ref >= 40.0 && max_ref <= 16, "%ux%u q%u: PSNR %.2f dB, max diff %d", w, h, q, p_ref,
           max_ref);
    CHECKF(p_src >= p_tj - 0.3, "%ux%u q%u: %.2f dB from the source, libjpeg %.2f dB", w, h, q,
           p_src, p_tj);

    /* striped: restart markers between stripes change no pixel */
    srv_jpeg_plan plan;
    CHECK(srv_jpeg_plan_make(&plan, w, h, 3, 1) == SRV_JPEG_OK);
    CHECKF(jpeg_gpu_entropy_striped(g, 3, &plan, stripes, &joined, err, sizeof err), "%s", err);
    dec_striped = decode(joined.data, joined.size, w, h);
    CHECKF(dec_striped && memcmp(dec_striped, dec, (size_t)w * h * 4) == 0,
           "%ux%u q%u: %u stripes decode to other pixels", w, h, q, plan.stripe_count);

    /* bad arguments are refused */
    srv_jpeg_coefs c = jpeg_gpu_coefs(g);
    srv_jpeg_plan other;
    CHECK(srv_jpeg_plan_make(&other, w + 16, h, 1, 1) == SRV_JPEG_OK);
    CHECK(srv_jpeg_encode_coefs(g->coders[0], &other, &c, 0, &whole) == SRV_JPEG_ERR_ARGS);
    CHECK(srv_jpeg_encode_coefs(g->coders[0], &plan, &c, plan.stripe_count, &whole) ==
          SRV_JPEG_ERR_ARGS);
    c.quality = 0;
    CHECK(srv_jpeg_encode_coefs(g->coders[0], &plan, &c, 0, &whole) == SRV_JPEG_ERR_ARGS);
done:
    free(src);
    free(ref);
    free(dec);
    free(dec_striped);
    tjFree(tj_jpeg);
    tjDestroy(tj);
    srv_jpeg_buf_free(&whole);
    srv_jpeg_buf_free(&joined);
    for (int i = 0; i < 4; i++)
        srv_jpeg_buf_free(&stripes[i]);
}

/* One pass at three qualities writes, set by set, exactly the coefficients of three passes at one
 * quality each (the daemon quantises a frame's lag variants in one pass). */
static void check_sets(jpeg_gpu *g, unsigned w, unsigned h)
{
    static const unsigned qs[3] = {30, 60, 90};
    uint8_t *src = make_image(w, h, 99);
    size_t set = rd_jpeg_coef_bytes(w, h);
    rd_buffer sets = {0};
    uint8_t *all = NULL;
    VK_CHECK(jpeg_gpu_set_frame(g, src, w, h, qs[0], err, sizeof err));
    VK_CHECK(rd_buffer_create(g->vk, &sets, 3 * set, RD_MEMORY_READBACK, err, sizeof err));
    rd_cmd cmd;
    VK_CHECK(rd_cmd_begin(g->vk, &cmd, err, sizeof err));
    rd_jpeg_dct_record(&g->dct, &cmd, &g->frame, w, h, qs, 3, &sets);
    rd_cmd_barrier(&cmd);
    VK_CHECK(rd_cmd_submit_wait(g->vk, &cmd, err, sizeof err));
    all = malloc(3 * set);
    VK_CHECK(rd_buffer_download(g->vk, &sets, 0, all, 3 * set, err, sizeof err));
    for (unsigned i = 0; i < 3; i++) {
        VK_CHECK(jpeg_gpu_set_frame(g, src, w, h, qs[i], err, sizeof err));
        VK_CHECK(jpeg_gpu_transform(g, NULL, err, sizeof err));
        CHECKF(memcmp(all + i * set, g->coefs_host.mapped, set) == 0,
               "%ux%u: set %u (q%u) of one pass equals a pass at q%u alone", w, h, i, qs[i], qs[i]);
    }
done:
    free(all);
    free(src);
    rd_buffer_destroy(g->vk, &sets);
}

int main(void)
{
    rd_vk vk;
    jpeg_gpu g = {0};
    if (!test_vk_open(&vk)) return test_finish();
    VK_CHECK(jpeg_gpu_create(&g, &vk, err, sizeof err));
    static const unsigned sizes[][2] = {{40, 24}, {64, 48}, {37, 29}, {17, 9}, {96, 80}};
    static const unsigned qualities[] = {50, 80, 95};
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++)
        for (size_t q = 0; q < sizeof qualities / sizeof qualities[0]; q++)
            check_size(&g, sizes[s][0], sizes[s][1], qualities[q]);
    check_sets(&g, 37, 29);
    check_sets(&g, 96, 80);
done:
    jpeg_gpu_destroy(&g);
    return test_vk_close(&vk);
}
