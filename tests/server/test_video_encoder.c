/* Video frames (server/encode/video_encoder.h): VP8, VP9 and AV1 encode a moving synthetic
 * sequence at 160x96 and at an odd 97x61; every packet decodes (libvpx; dav1d for AV1) to the
 * source within a PSNR bound, the first and forced frames are key frames and no others are, a
 * lowered bitrate gives fewer bytes (VP8/VP9 without a key frame), and bad parameters are
 * refused with their own result codes. */
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "server/encode/video_encoder.h"
#include "test_util.h"
#include "video_decode.h"

#define FRAMES 24
#define FORCED 12 /* this frame is forced to be a key frame */
#define FPS 30
/* Bounds on the decoded pictures against the source (dB): luma PSNR of every frame (in the
 * limited range's own units) and RGB PSNR of the sequence. The sequence is smooth gradients
 * with a moving disc and stripes, no noise; at the bitrates below (about 0.9 bit a pixel:
 * generous, as a still refresh would be) the codecs measured (x86-64, libvpx 1.12, SVT-AV1
 * 1.4.1) luma 37.5..44.9 dB (lowest frame) and RGB 31.7..35.3 dB (the 4:2:0 chroma of the red
 * disc's edge bounds RGB). The source against the source one frame later (a packet shown for the
 * wrong frame) measures 29.2 dB luma and 23.6 dB RGB, a flat grey picture 17.4 dB RGB: both fail.
 */
#define MIN_PSNR_Y 34.0
#define MIN_PSNR_RGB 28.0

static unsigned bitrate_for(unsigned w, unsigned h)
{
    /* ~0.9 bit per pixel at 30 fps */
    return (unsigned)((double)w * h * FPS * 0.9 / 1000.0);
}

/* Frame t of the sequence: a diagonal gradient drifting right, stripes scrolling down, a disc
 * crossing the frame. RGBA with a stride of w * 4 + 12 bytes (not a multiple of the width). */
static uint8_t *make_frame(unsigned w, unsigned h, unsigned t, size_t *stride)
{
    *stride = (size_t)w * 4 + 12;
    uint8_t *p = calloc(h, *stride);
    if (!p) abort();
    double cx = (0.15 + 0.7 * t / FRAMES) * w, cy = 0.5 * h + 0.25 * h * sin(t * 0.3);
    double r = 0.18 * (w < h ? w : h);
    for (unsigned y = 0; y < h; y++)
        for (unsigned x = 0; x < w; x++) {
            uint8_t *px = p + y * *stride + 4 * x;
            double g = 40 + 150.0 * (x + 2.0 * t) / (w + h) + 60.0 * y / h;
            double s = ((y + 2 * t) / 6) % 2 ? 25 : 0;
            double col[3] = {g + s, 0.7 * g + 30, 200 - 0.5 * g};
            double dx = x - cx, dy = y - cy;
            if (dx * dx + dy * dy < r * r) col[0] = 230, col[1] = 180 - dy, col[2] = 40;
            for (int c = 0; c < 3; c++)
                px[c] = (uint8_t)(col[c] < 0 ? 0 : col[c] > 255 ? 255 : col[c]);
            px[3] = 255;
        }
    return p;
}

static double psnr(double se, double n)
{
    return se > 0 ? 10 * log10(255.0 * 255.0 * n / se) : 99.0;
}

/* Luma and RGB PSNR of the top-left w x h of the decoded picture against the source. */
static void compare(const video_picture *pic, const uint8_t *src, size_t stride, unsigned w,
                    unsigned h, double *py, double *prgb)
{
    uint8_t *y = malloc((size_t)w * h), *c = malloc((size_t)(w + 1) / 2 * ((h + 1) / 2) * 2);
    uint8_t *rgb = malloc((size_t)w * h * 4);
    if (!y || !c || !rgb) abort();
    size_t cs = (w + 1) / 2;
    srv_video_rgba_to_i420(src, stride, w, h, y, w, c, c + cs * ((h + 1) / 2), cs);
    srv_video_i420_to_rgba(pic->y, pic->y_stride, pic->cb, pic->cr, pic->c_stride, w, h, rgb,
                           (size_t)w * 4);
    double sy = 0, sc = 0;
    for (unsigned j = 0; j < h; j++)
        for (unsigned i = 0; i < w; i++) {
            double d = (double)pic->y[j * pic->y_stride + i] - y[j * w + i];
            sy += d * d;
            for (int k = 0; k < 3; k++) {
                d = (double)rgb[((size_t)j * w + i) * 4 + k] - src[j * stride + 4 * i + k];
                sc += d * d;
            }
        }
    *py = psnr(sy, (double)w * h);
    *prgb = psnr(sc, 3.0 * w * h);
    free(y);
    free(c);
    free(rgb);
}

