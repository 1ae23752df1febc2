/* The encoder pool (server/encode/encoder_pool.h) without the daemon: large frames are encoded in
 * stripes and small ones whole, both decoding to the pixels of one tjCompress2 encode at every
 * variant's quality; coefficient frames (the GPU JPEG path) are encoded at their own sets'
 * qualities, whole byte for byte as server/encode/jpeg_coefs.c encodes them and striped to the same
 * pixels; latest frame wins per view while many striped frames of several views race through
 * the threads; every frame ends published or dropped. */
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <turbojpeg.h>

#include "server/encode/encoder_pool.h"
#include "server/encode/jpeg_coefs.h"
#include "server/encode/jpeg_striped.h"
#include "test_util.h"

static srv_image *make_image(unsigned w, unsigned h, unsigned seed)
{
    srv_image *img = srv_image_new(w, h);
    uint32_t s = seed * 2654435761u + 7;
    for (size_t i = 0; i < (size_t)w * h; i++) {
        unsigned x = (unsigned)(i % w), y = (unsigned)(i / w);
        s = s * 1664525u + 1013904223u;
        uint8_t *p = img->data + 4 * i;
        p[0] = (uint8_t)(x * 255 / w + (s >> 29));
        p[1] = (uint8_t)(y * 255 / h + (s >> 28 & 3));
        p[2] = (uint8_t)((x + y + seed * 40) & 255);
        p[3] = 255;
    }
    return img;
}

/* True when jpeg decodes to w x h with exactly the pixels of tjCompress2 at quality q. */
static bool same_as_turbojpeg(const srv_image *img, const srv_jpeg *jpeg)
{
    unsigned w = img->width, h = img->height;
    tjhandle c = tjInitCompress(), d = tjInitDecompress();
    unsigned char *ref = NULL;
    unsigned long ref_size = 0;
    int rc = tjCompress2(c, img->data, (int)w, 0, (int)h, TJPF_RGBA, &ref, &ref_size, TJSAMP_420,
                         (int)jpeg->quality, TJFLAG_FASTDCT);
    uint8_t *a = malloc((size_t)w * h * 3), *b = malloc((size_t)w * h * 3);
    int dw = 0, dh = 0, sub, cs;
    bool ok =
        rc == 0 &&
        tjDecompressHeader3(d, jpeg->data, (unsigned long)jpeg->size, &dw, &dh, &sub, &cs) == 0 &&
        dw == (int)w && dh == (int)h &&
        tjDecompress2(d, jpeg->data, (unsigned long)jpeg->size, a, dw, 0, dh, TJPF_RGB, 0) == 0 &&
        tjDecompress2(d, ref, ref_size, b, dw, 0, dh, TJPF_RGB, 0) == 0 &&
        memcmp(a, b, (size_t)w * h * 3) == 0;
    free(a);
    free(b);
    tjFree(ref);
    tjDestroy(c);
    tjDestroy(d);
    return ok;
}

static void test_paths(void)
{
    srv_encoder_pool *p = srv_encoder_pool_create(3);
    CHECK(p != NULL);
    srv_encoder_set_caps(p, 1u << 2); /* a viewer lags: a q50 variant besides the base one */
    srv_encoder_stats st;

    /* 1920x1080: striped (3 threads, 3 stripes a variant) */
    srv_image *big = make_image(1920, 1080, 1);
    srv_frame_info info = {.frame_id = 1, .view_id = 4};
    srv_encoder_submit(p, big, &info, 85);
    srv_frame *f = srv_encoder_wait_frame(p, 4, 0, 10000);
    CHECK(f != NULL);
    if (f) {
        CHECK(f->width == 1920 && f->height == 1080 && f->variant_count == 2);
        CHECK(f->variants[0].quality == 50 && f->variants[1].quality == 85);
        for (unsigned i = 0; i < f->variant_count; i++)
            CHECKF(same_as_turbojpeg(big, &f->variants[i]), "1080p variant q%u",
                   f->variants[i].quality);
        srv_frame_unref(f);
    }
    srv_encoder_get_stats(p, &st);
    CHECK(st.jpegs_encoded == 2 && st.jpegs_striped == 2 && st.frames_published == 1);

    /* 320x240 (under the threshold): whole, by tjCompress2 */
    srv_image *small = make_image(320, 240, 2);
    info.frame_id = 2;
    srv_encoder_submit(p, small, &info, 85);
    f = srv_encoder_wait_frame(p, 4, 1, 10000);
    CHECK(f != NULL && f->info.frame_id == 2);
    if (f) {
        for (unsigned i = 0; i < f->variant_count; i++)
            CHECK(same_as_turbojpeg(small, &f->variants[i]));
        srv_frame_unref(f);
    }
    srv_encoder_get_stats(p, &st);
    CHECK(st.jpegs_encoded == 4 && st.jpegs_striped == 2);

    /* the threshold lowered: odd sizes in stripes too (100x70: 5 MCU rows, 2 stripes) */
    srv_encoder_set_stripe_min_pixels(p, 1);
    srv_image *odd = make_image(100, 70, 3);
    info.frame_id = 3;
    srv_encoder_submit(p, odd, &info, 85);
    f = srv_encoder_wait_frame(p, 4, 2, 10000);
    CHECK(f != NULL && f->info.frame_id == 3);
    if (f) {
        for (unsigned i = 0; i < f->variant_count; i++)
            CHECK(same_as_turbojpeg(odd, &f->variants[i]));
        srv_frame_unref(f);
    }
    srv_encoder_get_stats(p, &st);
    CHECK(st.jpegs_encoded == 6 && st.jpegs_striped == 4);
    /* never: whole again */
    srv_encoder_set_stripe_min_pixels(p, ~0u);
    info.frame_id = 4;
    srv_encoder_submit(p, big, &info, 85);
    f = srv_encoder_wait_frame(p, 4, 3, 10000);
    CHECK(f != NULL && f->info.frame_id == 4);
    srv_frame_unref(f);
    srv_encoder_get_stats(p, &st);
    CHECK(st.jpegs_encoded == 8 && st.jpegs_striped == 4);

    srv_image_unref(big);
    srv_image_unref(small);
    srv_image_unref(odd);
    srv_encoder_pool_destroy(p);
}

