/* probecast_videobench: JPEG against video (issue 26) on rendered orbits. A benchmark, not a
 * test: nothing is asserted.
 *
 * For each scene and size, the renderer (renderer/render.h, the product's passes with DDGI and
 * the default lighting, as `probecast render` does; on a CPU device the daemon's CPU settings:
 * 64 rays a probe, probe paths 0, near-field rays off) draws an orbit: the scene's camera swings
 * about the point it looks at (its distance to the scene's centre) by --degrees per frame, one
 * probe update a frame after --warmup updates. The tone-mapped RGBA8 frames are kept in memory
 * and encoded:
 *   - JPEG with libjpeg-turbo as the daemon's encoder pool does (tjCompress2, 4:2:0, fast DCT)
 *     at each --qualities, one thread;
 *   - VP8, VP9 and AV1 with server/encode/video_encoder.c at each --bitrates (Mbit/s for
 *     1920x1080 at 60 fps, scaled by the frame's pixels; at least 50 kbit/s), rate control at
 *     60 fps, --threads encoder threads, first frame a key frame and no other.
 * Every frame is decoded (tjDecompress2; libvpx; dav1d for AV1) and compared with its source:
 *   psnr_rgb_db: mean over frames of the RGB PSNR of the decoded frame (each codec's own
 *     conversion back to RGB: JFIF full range for JPEG, BT.601 limited for video, as a browser
 *     does); the fair comparison;
 *   psnr_y_db: mean luma PSNR against the source converted with the codec's matrix (JPEG: JFIF
 *     Y from tjDecompressToYUV2; video: srv_video_rgba_to_i420), limited-range errors scaled by
 *     255/219 so both are in full-range units;
 *   bytes_mean (all frames), bytes_key (the first), bytes_inter (the others), mbps_60: bytes_mean
 *     as Mbit/s at 60 frames a second;
 *   encode_ms_mean and encode_ms_p95 per frame (colour conversion included; AV1's call encodes
 *     the previous frame: see video_encoder.h), on --threads threads (JPEG: 1).
 * It prints a table, and writes video_encode.csv and one SVG per sequence (RGB PSNR against
 * Mbit/s, one line per codec) to --out.
 *
 *   probecast_videobench [--scenes cornell,interior] [--sizes 1280x720,1920x1080] [--frames 60]
 *       [--degrees 1.5] [--warmup 16] [--qualities 40,50,60,70,80,90] [--bitrates 1,2,4,8,16]
 *       [--codecs vp8,vp9,av1] [--threads 1] [--vp8-speed 4..16] [--vp9-speed 5..9]
 *       [--av1-preset 8..13] [--near-field auto|off] [--device SELECTOR] [--machine NAME]
 *       [--out DIR]
 * (speeds: srv_video_desc.speed; unset, SRV_VIDEO_*_SPEED)
 *
 * On lavapipe (two cores) keep it small; tests/bench/results/lavapipe/video_encode.* came from
 *   probecast_videobench --sizes 320x180 --frames 30 --threads 1 --bitrates 1,2,4,8,16,32,64,128
 *       --machine "2-core CPU machine (lavapipe)" --out tests/bench/results/lavapipe
 * and video_encode_640x360.* from --scenes cornell --sizes 640x360 --frames 20
 * --bitrates 2,4,8,16,32,64 (into a scratch --out, files renamed)
 * (each a few minutes at most, mostly rendering; small frames carry more detail a pixel, so the
 * video rates that reach JPEG's quality lie above 16 Mbit/s scaled). On an NVIDIA GPU:
 *   --sizes 1280x720,1920x1080 --threads 1, and again with --threads 4 (encode cost per core
 *   against wall time), --out tests/bench/results/h200 (or h100).
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <turbojpeg.h>
#include <unistd.h>

#include "renderer/builtin/builtin.h"
#include "renderer/render.h"
#include "renderer/scene/default_lighting.h"
#include "server/base/clock.h"
#include "server/encode/video_encoder.h"
#include "server/video_decode.h"

#define MAX_LIST 16

typedef struct options {
    const char *scenes[MAX_LIST];
    unsigned scene_count;
    unsigned sizes[MAX_LIST][2], size_count;
    unsigned frames, warmup, threads;
    double degrees;
    unsigned qualities[MAX_LIST], quality_count;
    double bitrates[MAX_LIST];
    unsigned bitrate_count;
    srv_video_codec codecs[3];
    unsigned codec_count;
    unsigned speed[4]; /* by srv_video_codec: 0 = the encoder's default */
    int near_field;    /* -1: the daemon's for the device; else PC_NEAR_AUTO or PC_NEAR_OFF */
    const char *device, *machine, *out;
} options;