/* What test_sequence gathers from the packets it decodes. */
typedef struct seq_state {
    const char *name;
    unsigned w, h, cw, ch, packets;
    video_decoder *dec;
    double min_y, sum_se_rgb, sum_bytes;
} seq_state;

/* Checks one packet (of frame pkt->frame) and decodes it against its source. */
static void check_packet(seq_state *s, const srv_video_packet *pkt)
{
    char err[256];
    unsigned t = (unsigned)pkt->frame;
    CHECKF(pkt->size > 0 && t < FRAMES && t == s->packets,
           "%s: packet of frame %u, %zu bytes, "
           "expected frame %u",
           s->name, t, pkt->size, s->packets);
    if (pkt->size == 0 || t >= FRAMES) return;
    s->packets++;
    s->sum_bytes += (double)pkt->size;
    bool want_key = t == 0 || t == FORCED;
    CHECKF(pkt->key == want_key, "%s %ux%u frame %u: key %d", s->name, s->w, s->h, t, pkt->key);
    if (!s->dec) return;
    video_picture pic;
    bool ok = video_decoder_decode(s->dec, pkt->data, pkt->size, &pic, err, sizeof err);
    CHECKF(ok, "%s %ux%u frame %u: %s", s->name, s->w, s->h, t, err);
    if (!ok) return;
    CHECKF(pic.width == s->cw && pic.height == s->ch, "%s: decoded %ux%u, coded %ux%u", s->name,
           pic.width, pic.height, s->cw, s->ch);
    CHECKF(pic.key == want_key, "%s frame %u: the decoder saw key %d", s->name, t, pic.key);
    size_t stride;
    uint8_t *src = make_frame(s->w, s->h, t, &stride);
    double py, prgb;
    compare(&pic, src, stride, s->w, s->h, &py, &prgb);
    free(src);
    if (py < s->min_y) s->min_y = py;
    s->sum_se_rgb += 255.0 * 255.0 * pow(10, -prgb / 10);
    CHECKF(py >= MIN_PSNR_Y, "%s %ux%u frame %u: luma PSNR %.2f dB", s->name, s->w, s->h, t, py);
}