/* Striped frames of three views submitted faster than they encode. */
static void test_latest_wins(void)
{
    enum { VIEWS = 3, FRAMES = 40 };
    srv_encoder_pool *p = srv_encoder_pool_create(4);
    CHECK(p != NULL);
    srv_encoder_set_caps(p, 1u << 1 | 1u << 4); /* three variants: 40, 70, 80 */
    srv_image *img[VIEWS];
    for (unsigned v = 0; v < VIEWS; v++)
        img[v] = make_image(1024 + 64 * v, 576 + 16 * v, 10 + v);
    uint64_t seen[VIEWS] = {0};
    for (unsigned k = 1; k <= FRAMES; k++) {
        for (unsigned v = 0; v < VIEWS; v++) {
            srv_frame_info info = {.frame_id = k, .view_id = v};
            srv_encoder_submit(p, img[v], &info, 80);
            /* what a sender sees: never older than what it saw before */
            srv_frame *f = srv_encoder_latest(p, v);
            if (f) {
                CHECK(f->info.frame_id >= seen[v] && f->variant_count == 3);
                seen[v] = f->info.frame_id;
                srv_frame_unref(f);
            }
        }
        if (k % 10 == 5) { /* a view freed and reused: its history starts again */
            srv_encoder_forget_view(p, 2);
            seen[2] = 0;
        }
        struct timespec pause = {0, 700000}; /* some frames get through */
        nanosleep(&pause, NULL);
    }
    /* the newest frame of every view is never dropped */
    for (unsigned v = 0; v < VIEWS; v++) {
        srv_frame *f = srv_encoder_wait_frame(p, v, FRAMES - 1, 10000);
        CHECKF(f && f->info.frame_id == FRAMES, "view %u", v);
        if (f) {
            CHECK(same_as_turbojpeg(img[v], srv_frame_best(f)));
            srv_frame_unref(f);
        }
    }
    /* every frame ends published or dropped (the older ones' started stripes finish late) */
    srv_encoder_stats st;
    struct timespec pause = {0, 2000000};
    for (int i = 0; i < 5000; i++) {
        srv_encoder_get_stats(p, &st);
        if (st.frames_published + st.frames_dropped == VIEWS * FRAMES) break;
        nanosleep(&pause, NULL);
    }
    CHECKF(st.frames_published + st.frames_dropped == VIEWS * FRAMES,
           "%llu published, %llu dropped", (unsigned long long)st.frames_published,
           (unsigned long long)st.frames_dropped);
    CHECK(st.frames_dropped > 0 && st.jpegs_striped == st.jpegs_encoded);
    fprintf(stderr, "%u frames: %llu published, %llu dropped\n", VIEWS * FRAMES,
            (unsigned long long)st.frames_published, (unsigned long long)st.frames_dropped);

    /* destroyed with work queued: pending stripe jobs are dropped, nothing leaks */
    for (unsigned v = 0; v < VIEWS; v++) {
        srv_frame_info info = {.frame_id = FRAMES + 1, .view_id = v};
        srv_encoder_submit(p, img[v], &info, 80);
    }
    srv_encoder_pool_destroy(p);
    for (unsigned v = 0; v < VIEWS; v++)
        srv_image_unref(img[v]);
}