typedef struct result {
    const char *codec;
    unsigned setting; /* JPEG quality or kbit/s */
    unsigned speed;   /* the video encoder's speed (JPEG: 0) */
    double bytes_mean, bytes_key, bytes_inter, mbps, psnr_y, psnr_rgb, ms_mean, ms_p95;
} result;

/* ---- measuring ------------------------------------------------------------------------------- */

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double p95(double *v, unsigned n)
{
    qsort(v, n, sizeof *v, cmp_double);
    unsigned i = (unsigned)(0.95 * (n - 1) + 0.5);
    return v[i < n ? i : n - 1];
}

static double psnr(double se, double n)
{
    return se > 0 ? 10 * log10(255.0 * 255.0 * n / se) : 99.0;
}

/* RGB PSNR of a decoded RGBA frame against the source. */
static double psnr_rgb(const uint8_t *a, const uint8_t *b, size_t pixels)
{
    double se = 0;
    for (size_t i = 0; i < pixels; i++)
        for (int k = 0; k < 3; k++) {
            double d = (double)a[4 * i + k] - b[4 * i + k];
            se += d * d;
        }
    return psnr(se, 3.0 * (double)pixels);
}

/* Luma PSNR; scale multiplies each difference (255/219 for limited range). */
static double psnr_plane(const uint8_t *a, size_t as, const uint8_t *b, size_t bs, unsigned w,
                         unsigned h, double scale)
{
    double se = 0;
    for (unsigned j = 0; j < h; j++)
        for (unsigned i = 0; i < w; i++) {
            double d = ((double)a[j * as + i] - b[j * bs + i]) * scale;
            se += d * d;
        }
    return psnr(se, (double)w * h);
}

static void fill_result(result *r, const double *bytes, double *ms, const double *py,
                        const double *prgb, unsigned n)
{
    double sb = 0, sm = 0, sy = 0, sc = 0;
    for (unsigned i = 0; i < n; i++)
        sb += bytes[i], sm += ms[i], sy += py[i], sc += prgb[i];
    r->bytes_mean = sb / n;
    r->bytes_key = bytes[0];
    r->bytes_inter = n > 1 ? (sb - bytes[0]) / (n - 1) : bytes[0];
    r->mbps = r->bytes_mean * 8 * 60 / 1e6;
    r->psnr_y = sy / n, r->psnr_rgb = sc / n;
    r->ms_mean = sm / n;
    r->ms_p95 = p95(ms, n);
}

/* ---- JPEG --------------------------------------------------------------------------------- */