static void test_sequence(srv_video_codec codec, unsigned w, unsigned h)
{
    seq_state s = {.name = srv_video_codec_name(codec), .w = w, .h = h, .min_y = 99};
    char err[256] = "";
    srv_video_encoder *e = NULL;
    srv_video_desc desc = {.codec = codec,
                           .width = w,
                           .height = h,
                           .bitrate_kbps = bitrate_for(w, h),
                           .fps = FPS,
                           .threads = 2};
    srv_video_result r = srv_video_encoder_create(&desc, &e, err, sizeof err);
    CHECKF(r == SRV_VIDEO_OK, "%s %ux%u: %s: %s", s.name, w, h, srv_video_strerror(r), err);
    if (r) return;
    CHECK(srv_video_encoder_codec(e) == codec);
    unsigned delay = srv_video_delay(e);
    CHECK(delay == (codec == SRV_VIDEO_AV1 ? 1u : 0u));
    srv_video_coded_size(e, &s.cw, &s.ch);
    CHECK(s.cw >= w && s.ch >= h);
    if (codec != SRV_VIDEO_AV1) CHECK(s.cw == w && s.ch == h);

    bool decode = video_decoder_open(&s.dec, codec, err, sizeof err);
    if (!decode) printf("# %s: packets not decoded: %s\n", s.name, err);
    CHECKF(decode || codec == SRV_VIDEO_AV1, "%s decoder: %s", s.name, err);

    srv_video_packet pkt;
    for (unsigned t = 0; t < FRAMES; t++) {
        size_t stride;
        uint8_t *src = make_frame(w, h, t, &stride);
        r = srv_video_encode(e, src, stride, t == FORCED, &pkt, err, sizeof err);
        free(src);
        CHECKF(r == SRV_VIDEO_OK, "%s frame %u: %s", s.name, t, err);
        if (r) break;
        /* a packet for every frame, delay frames late */
        CHECKF((pkt.size > 0) == (t >= delay), "%s frame %u: %zu bytes", s.name, t, pkt.size);
        if (pkt.size) check_packet(&s, &pkt);
    }
    CHECK(srv_video_flush(e, &pkt, err, sizeof err) == SRV_VIDEO_OK);
    CHECKF((pkt.size > 0) == (delay > 0), "%s flush: %zu bytes", s.name, pkt.size);
    if (pkt.size) check_packet(&s, &pkt);
    CHECKF(s.packets == FRAMES, "%s: %u packets", s.name, s.packets);
    if (s.dec) {
        double rgb = 10 * log10(255.0 * 255.0 * s.packets / s.sum_se_rgb);
        printf("%s %ux%u (coded %ux%u) at %u kbit/s: %.0f bytes a frame, luma PSNR min %.2f dB, "
               "RGB PSNR %.2f dB\n",
               s.name, w, h, s.cw, s.ch, desc.bitrate_kbps, s.sum_bytes / FRAMES, s.min_y, rgb);
        CHECKF(rgb >= MIN_PSNR_RGB, "%s %ux%u: RGB PSNR %.2f dB", s.name, w, h, rgb);
    } else {
        printf("%s %ux%u at %u kbit/s: %.0f bytes a frame (not decoded)\n", s.name, w, h,
               desc.bitrate_kbps, s.sum_bytes / FRAMES);
    }
    video_decoder_close(s.dec);
    srv_video_encoder_destroy(e);
}

/* 40 frames at a bitrate the sequence fills, then 40 at a quarter of it: the last 10 of each
 * are compared (the rate control's buffer of a second has drained by then). */
static void test_bitrate_change(srv_video_codec codec)
{
    enum { HALF = 40, TAIL = 10 };
    const char *name = srv_video_codec_name(codec);
    unsigned w = 160, h = 96, high = 240, low = 60;
    char err[256] = "";
    srv_video_encoder *e = NULL;
    srv_video_desc desc = {
        .codec = codec, .width = w, .height = h, .bitrate_kbps = high, .fps = FPS};
    srv_video_result r = srv_video_encoder_create(&desc, &e, err, sizeof err);
    CHECKF(r == SRV_VIDEO_OK, "%s: %s", name, err);
    if (r) return;
    video_decoder *dec = NULL;
    bool decode = video_decoder_open(&dec, codec, err, sizeof err);
    double bytes[2] = {0, 0};
    /* one round more: the flush, for AV1's last packet */
    for (unsigned t = 0; t <= 2 * HALF; t++) {
        if (t == HALF) {
            r = srv_video_set_bitrate(e, low, err, sizeof err);
            CHECKF(r == SRV_VIDEO_OK, "%s set_bitrate: %s", name, err);
        }
        srv_video_packet pkt;
        if (t == 2 * HALF) {
            r = srv_video_flush(e, &pkt, err, sizeof err);
        } else {
            size_t stride;
            uint8_t *src = make_frame(w, h, t % FRAMES, &stride);
            r = srv_video_encode(e, src, stride, false, &pkt, err, sizeof err);
            free(src);
        }
        CHECKF(r == SRV_VIDEO_OK, "%s frame %u: %s", name, t, err);
        if (r) break;
        if (pkt.size == 0) continue;
        unsigned f = (unsigned)pkt.frame;
        /* AV1 restarts its stream at a bitrate change; VP8 and VP9 change in place */
        bool want_key = f == 0 || (f == HALF && codec == SRV_VIDEO_AV1);
        CHECKF(pkt.key == want_key, "%s frame %u: key %d", name, f, pkt.key);
        if (decode) {
            video_picture pic;
            CHECKF(video_decoder_decode(dec, pkt.data, pkt.size, &pic, err, sizeof err),
                   "%s frame %u after a bitrate change: %s", name, f, err);
        }
        if (f % HALF >= HALF - TAIL) bytes[f / HALF] += (double)pkt.size;
    }
    printf("%s: %u kbit/s %.0f bytes a frame, then %u kbit/s %.0f bytes a frame\n", name, high,
           bytes[0] / TAIL, low, bytes[1] / TAIL);
    /* a quarter of the bitrate must at least halve the bytes (measured: see the output) */
    CHECKF(bytes[1] < 0.5 * bytes[0], "%s: %.0f bytes after lowering, %.0f before", name, bytes[1],
           bytes[0]);
    video_decoder_close(dec);
    srv_video_encoder_destroy(e);
}