/* Decoded RGB of a JPEG of w x h (caller frees), NULL when it does not decode as that. */
static uint8_t *decode_rgb(const srv_jpeg *jpeg, unsigned w, unsigned h)
{
    tjhandle d = tjInitDecompress();
    int dw = 0, dh = 0, sub, cs;
    uint8_t *rgb = malloc((size_t)w * h * 3);
    if (tjDecompressHeader3(d, jpeg->data, (unsigned long)jpeg->size, &dw, &dh, &sub, &cs) != 0 ||
        dw != (int)w || dh != (int)h || sub != TJSAMP_420 ||
        tjDecompress2(d, jpeg->data, (unsigned long)jpeg->size, rgb, dw, 0, dh, TJPF_RGB, 0) != 0) {
        free(rgb);
        rgb = NULL;
    }
    tjDestroy(d);
    return rgb;
}

/* Two coefficient sets (qualities 40 and 85) of a 100x70 image, made up on the CPU: a DC ramp
 * and a few low-frequency terms in every block. */
static srv_image *make_coefs(unsigned w, unsigned h)
{
    size_t set = rd_jpeg_coef_bytes(w, h);
    srv_image *img = srv_image_alloc(w, h, 2 * set);
    img->coef_sets = 2;
    img->coef_quality[0] = 40;
    img->coef_quality[1] = 85;
    uint32_t s = 12345;
    for (unsigned k = 0; k < 2; k++) {
        int16_t *c = (int16_t *)(img->data + k * set);
        size_t blocks = set / RD_JPEG_BLOCK_BYTES;
        for (size_t b = 0; b < blocks; b++) {
            memset(c + 64 * b, 0, 128);
            s = s * 1664525u + 1013904223u;
            c[64 * b] = (int16_t)((int)(b % 37) - 18 + (int)(s >> 29));
            c[64 * b + 1] = (int16_t)((int)(s >> 26 & 7) - 3);
            c[64 * b + 8] = (int16_t)((int)(s >> 22 & 7) - 3);
        }
    }
    return img;
}

static void test_coefficients(void)
{
    enum { W = 100, H = 70 };
    srv_encoder_pool *p = srv_encoder_pool_create(3);
    CHECK(p != NULL);
    srv_encoder_set_caps(p, 1u << 2); /* ignored: the sets say the qualities */
    srv_image *img = make_coefs(W, H);
    srv_jpeg_encoder *enc = srv_jpeg_encoder_create();
    srv_jpeg_plan whole;
    CHECK(srv_jpeg_plan_make(&whole, W, H, 1, 1) == SRV_JPEG_OK);
    uint8_t *ref_rgb[2] = {NULL, NULL};
    for (unsigned pass = 0; pass < 2; pass++) { /* whole, then striped (2 stripes) */
        srv_encoder_set_stripe_min_pixels(p, pass == 0 ? ~0u : 1);
        srv_frame_info info = {.frame_id = 1 + pass, .view_id = 9};
        srv_encoder_submit(p, img, &info, 60);
        srv_frame *f = srv_encoder_wait_frame(p, 9, pass, 10000);
        CHECK(f != NULL && f->variant_count == 2);
        if (!f || f->variant_count != 2) {
            srv_frame_unref(f);
            break;
        }
        CHECK(f->variants[0].quality == 40 && f->variants[1].quality == 85);
        for (unsigned k = 0; k < 2; k++) {
            uint8_t *rgb = decode_rgb(&f->variants[k], W, H);
            CHECKF(rgb != NULL, "pass %u: variant q%u decodes", pass, f->variants[k].quality);
            if (pass == 0) {
                srv_jpeg_coefs c = {.blocks =
                                        (const int16_t *)(img->data + k * rd_jpeg_coef_bytes(W, H)),
                                    .width = W,
                                    .height = H,
                                    .quality = img->coef_quality[k]};
                srv_jpeg_buf out = {0};
                CHECK(srv_jpeg_encode_coefs(enc, &whole, &c, 0, &out) == SRV_JPEG_OK);
                CHECKF(out.size == f->variants[k].size &&
                           memcmp(out.data, f->variants[k].data, out.size) == 0,
                       "variant q%u is jpeg_coefs' encode of its set", c.quality);
                srv_jpeg_buf_free(&out);
                ref_rgb[k] = rgb;
            } else {
                CHECKF(rgb && ref_rgb[k] && memcmp(rgb, ref_rgb[k], (size_t)W * H * 3) == 0,
                       "striped variant q%u decodes as the whole one", f->variants[k].quality);
                free(rgb);
            }
        }
        srv_frame_unref(f);
    }
    srv_encoder_stats st;
    srv_encoder_get_stats(p, &st);
    CHECK(st.jpegs_encoded == 4 && st.jpegs_from_gpu == 4 && st.jpegs_striped == 2);
    free(ref_rgb[0]);
    free(ref_rgb[1]);
    srv_jpeg_encoder_destroy(enc);
    srv_image_unref(img);
    srv_encoder_pool_destroy(p);
}

int main(void)
{
    test_paths();
    test_coefficients();
    test_latest_wins();
    return test_finish();
}