static void run_jpeg(uint8_t **frames, unsigned n, unsigned w, unsigned h, unsigned q, result *r)
{
    tjhandle c = tjInitCompress(), d = tjInitDecompress();
    double *bytes = calloc(n, sizeof *bytes), *ms = calloc(n, sizeof *ms);
    double *py = calloc(n, sizeof *py), *pc = calloc(n, sizeof *pc);
    uint8_t *rgba = malloc((size_t)w * h * 4), *yuv = malloc(tjBufSizeYUV2(w, 1, h, TJSAMP_420));
    uint8_t *ysrc = malloc((size_t)w * h);
    if (!c || !d || !bytes || !ms || !py || !pc || !rgba || !yuv || !ysrc) abort();
    for (unsigned f = 0; f < n; f++) {
        unsigned char *jpeg = NULL;
        unsigned long size = 0;
        double t0 = srv_mono_ms();
        if (tjCompress2(c, frames[f], (int)w, 0, (int)h, TJPF_RGBA, &jpeg, &size, TJSAMP_420,
                        (int)q, TJFLAG_FASTDCT) != 0) {
            fprintf(stderr, "tjCompress2: %s\n", tjGetErrorStr2(c));
            exit(1);
        }
        ms[f] = srv_mono_ms() - t0;
        bytes[f] = (double)size;
        if (tjDecompress2(d, jpeg, size, rgba, (int)w, 0, (int)h, TJPF_RGBA, 0) != 0 ||
            tjDecompressToYUV2(d, jpeg, size, yuv, (int)w, 1, (int)h, 0) != 0) {
            fprintf(stderr, "tjDecompress: %s\n", tjGetErrorStr2(d));
            exit(1);
        }
        tjFree(jpeg);
        pc[f] = psnr_rgb(rgba, frames[f], (size_t)w * h);
        /* JFIF luma of the source (full range, BT.601 weights), rounded as libjpeg does */
        for (size_t i = 0; i < (size_t)w * h; i++) {
            const uint8_t *p = frames[f] + 4 * i;
            ysrc[i] = (uint8_t)(0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2] + 0.5);
        }
        py[f] = psnr_plane(yuv, w, ysrc, w, w, h, 1.0);
    }
    r->codec = "jpeg", r->setting = q, r->speed = 0;
    fill_result(r, bytes, ms, py, pc, n);
    free(bytes), free(ms), free(py), free(pc), free(rgba), free(yuv), free(ysrc);
    tjDestroy(c);
    tjDestroy(d);
}

/* ---- video -------------------------------------------------------------------------------- */

typedef struct video_run {
    unsigned w, h, n;
    uint8_t **frames;
    video_decoder *dec;
    double *bytes, *py, *pc;
    uint8_t *y, *cb, *cr, *rgba;
    unsigned got;
    double conv_ms; /* the RGBA to I420 conversion alone, summed over the frames decoded */
} video_run;

/* Decodes one packet and compares it with its frame. */
static void take_packet(video_run *v, const srv_video_packet *p)
{
    if (p->size == 0) return;
    unsigned f = (unsigned)p->frame;
    if (f >= v->n) {
        fprintf(stderr, "packet for frame %u of %u\n", f, v->n);
        exit(1);
    }
    v->bytes[f] = (double)p->size;
    v->got++;
    if (!v->dec) return;
    video_picture pic;
    char err[256];
    if (!video_decoder_decode(v->dec, p->data, p->size, &pic, err, sizeof err)) {
        fprintf(stderr, "frame %u: %s\n", f, err);
        exit(1);
    }
    unsigned w = v->w, h = v->h;
    size_t cs = (w + 1) / 2;
    double t0 = srv_mono_ms();
    srv_video_rgba_to_i420(v->frames[f], (size_t)w * 4, w, h, v->y, w, v->cb, v->cr, cs);
    v->conv_ms += srv_mono_ms() - t0;
    v->py[f] = psnr_plane(pic.y, pic.y_stride, v->y, w, w, h, 255.0 / 219.0);
    srv_video_i420_to_rgba(pic.y, pic.y_stride, pic.cb, pic.cr, pic.c_stride, w, h, v->rgba,
                           (size_t)w * 4);
    v->pc[f] = psnr_rgb(v->rgba, v->frames[f], (size_t)w * h);
}