static void expect_refused(const srv_video_desc *d, srv_video_result want, const char *what)
{
    char err[256] = "";
    srv_video_encoder *e = (srv_video_encoder *)&err; /* must be reset to NULL */
    srv_video_result r = srv_video_encoder_create(d, &e, err, sizeof err);
    CHECKF(r == want, "%s: got %s (%s), want %s", what, srv_video_strerror(r), err,
           srv_video_strerror(want));
    CHECKF(e == NULL, "%s: an encoder came back", what);
    CHECKF(r == SRV_VIDEO_OK || err[0] != '\0', "%s: no message", what);
    srv_video_encoder_destroy(e);
}

static void test_bad_parameters(void)
{
    const srv_video_desc good = {
        .codec = SRV_VIDEO_VP8, .width = 160, .height = 96, .bitrate_kbps = 500};
    srv_video_desc d;
#define REFUSE(field, value, want)                                                                 \
    do {                                                                                           \
        d = good;                                                                                  \
        d.field = value;                                                                           \
        expect_refused(&d, want, #field " = " #value);                                             \
    } while (0)
    REFUSE(codec, (srv_video_codec)0, SRV_VIDEO_BAD_CODEC);
    REFUSE(codec, (srv_video_codec)4, SRV_VIDEO_BAD_CODEC);
    REFUSE(width, 0, SRV_VIDEO_BAD_SIZE);
    REFUSE(width, 15, SRV_VIDEO_BAD_SIZE);
    REFUSE(height, 4097, SRV_VIDEO_BAD_SIZE);
    REFUSE(width, 100000, SRV_VIDEO_BAD_SIZE);
    REFUSE(bitrate_kbps, 0, SRV_VIDEO_BAD_BITRATE);
    REFUSE(bitrate_kbps, 49, SRV_VIDEO_BAD_BITRATE);
    REFUSE(bitrate_kbps, 100001, SRV_VIDEO_BAD_BITRATE);
    REFUSE(bitrate_kbps, 4000000000u, SRV_VIDEO_BAD_BITRATE);
    REFUSE(threads, 65, SRV_VIDEO_BAD_ARG);
    REFUSE(fps, 241, SRV_VIDEO_BAD_ARG);
    REFUSE(speed, 17, SRV_VIDEO_BAD_ARG);
    REFUSE(speed, 3, SRV_VIDEO_BAD_ARG);
#undef REFUSE
    d = good;
    d.codec = SRV_VIDEO_AV1, d.speed = 7; /* AV1 presets 8..13 only */
    expect_refused(&d, SRV_VIDEO_BAD_ARG, "AV1 preset 7");
    expect_refused(NULL, SRV_VIDEO_BAD_ARG, "no description");
    CHECK(srv_video_encoder_create(&good, NULL, NULL, 0) == SRV_VIDEO_BAD_ARG);

    /* a working encoder refuses a bad bitrate change and a short stride, and keeps working */
    char err[256];
    srv_video_encoder *e = NULL;
    CHECK(srv_video_encoder_create(&good, &e, err, sizeof err) == SRV_VIDEO_OK);
    if (!e) return;
    CHECK(srv_video_set_bitrate(e, 0, err, sizeof err) == SRV_VIDEO_BAD_BITRATE);
    CHECK(strstr(err, "kbit/s") != NULL);
    CHECK(srv_video_set_bitrate(e, SRV_VIDEO_MAX_KBPS + 1, err, sizeof err) ==
          SRV_VIDEO_BAD_BITRATE);
    size_t stride;
    uint8_t *src = make_frame(160, 96, 0, &stride);
    srv_video_packet pkt;
    CHECK(srv_video_encode(e, src, 160 * 4 - 1, false, &pkt, err, sizeof err) == SRV_VIDEO_BAD_ARG);
    CHECK(srv_video_encode(e, NULL, stride, false, &pkt, err, sizeof err) == SRV_VIDEO_BAD_ARG);
    CHECK(srv_video_encode(e, src, stride, false, NULL, err, sizeof err) == SRV_VIDEO_BAD_ARG);
    CHECK(srv_video_encode(e, src, stride, false, &pkt, err, sizeof err) == SRV_VIDEO_OK);
    CHECK(pkt.size > 0 && pkt.key);
    free(src);
    srv_video_encoder_destroy(e);
    srv_video_encoder_destroy(NULL);
    CHECK(strcmp(srv_video_strerror((srv_video_result)99), "unknown result") == 0);
    CHECK(srv_video_codec_name((srv_video_codec)0) == NULL);
}

/* The conversion round trip: grey levels, primaries and a smooth ramp survive I420 within the
 * rounding of 8-bit limited range (Y keeps 220 levels of 256: at most 1 level each way, plus
 * the 2x2 chroma of flat colour, at most 2 in total). */
static void test_colour(void)
{
    enum { W = 17, H = 5 }; /* odd: the last column and row of chroma average what they have */
    uint8_t src[W * H * 4], y[W * H], cb[9 * 3], cr[9 * 3], back[W * H * 4];
    static const uint8_t colours[][3] = {{0, 0, 0},   {255, 255, 255}, {128, 128, 128}, {255, 0, 0},
                                         {0, 255, 0}, {0, 0, 255},     {200, 120, 40}};
    for (size_t c = 0; c < sizeof colours / sizeof *colours; c++) {
        for (int i = 0; i < W * H; i++)
            memcpy(src + 4 * i, colours[c], 3), src[4 * i + 3] = 255;
        srv_video_rgba_to_i420(src, W * 4, W, H, y, W, cb, cr, 9);
        srv_video_i420_to_rgba(y, W, cb, cr, 9, W, H, back, W * 4);
        int worst = 0;
        for (int i = 0; i < W * H * 4; i++) {
            int d = abs((int)back[i] - (int)src[i]);
            if (d > worst) worst = d;
        }
        CHECKF(worst <= 2, "colour (%u, %u, %u): off by %d", colours[c][0], colours[c][1],
               colours[c][2], worst);
    }
    /* limited range: black and white at 16 and 235, neutral chroma at 128 */
    memset(src, 0, sizeof src);
    srv_video_rgba_to_i420(src, W * 4, W, H, y, W, cb, cr, 9);
    CHECK(y[0] == 16 && cb[0] == 128 && cr[0] == 128);
    memset(src, 255, sizeof src);
    srv_video_rgba_to_i420(src, W * 4, W, H, y, W, cb, cr, 9);
    CHECK(y[W * H - 1] == 235 && cb[26] == 128 && cr[26] == 128);
}

int main(void)
{
    test_colour();
    test_bad_parameters();
    static const srv_video_codec codecs[] = {SRV_VIDEO_VP8, SRV_VIDEO_VP9, SRV_VIDEO_AV1};
    for (int i = 0; i < 3; i++) {
        test_sequence(codecs[i], 160, 96);
        test_sequence(codecs[i], 97, 61);
        test_bitrate_change(codecs[i]);
    }
    return test_finish();
}