static bool run_video(uint8_t **frames, unsigned n, unsigned w, unsigned h, srv_video_codec codec,
                      unsigned kbps, unsigned threads, unsigned speed, result *r)
{
    char err[256];
    srv_video_encoder *e = NULL;
    srv_video_desc desc = {.codec = codec,
                           .width = w,
                           .height = h,
                           .bitrate_kbps = kbps,
                           .threads = threads,
                           .speed = speed,
                           .fps = 60};
    if (srv_video_encoder_create(&desc, &e, err, sizeof err) != SRV_VIDEO_OK) {
        fprintf(stderr, "%s: %s\n", srv_video_codec_name(codec), err);
        return false;
    }
    video_run v = {.w = w, .h = h, .n = n, .frames = frames};
    size_t cs = (w + 1) / 2, ch = (h + 1) / 2;
    v.bytes = calloc(n, sizeof(double)), v.py = calloc(n, sizeof(double));
    v.pc = calloc(n, sizeof(double));
    v.y = malloc((size_t)w * h), v.cb = malloc(cs * ch), v.cr = malloc(cs * ch);
    v.rgba = malloc((size_t)w * h * 4);
    double *ms = calloc(n, sizeof *ms);
    if (!v.bytes || !v.py || !v.pc || !v.y || !v.cb || !v.cr || !v.rgba || !ms) abort();
    if (!video_decoder_open(&v.dec, codec, err, sizeof err))
        fprintf(stderr, "# %s not decoded (no PSNR): %s\n", srv_video_codec_name(codec), err);
    srv_video_packet p;
    for (unsigned f = 0; f < n; f++) {
        double t0 = srv_mono_ms();
        if (srv_video_encode(e, frames[f], (size_t)w * 4, false, &p, err, sizeof err) != 0) {
            fprintf(stderr, "%s frame %u: %s\n", srv_video_codec_name(codec), f, err);
            exit(1);
        }
        ms[f] = srv_mono_ms() - t0;
        take_packet(&v, &p);
    }
    if (srv_video_flush(e, &p, err, sizeof err) != SRV_VIDEO_OK) {
        fprintf(stderr, "flush: %s\n", err);
        exit(1);
    }
    take_packet(&v, &p);
    if (v.got != n) {
        fprintf(stderr, "%s: %u packets for %u frames\n", srv_video_codec_name(codec), v.got, n);
        exit(1);
    }
    r->codec = srv_video_codec_name(codec), r->setting = kbps, r->speed = speed;
    fill_result(r, v.bytes, ms, v.py, v.pc, n);
    if (!v.dec)
        r->psnr_y = r->psnr_rgb = NAN;
    else /* the conversion was timed where the PSNR is taken */
        printf("# %s %u kbit/s: RGBA to I420 %.2f ms a frame of the encode's %.2f\n", r->codec,
               kbps, v.conv_ms / n, r->ms_mean);
    video_decoder_close(v.dec);
    srv_video_encoder_destroy(e);
    free(v.bytes), free(v.py), free(v.pc), free(v.y), free(v.cb), free(v.cr), free(v.rgba);
    free(ms);
    return true;
}

/* ---- rendering the orbit ------------------------------------------------------------------ */

static void rotate_y(float v[3], double c, double s)
{
    double x = v[0], z = v[2];
    v[0] = (float)(c * x + s * z), v[2] = (float)(-s * x + c * z);
}

/* n frames of the orbit (RGBA8, caller frees), or NULL with a message. */
static uint8_t **render_orbit(rd_vk *vk, const char *scene, unsigned w, unsigned h,
                              const options *o, double *render_ms)
{
    char err[512] = "";
    rd_scene s;
    if (!rd_procedural_build(scene, &s, err, sizeof err)) {
        fprintf(stderr, "%s: %s\n", scene, err);
        return NULL;
    }
    rd_view_camera cam0;
    if (!rd_camera_for_scene(&s, -1, &cam0, err, sizeof err)) {
        fprintf(stderr, "%s: %s\n", scene, err);
        rd_scene_destroy(&s);
        return NULL;
    }
    /* as `probecast render` with the daemon's settings: a black sky, and the default lighting
     * when the scene needs it */
    rd_environment env = {.mode = RD_ENV_UNIFORM, .intensity = 1};
    rd_default_lighting_apply(&s, &cam0, &env, NULL);
    rd_frame_settings fs = {.width = w, .height = h, .env = &env, .seed = 1};
    rd_ddgi_settings gi = {.mode = PC_GI_DDGI, .seed = 1};
    if (vk->is_cpu) {
        /* the daemon's settings on a CPU device (SRV_SETTINGS_CPU in server/api/settings.h) */
        gi.rays = 64, gi.path_bounces = 0, gi.has_path_bounces = true;
        fs.near_field = PC_NEAR_OFF;
    }
    if (o->near_field >= 0) fs.near_field = (unsigned)o->near_field;
    rd_gpu_scene gs;
    rd_renderer r;
    memset(&gs, 0, sizeof gs);
    memset(&r, 0, sizeof r);
    uint8_t **frames = calloc(o->frames, sizeof *frames);
    rd_vk_result vr = rd_gpu_scene_create(vk, &gs, &s, err, sizeof err);
    if (vr == RD_VK_OK) vr = rd_renderer_create(vk, &r, err, sizeof err);
    if (vr == RD_VK_OK)
        vr = rd_renderer_configure_gi(&r, s.bounds_min, s.bounds_max, &gi, err, sizeof err);
    /* the orbit's centre: the point the camera looks at, as far as the scene's centre */
    float c[3], ctr[3];
    for (int k = 0; k < 3; k++)
        ctr[k] = 0.5f * (s.bounds_min[k] + s.bounds_max[k]);
    double dist = 0;
    for (int k = 0; k < 3; k++)
        dist += (ctr[k] - cam0.eye[k]) * (ctr[k] - cam0.eye[k]);
    dist = sqrt(dist);
    for (int k = 0; k < 3; k++)
        c[k] = cam0.eye[k] + (float)dist * cam0.forward[k];
    double t0 = srv_mono_ms();
    for (unsigned f = 0; vr == RD_VK_OK && f < o->frames; f++) {
        double a = (f * o->degrees - 0.5 * o->frames * o->degrees) * M_PI / 180, cs = cos(a),
               sn = sin(a);
        rd_view_camera cam = cam0;
        float rel[3] = {cam0.eye[0] - c[0], cam0.eye[1] - c[1], cam0.eye[2] - c[2]};
        rotate_y(rel, cs, sn);
        rotate_y(cam.forward, cs, sn);
        rotate_y(cam.up, cs, sn);
        for (int k = 0; k < 3; k++)
            cam.eye[k] = c[k] + rel[k];
        fs.gi_updates = f == 0 ? o->warmup : 1;
        vr = rd_renderer_render(&r, &gs, &cam, &fs, err, sizeof err);
        frames[f] = malloc((size_t)w * h * 4);
        if (!frames[f]) abort();
        if (vr == RD_VK_OK) vr = rd_renderer_read_rgba8(&r, frames[f], err, sizeof err);
    }
    *render_ms = (srv_mono_ms() - t0) / o->frames;
    rd_renderer_destroy(&r);
    rd_gpu_scene_destroy(vk, &gs);
    rd_scene_destroy(&s);
    if (vr != RD_VK_OK) {
        fprintf(stderr, "%s: %s: %s\n", scene, rd_vk_strerror(vr), err);
        for (unsigned f = 0; f < o->frames; f++)
            free(frames[f]);
        free(frames);
        return NULL;
    }
    return frames;
}

/* ---- output -----------------------------------------------------------------------------------
 */

/* RGB PSNR against Mbit/s at 60 fps (log axis), one line per codec. */
static void write_svg(const char *path, const char *title, const result *res, unsigned n)
{
    FILE *f = fopen(path, "w");
    if (!f) {
        fprintf(stderr, "cannot write %s\n", path);
        return;
    }
    double x0 = 1e9, x1 = 0, y0 = 1e9, y1 = 0;
    for (unsigned i = 0; i < n; i++) {
        if (isnan(res[i].psnr_rgb)) continue;
        x0 = fmin(x0, res[i].mbps), x1 = fmax(x1, res[i].mbps);
        y0 = fmin(y0, res[i].psnr_rgb), y1 = fmax(y1, res[i].psnr_rgb);
    }
    x0 = pow(2, floor(log2(x0))), x1 = pow(2, ceil(log2(x1)));
    y0 = floor(y0) - 1, y1 = ceil(y1) + 1;
    const double W = 720, H = 440, L = 60, R = 140, T = 40, B = 50;
#define SX(v) (L + (log2(v) - log2(x0)) / (log2(x1) - log2(x0)) * (W - L - R))
#define SY(v) (H - B - ((v)-y0) / (y1 - y0) * (H - T - B))
    fprintf(f,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0f\" height=\"%.0f\" "
            "font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%%\" "
            "height=\"100%%\" fill=\"white\"/>\n<text x=\"%.0f\" y=\"22\" "
            "font-size=\"14\">%s</text>\n",
            W, H, L, title);
    for (double x = x0; x <= x1 * 1.001; x *= 2)
        fprintf(f,
                "<line x1=\"%.1f\" y1=\"%.0f\" x2=\"%.1f\" y2=\"%.0f\" stroke=\"#ddd\"/>"
                "<text x=\"%.1f\" y=\"%.0f\" text-anchor=\"middle\">%g</text>\n",
                SX(x), T, SX(x), H - B, SX(x), H - B + 16, x);
    for (double y = y0; y <= y1; y += 2)
        fprintf(f,
                "<line x1=\"%.0f\" y1=\"%.1f\" x2=\"%.0f\" y2=\"%.1f\" stroke=\"#ddd\"/>"
                "<text x=\"%.0f\" y=\"%.1f\" text-anchor=\"end\">%g</text>\n",
                L, SY(y), W - R, SY(y), L - 6, SY(y) + 4, y);
    fprintf(f,
            "<text x=\"%.0f\" y=\"%.0f\" text-anchor=\"middle\">Mbit/s at 60 fps</text>\n"
            "<text transform=\"translate(16 %.0f) rotate(-90)\" text-anchor=\"middle\">RGB "
            "PSNR (dB)</text>\n",
            (L + W - R) / 2, H - 12, (T + H - B) / 2);
    static const char *names[] = {"jpeg", "vp8", "vp9", "av1"};
    static const char *colours[] = {"#444444", "#d62728", "#1f77b4", "#2ca02c"};
    for (int c = 0; c < 4; c++) {
        fprintf(f, "<polyline fill=\"none\" stroke=\"%s\" stroke-width=\"2\" points=\"",
                colours[c]);
        unsigned last = n;
        for (unsigned i = 0; i < n; i++)
            if (!strcmp(res[i].codec, names[c]) && !isnan(res[i].psnr_rgb)) {
                fprintf(f, "%.1f,%.1f ", SX(res[i].mbps), SY(res[i].psnr_rgb));
                last = i;
            }
        fprintf(f, "\"/>\n");
        if (last == n) continue;
        for (unsigned i = 0; i < n; i++)
            if (!strcmp(res[i].codec, names[c]) && !isnan(res[i].psnr_rgb))
                fprintf(f, "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"3\" fill=\"%s\"/>\n",
                        SX(res[i].mbps), SY(res[i].psnr_rgb), colours[c]);
        fprintf(f, "<text x=\"%.0f\" y=\"%.0f\" fill=\"%s\">%s</text>\n", W - R + 10,
                T + 20 + 18 * c, colours[c], names[c]);
    }
#undef SX
#undef SY
    fprintf(f, "</svg>\n");
    fclose(f);
}

static unsigned split(const char *s, char out[][32], unsigned max)
{
    unsigned n = 0;
    while (*s && n < max) {
        size_t len = strcspn(s, ",");
        snprintf(out[n++], 32, "%.*s", (int)(len < 31 ? len : 31), s);
        s += len;
        if (*s == ',') s++;
    }
    return n;
}

static bool parse(int argc, char **argv, options *o)
{
    static char scene_names[MAX_LIST][32];
    char items[MAX_LIST][32];
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!v) {
            fprintf(stderr, "%s needs a value (see the top of tests/bench/video_encode.c)\n", a);
            return false;
        }
        i++;
        unsigned n;
        if (!strcmp(a, "--scenes")) {
            o->scene_count = split(v, scene_names, MAX_LIST);
            for (unsigned k = 0; k < o->scene_count; k++)
                o->scenes[k] = scene_names[k];
        } else if (!strcmp(a, "--sizes")) {
            n = split(v, items, MAX_LIST);
            o->size_count = 0;
            for (unsigned k = 0; k < n; k++)
                if (sscanf(items[k], "%ux%u", &o->sizes[k][0], &o->sizes[k][1]) == 2)
                    o->size_count++;
        } else if (!strcmp(a, "--qualities")) {
            n = split(v, items, MAX_LIST);
            for (unsigned k = 0; k < n; k++)
                o->qualities[k] = (unsigned)atoi(items[k]);
            o->quality_count = n;
        } else if (!strcmp(a, "--bitrates")) {
            n = split(v, items, MAX_LIST);
            for (unsigned k = 0; k < n; k++)
                o->bitrates[k] = atof(items[k]);
            o->bitrate_count = n;
        } else if (!strcmp(a, "--codecs")) {
            n = split(v, items, 3);
            o->codec_count = 0;
            for (unsigned k = 0; k < n; k++)
                for (int c = SRV_VIDEO_VP8; c <= SRV_VIDEO_AV1; c++)
                    if (!strcmp(items[k], srv_video_codec_name((srv_video_codec)c)))
                        o->codecs[o->codec_count++] = (srv_video_codec)c;
        } else if (!strcmp(a, "--vp8-speed")) {
            o->speed[SRV_VIDEO_VP8] = (unsigned)atoi(v);
        } else if (!strcmp(a, "--vp9-speed")) {
            o->speed[SRV_VIDEO_VP9] = (unsigned)atoi(v);
        } else if (!strcmp(a, "--av1-preset")) {
            o->speed[SRV_VIDEO_AV1] = (unsigned)atoi(v);
        } else if (!strcmp(a, "--frames")) {
            o->frames = (unsigned)atoi(v);
        } else if (!strcmp(a, "--warmup")) {
            o->warmup = (unsigned)atoi(v);
        } else if (!strcmp(a, "--threads")) {
            o->threads = (unsigned)atoi(v);
        } else if (!strcmp(a, "--near-field")) {
            if (strcmp(v, "auto") && strcmp(v, "off")) {
                fprintf(stderr, "--near-field: auto or off\n");
                return false;
            }
            o->near_field = !strcmp(v, "off") ? (int)PC_NEAR_OFF : (int)PC_NEAR_AUTO;
        } else if (!strcmp(a, "--degrees")) {
            o->degrees = atof(v);
        } else if (!strcmp(a, "--device")) {
            o->device = v;
        } else if (!strcmp(a, "--machine")) {
            o->machine = v;
        } else if (!strcmp(a, "--out")) {
            o->out = v;
        } else {
            fprintf(stderr, "unknown option %s\n", a);
            return false;
        }
    }
    return o->frames >= 2 && o->scene_count && o->size_count && o->threads >= 1 && o->warmup >= 1;
}

int main(int argc, char **argv)
{
    options o = {.scenes = {"cornell", "interior"},
                 .scene_count = 2,
                 .sizes = {{1280, 720}, {1920, 1080}},
                 .size_count = 2,
                 .frames = 60,
                 .warmup = 16,
                 .threads = 1,
                 .degrees = 1.5,
                 .near_field = -1,
                 .qualities = {40, 50, 60, 70, 80, 90},
                 .quality_count = 6,
                 .bitrates = {1, 2, 4, 8, 16},
                 .bitrate_count = 5,
                 .codecs = {SRV_VIDEO_VP8, SRV_VIDEO_VP9, SRV_VIDEO_AV1},
                 .codec_count = 3,
                 .machine = "unnamed machine",
                 .out = "."};
    if (!parse(argc, argv, &o)) return 2;
    static const unsigned defaults[4] = {0, SRV_VIDEO_VP8_SPEED, SRV_VIDEO_VP9_SPEED,
                                         SRV_VIDEO_AV1_SPEED};
    for (int c = SRV_VIDEO_VP8; c <= SRV_VIDEO_AV1; c++)
        if (!o.speed[c]) o.speed[c] = defaults[c];
    if (mkdir(o.out, 0777) != 0 && errno != EEXIST) {
        fprintf(stderr, "cannot create %s\n", o.out);
        return 1;
    }
    static rd_vk vk; /* the validation messenger keeps its address */
    char err[512] = "", path[1024];
    if (rd_vk_create(&vk, &(rd_vk_options){.device = o.device}, err, sizeof err) != RD_VK_OK) {
        fprintf(stderr, "Vulkan: %s\n", err);
        return 1;
    }
    snprintf(path, sizeof path, "%s/video_encode.csv", o.out);
    FILE *csv = fopen(path, "w");
    if (!csv) {
        fprintf(stderr, "cannot write %s\n", path);
        return 1;
    }
    fprintf(csv,
            "machine,device,cores,scene,width,height,frames,codec,setting,threads,speed,bytes_mean,"
            "bytes_key,bytes_inter,mbps_60,psnr_y_db,psnr_rgb_db,encode_ms_mean,"
            "encode_ms_p95\n");
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    printf("# video against JPEG, %s (%ld cores), %s; %u frames an orbit (%.2f degrees a frame), "
           "video on %u thread(s) at 60 fps (speeds: VP8 %u, VP9 %u, AV1 preset %u), JPEG on 1; "
           "PSNR means over frames; near-field rays %s\n",
           o.machine, cores, vk.device_name, o.frames, o.degrees, o.threads, o.speed[SRV_VIDEO_VP8],
           o.speed[SRV_VIDEO_VP9], o.speed[SRV_VIDEO_AV1],
           o.near_field < 0 ? "as the daemon has them"
           : o.near_field   ? "off"
                            : "auto");
    for (unsigned si = 0; si < o.scene_count; si++)
        for (unsigned zi = 0; zi < o.size_count; zi++) {
            unsigned w = o.sizes[zi][0], h = o.sizes[zi][1], n = o.frames;
            double render_ms = 0;
            uint8_t **frames = render_orbit(&vk, o.scenes[si], w, h, &o, &render_ms);
            if (!frames) continue;
            printf("# %s %ux%u: rendered in %.1f ms a frame\n", o.scenes[si], w, h, render_ms);
            printf("%-6s %7s %10s %10s %10s %8s %9s %11s %10s %9s\n", "codec", "setting", "bytes",
                   "key_bytes", "inter", "mbps_60", "psnr_y", "psnr_rgb", "enc_ms", "enc_p95");
            unsigned count = 0;
            result res[MAX_LIST * 4];
            for (unsigned q = 0; q < o.quality_count; q++)
                run_jpeg(frames, n, w, h, o.qualities[q], &res[count++]);
            double scale = (double)w * h / (1920.0 * 1080.0);
            for (unsigned c = 0; c < o.codec_count; c++)
                for (unsigned b = 0; b < o.bitrate_count; b++) {
                    double kbps = o.bitrates[b] * 1000 * scale;
                    if (kbps < SRV_VIDEO_MIN_KBPS) kbps = SRV_VIDEO_MIN_KBPS;
                    if (kbps > SRV_VIDEO_MAX_KBPS) kbps = SRV_VIDEO_MAX_KBPS;
                    if (run_video(frames, n, w, h, o.codecs[c], (unsigned)(kbps + 0.5), o.threads,
                                  o.speed[o.codecs[c]], &res[count]))
                        count++;
                }
            for (unsigned i = 0; i < count; i++) {
                const result *r = &res[i];
                bool jpeg = !strcmp(r->codec, "jpeg");
                printf("%-6s %6u%s %10.0f %10.0f %10.0f %8.2f %9.2f %11.2f %10.2f %9.2f\n",
                       r->codec, r->setting, jpeg ? "q" : "k", r->bytes_mean, r->bytes_key,
                       r->bytes_inter, r->mbps, r->psnr_y, r->psnr_rgb, r->ms_mean, r->ms_p95);
                fprintf(csv,
                        "\"%s\",\"%s\",%ld,%s,%u,%u,%u,%s,%u,%u,%u,%.1f,%.0f,%.1f,%.3f,%.3f,"
                        "%.3f,%.3f,%.3f\n",
                        o.machine, vk.device_name, cores, o.scenes[si], w, h, n, r->codec,
                        r->setting, jpeg ? 1 : o.threads, r->speed, r->bytes_mean, r->bytes_key,
                        r->bytes_inter, r->mbps, r->psnr_y, r->psnr_rgb, r->ms_mean, r->ms_p95);
            }
            fflush(stdout);
            char title[640];
            snprintf(title, sizeof title, "%s %ux%u, %u frames: RGB PSNR against Mbit/s (%s)",
                     o.scenes[si], w, h, n, vk.device_name);
            snprintf(path, sizeof path, "%s/video_%s_%ux%u.svg", o.out, o.scenes[si], w, h);
            write_svg(path, title, res, count);
            for (unsigned f = 0; f < n; f++)
                free(frames[f]);
            free(frames);
        }
    fclose(csv);
    rd_vk_destroy(&vk);
    return 0;
}
