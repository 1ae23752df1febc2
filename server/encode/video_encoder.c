/* video_encoder.c: VP8/VP9 (libvpx realtime) and AV1 (SVT-AV1 low delay) behind one interface;
 * see video_encoder.h for the contract. */
#include "server/encode/video_encoder.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <svt-av1/EbSvtAv1Enc.h>
#include <time.h>
#include <vpx/vp8cx.h>
#include <vpx/vpx_encoder.h>

/* SVT-AV1 1.4.1 refuses a side under 64 ("Source Width must be at least 64") and an odd one
 * ("Source Width must be even for YUV_420 colorspace"). */
#define AV1_MIN_SIDE 64u
/* How long a frame may take inside SVT-AV1 before encode gives up (its packets are polled). */
#define AV1_TIMEOUT_MS 10000

struct srv_video_encoder {
    srv_video_desc d;
    unsigned cw, ch; /* coded size */
    uint8_t *planes; /* I420, cw x ch (AV1 only; libvpx owns its image) */
    uint64_t frames; /* frames given to the running stream (0: the next is a key frame) */
    uint64_t sent;   /* frames given to srv_video_encode */
    uint8_t *buf;    /* the last packet */
    size_t buf_size, buf_cap;
    bool buf_key;       /* the library marked it a key frame */
    uint64_t buf_frame; /* the frame it encodes */
    /* libvpx */
    vpx_codec_ctx_t vpx;
    vpx_codec_enc_cfg_t cfg;
    vpx_image_t img;
    bool vpx_open, img_open;
    /* SVT-AV1 */
    EbComponentType *svt;
    bool svt_init;
    bool pending; /* a frame in the encoder without its packet */
    bool restart; /* a new stream before the next frame (new bitrate, or after a flush) */
};

static const char *const result_names[] = {
    [SRV_VIDEO_OK] = "ok",
    [SRV_VIDEO_BAD_CODEC] = "unknown video codec",
    [SRV_VIDEO_BAD_SIZE] = "frame size out of range",
    [SRV_VIDEO_BAD_BITRATE] = "bitrate out of range",
    [SRV_VIDEO_BAD_ARG] = "bad argument",
    [SRV_VIDEO_LIBRARY] = "the codec library failed",
    [SRV_VIDEO_NO_MEMORY] = "out of memory",
};

const char *srv_video_strerror(srv_video_result r)
{
    return (unsigned)r < sizeof result_names / sizeof *result_names ? result_names[r]
                                                                    : "unknown result";
}

const char *srv_video_codec_name(srv_video_codec c)
{
    switch (c) {
    case SRV_VIDEO_VP8:
        return "vp8";
    case SRV_VIDEO_VP9:
        return "vp9";
    case SRV_VIDEO_AV1:
        return "av1";
    }
    return NULL;
}

static srv_video_result fail(srv_video_result r, char *err, size_t err_size, const char *fmt, ...)
{
    if (err && err_size) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, err_size, fmt, ap);
        va_end(ap);
    }
    return r;
}

/* ---- colour ---------------------------------------------------------------------------------- */

/* BT.601 limited range, 16-bit fixed point (Kr 0.299, Kb 0.114; Y scaled 219/255, Cb and Cr
 * 224/255): Y = 16 + 0.256788 R + 0.504129 G + 0.097906 B, and so on. */
static inline uint8_t luma(int r, int g, int b)
{
    return (uint8_t)((16829 * r + 33039 * g + 6416 * b + (16 << 16) + 32768) >> 16);
}

/* r, g, b: sums of four samples (a 2x2 block) */
static inline void chroma4(int r, int g, int b, uint8_t *cb, uint8_t *cr)
{
    *cb = (uint8_t)((-9714 * r - 19070 * g + 28784 * b + (512 << 16) + 131072) >> 18);
    *cr = (uint8_t)((28784 * r - 24103 * g - 4681 * b + (512 << 16) + 131072) >> 18);
}

void srv_video_rgba_to_i420(const uint8_t *rgba, size_t stride, unsigned width, unsigned height,
                            uint8_t *y, size_t y_stride, uint8_t *cb, uint8_t *cr, size_t c_stride)
{
    for (unsigned j = 0; j < height; j++) {
        const uint8_t *p = rgba + j * stride;
        uint8_t *o = y + j * y_stride;
        for (unsigned i = 0; i < width; i++, p += 4)
            o[i] = luma(p[0], p[1], p[2]);
    }
    for (unsigned j = 0; j < (height + 1) / 2; j++) {
        const uint8_t *r0 = rgba + 2 * j * stride;
        const uint8_t *r1 = 2 * j + 1 < height ? r0 + stride : r0; /* odd last row: itself */
        for (unsigned i = 0; i < (width + 1) / 2; i++) {
            unsigned x0 = 2 * i, x1 = 2 * i + 1 < width ? 2 * i + 1 : 2 * i;
            int s[3];
            for (int k = 0; k < 3; k++)
                s[k] = r0[4 * x0 + k] + r0[4 * x1 + k] + r1[4 * x0 + k] + r1[4 * x1 + k];
            chroma4(s[0], s[1], s[2], &cb[j * c_stride + i], &cr[j * c_stride + i]);
        }
    }
}

static inline uint8_t clamp8(int v)
{
    return (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
}

void srv_video_i420_to_rgba(const uint8_t *y, size_t y_stride, const uint8_t *cb, const uint8_t *cr,
                            size_t c_stride, unsigned width, unsigned height, uint8_t *rgba,
                            size_t stride)
{
    /* the inverse: R = 1.164384 (Y - 16) + 1.596027 (Cr - 128), and so on */
    for (unsigned j = 0; j < height; j++) {
        uint8_t *o = rgba + j * stride;
        for (unsigned i = 0; i < width; i++, o += 4) {
            int l = 76309 * (y[j * y_stride + i] - 16) + 32768;
            int u = cb[(j / 2) * c_stride + i / 2] - 128, v = cr[(j / 2) * c_stride + i / 2] - 128;
            o[0] = clamp8((l + 104597 * v) >> 16);
            o[1] = clamp8((l - 25675 * u - 53279 * v) >> 16);
            o[2] = clamp8((l + 132201 * u) >> 16);
            o[3] = 255;
        }
    }
}

/* Fills the coded planes beyond width x height (AV1 padding) with the last column and row. */
static void pad_plane(uint8_t *p, size_t stride, unsigned w, unsigned h, unsigned cw, unsigned ch)
{
    for (unsigned j = 0; j < h; j++)
        memset(p + j * stride + w, p[j * stride + w - 1], cw - w);
    for (unsigned j = h; j < ch; j++)
        memcpy(p + j * stride, p + (h - 1) * stride, cw);
}

/* ---- packets ----------------------------------------------------------------------------------
 */

static bool append(srv_video_encoder *e, const void *data, size_t size)
{
    if (e->buf_size + size > e->buf_cap) {
        size_t cap = e->buf_cap ? e->buf_cap : 65536;
        while (cap < e->buf_size + size)
            cap *= 2;
        uint8_t *b = realloc(e->buf, cap);
        if (!b) return false;
        e->buf = b, e->buf_cap = cap;
    }
    memcpy(e->buf + e->buf_size, data, size);
    e->buf_size += size;
    return true;
}

/* ---- libvpx -----------------------------------------------------------------------------------
 */

static unsigned log2_floor(unsigned v)
{
    unsigned l = 0;
    while (v >>= 1)
        l++;
    return l;
}

static srv_video_result vpx_fail(srv_video_encoder *e, const char *what, char *err, size_t err_size)
{
    const char *detail = vpx_codec_error_detail(&e->vpx);
    return fail(SRV_VIDEO_LIBRARY, err, err_size, "%s: %s%s%s", what, vpx_codec_error(&e->vpx),
                detail ? ": " : "", detail ? detail : "");
}

#define VPX_CONTROL(id, value)                                                                     \
    do {                                                                                           \
        if (vpx_codec_control(&e->vpx, id, value) != VPX_CODEC_OK)                                 \
            return vpx_fail(e, "vpx_codec_control(" #id ")", err, err_size);                       \
    } while (0)

static srv_video_result vpx_open(srv_video_encoder *e, char *err, size_t err_size)
{
    const srv_video_desc *d = &e->d;
    vpx_codec_iface_t *iface = d->codec == SRV_VIDEO_VP8 ? vpx_codec_vp8_cx() : vpx_codec_vp9_cx();
    vpx_codec_enc_cfg_t *c = &e->cfg;
    if (vpx_codec_enc_config_default(iface, c, 0) != VPX_CODEC_OK)
        return fail(SRV_VIDEO_LIBRARY, err, err_size, "vpx_codec_enc_config_default failed");
    c->g_w = e->cw, c->g_h = e->ch;
    c->g_timebase.num = 1, c->g_timebase.den = (int)d->fps; /* pts counts frames */
    c->g_threads = d->threads;
    c->g_lag_in_frames = 0; /* one frame in, one packet out */
    c->g_error_resilient = VPX_ERROR_RESILIENT_DEFAULT;
    c->g_pass = VPX_RC_ONE_PASS;
    c->rc_end_usage = VPX_CBR;
    c->rc_target_bitrate = d->bitrate_kbps;
    c->rc_dropframe_thresh = 0; /* every frame gets a packet */
    c->rc_resize_allowed = 0;
    /* WebRTC's realtime buffer of 1 s. WebRTC caps the quantiser at 56 (VP8) / 52 (VP9) and
     * drops frames below that quality; we never drop frames, so the whole range lets CBR reach
     * the target (measured at 320x180: the caps held VP8 at 0.43 Mbit/s for a 0.05 target). */
    c->rc_min_quantizer = 2;
    c->rc_max_quantizer = 63;
    c->rc_undershoot_pct = 50;
    c->rc_overshoot_pct = 50;
    c->rc_buf_sz = 1000, c->rc_buf_initial_sz = 500, c->rc_buf_optimal_sz = 600;
    c->kf_mode = VPX_KF_DISABLED; /* key frames only when asked for */
    if (vpx_codec_enc_init(&e->vpx, iface, c, 0) != VPX_CODEC_OK)
        return vpx_fail(e, "vpx_codec_enc_init", err, err_size);
    e->vpx_open = true;
    unsigned tiles = log2_floor(d->threads);
    if (d->codec == SRV_VIDEO_VP8) {
        VPX_CONTROL(VP8E_SET_CPUUSED, -(int)d->speed);
        VPX_CONTROL(VP8E_SET_ENABLEAUTOALTREF, 0);
        VPX_CONTROL(VP8E_SET_NOISE_SENSITIVITY, 0);
        VPX_CONTROL(VP8E_SET_STATIC_THRESHOLD, 1);
        VPX_CONTROL(VP8E_SET_MAX_INTRA_BITRATE_PCT, 300);
        VPX_CONTROL(VP8E_SET_TOKEN_PARTITIONS, (int)(tiles > 3 ? 3 : tiles));
    } else {
        VPX_CONTROL(VP8E_SET_CPUUSED, (int)d->speed);
        VPX_CONTROL(VP8E_SET_ENABLEAUTOALTREF, 0);
        VPX_CONTROL(VP9E_SET_ROW_MT, 1);
        VPX_CONTROL(VP9E_SET_TILE_COLUMNS, (int)(tiles > 6 ? 6 : tiles));
        VPX_CONTROL(VP9E_SET_AQ_MODE, 3); /* cyclic refresh, as WebRTC */
        VPX_CONTROL(VP9E_SET_NOISE_SENSITIVITY, 0);
        VPX_CONTROL(VP8E_SET_MAX_INTRA_BITRATE_PCT, 300);
        VPX_CONTROL(VP9E_SET_FRAME_PARALLEL_DECODING, 1);
        VPX_CONTROL(VP9E_SET_COLOR_SPACE, VPX_CS_BT_601);
        VPX_CONTROL(VP9E_SET_COLOR_RANGE, VPX_CR_STUDIO_RANGE);
    }
    if (!vpx_img_alloc(&e->img, VPX_IMG_FMT_I420, e->cw, e->ch, 32))
        return fail(SRV_VIDEO_NO_MEMORY, err, err_size, "vpx_img_alloc failed");
    e->img_open = true;
    return SRV_VIDEO_OK;
}

static srv_video_result vpx_encode_frame(srv_video_encoder *e, bool key, char *err, size_t err_size)
{
    vpx_enc_frame_flags_t flags = key ? VPX_EFLAG_FORCE_KF : 0;
    if (vpx_codec_encode(&e->vpx, &e->img, (vpx_codec_pts_t)e->frames, 1, flags, VPX_DL_REALTIME) !=
        VPX_CODEC_OK)
        return vpx_fail(e, "vpx_codec_encode", err, err_size);
    vpx_codec_iter_t it = NULL;
    const vpx_codec_cx_pkt_t *pkt;
    while ((pkt = vpx_codec_get_cx_data(&e->vpx, &it)))
        if (pkt->kind == VPX_CODEC_CX_FRAME_PKT) {
            if (!append(e, pkt->data.frame.buf, pkt->data.frame.sz))
                return fail(SRV_VIDEO_NO_MEMORY, err, err_size, "packet buffer");
            e->buf_key |= (pkt->data.frame.flags & VPX_FRAME_IS_KEY) != 0;
            e->buf_frame = e->sent;
        }
    return SRV_VIDEO_OK;
}

/* ---- SVT-AV1 ----------------------------------------------------------------------------------
 */

static void svt_close(srv_video_encoder *e)
{
    if (e->svt_init) svt_av1_enc_deinit(e->svt);
    if (e->svt) svt_av1_enc_deinit_handle(e->svt);
    e->svt = NULL, e->svt_init = false;
}

static srv_video_result svt_open(srv_video_encoder *e, char *err, size_t err_size)
{
    const srv_video_desc *d = &e->d;
    EbSvtAv1EncConfiguration c;
    memset(&c, 0, sizeof c);
    EbErrorType r = svt_av1_enc_init_handle(&e->svt, NULL, &c);
    if (r != EB_ErrorNone) {
        e->svt = NULL;
        return fail(SRV_VIDEO_LIBRARY, err, err_size, "svt_av1_enc_init_handle: 0x%x", (unsigned)r);
    }
    c.enc_mode = (int8_t)d->speed;
    c.source_width = e->cw, c.source_height = e->ch;
    c.frame_rate_numerator = d->fps, c.frame_rate_denominator = 1;
    c.encoder_bit_depth = 8;
    c.encoder_color_format = EB_YUV420;
    c.pred_structure = SVT_AV1_PRED_LOW_DELAY_B; /* frames in display order: no B-frame delay */
    c.hierarchical_levels = 0;                   /* flat: every frame refers back */
    c.intra_period_length = -1;                  /* key frames only when forced */
    c.intra_refresh_type = SVT_AV1_KF_REFRESH;
    /* force_key_frames: "only supported with RA CRF/CQP mode" in 1.4.1, so srv_video_encode
     * forces a key frame by starting a new encoder (see svt_restart) */
    c.look_ahead_distance = 0;
    c.enable_tf = 0; /* no temporally filtered alt-ref */
    c.enable_overlays = 0;
    c.scene_change_detection = 0;
    c.rate_control_mode = SVT_AV1_RC_MODE_CBR;
    c.target_bit_rate = d->bitrate_kbps * 1000u;
    c.starting_buffer_level_ms = 500, c.optimal_buffer_level_ms = 600;
    c.maximum_buffer_size_ms = 1000;
    c.logical_processors = d->threads;
    c.color_description_present_flag = 1;
    c.color_primaries = EB_CICP_CP_BT_709;
    c.transfer_characteristics = EB_CICP_TC_SRGB;
    c.matrix_coefficients = EB_CICP_MC_BT_601;
    c.color_range = EB_CR_STUDIO_RANGE;
    if ((r = svt_av1_enc_set_parameter(e->svt, &c)) != EB_ErrorNone) {
        svt_close(e);
        return fail(SRV_VIDEO_LIBRARY, err, err_size, "svt_av1_enc_set_parameter: 0x%x",
                    (unsigned)r);
    }
    if ((r = svt_av1_enc_init(e->svt)) != EB_ErrorNone) {
        svt_close(e);
        return fail(SRV_VIDEO_LIBRARY, err, err_size, "svt_av1_enc_init: 0x%x", (unsigned)r);
    }
    e->svt_init = true;
    return SRV_VIDEO_OK;
}

/* Waits for the next packet of the running encoder and appends it (eos: after ending the
 * stream, until its last packet). SVT-AV1 1.4.1 has no blocking receive short of ending the
 * stream, so a running stream is polled. */
static srv_video_result svt_receive(srv_video_encoder *e, bool eos, char *err, size_t err_size)
{
    struct timespec t0, now, nap = {0, 50000};
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (;;) {
        EbBufferHeaderType *pkt = NULL;
        EbErrorType r = svt_av1_enc_get_packet(e->svt, &pkt, eos);
        if (r == EB_ErrorNone && pkt) {
            bool ok = true, last = (pkt->flags & EB_BUFFERFLAG_EOS) != 0;
            if (pkt->n_filled_len > 0) {
                ok = append(e, pkt->p_buffer, pkt->n_filled_len);
                e->buf_key = pkt->pic_type == EB_AV1_KEY_PICTURE;
                e->buf_frame = (uint64_t)pkt->pts;
            }
            svt_av1_enc_release_out_buffer(&pkt);
            if (!ok) return fail(SRV_VIDEO_NO_MEMORY, err, err_size, "packet buffer");
            if (!eos || last) return SRV_VIDEO_OK;
            continue;
        }
        if (r != EB_NoErrorEmptyQueue)
            return fail(SRV_VIDEO_LIBRARY, err, err_size, "svt_av1_enc_get_packet: 0x%x",
                        (unsigned)r);
        clock_gettime(CLOCK_MONOTONIC, &now);
        long ms = (now.tv_sec - t0.tv_sec) * 1000 + (now.tv_nsec - t0.tv_nsec) / 1000000;
        if (ms > AV1_TIMEOUT_MS)
            return fail(SRV_VIDEO_LIBRARY, err, err_size, "SVT-AV1 returned no packet within %d ms",
                        AV1_TIMEOUT_MS);
        nanosleep(&nap, NULL);
    }
}

/* Ends the running stream: its pending frame's packet is appended, the encoder closed. */
static srv_video_result svt_drain(srv_video_encoder *e, char *err, size_t err_size)
{
    srv_video_result r = SRV_VIDEO_OK;
    if (e->svt_init && e->pending) {
        EbBufferHeaderType eos = {.size = sizeof eos, .flags = EB_BUFFERFLAG_EOS};
        EbErrorType er = svt_av1_enc_send_picture(e->svt, &eos);
        r = er == EB_ErrorNone ? svt_receive(e, true, err, err_size)
                               : fail(SRV_VIDEO_LIBRARY, err, err_size,
                                      "svt_av1_enc_send_picture(EOS): 0x%x", (unsigned)er);
    }
    e->pending = false;
    svt_close(e);
    return r;
}

/* A new stream (its first frame a key frame) at the current bitrate: SVT-AV1 1.4.1 can neither
 * force a key frame in low delay nor change the bitrate of a running encoder. The new encoder
 * starts before the old one ends, so a failure keeps the old one. */
static srv_video_result svt_restart(srv_video_encoder *e, char *err, size_t err_size)
{
    srv_video_encoder fresh = *e;
    fresh.svt = NULL, fresh.svt_init = false;
    srv_video_result r = svt_open(&fresh, err, err_size);
    if (r) return r;
    r = svt_drain(e, err, err_size);
    e->svt = fresh.svt, e->svt_init = true;
    e->frames = 0, e->restart = false;
    return r;
}

/* Sends the frame in e->planes; appends the packet of the frame before it (the encoder holds
 * one frame: see srv_video_delay). */
static srv_video_result svt_encode_frame(srv_video_encoder *e, char *err, size_t err_size)
{
    size_t ysz = (size_t)e->cw * e->ch, csz = ysz / 4;
    EbSvtIOFormat io = {
        .luma = e->planes,
        .cb = e->planes + ysz,
        .cr = e->planes + ysz + csz,
        .y_stride = e->cw,
        .cb_stride = e->cw / 2,
        .cr_stride = e->cw / 2,
        .width = e->cw,
        .height = e->ch,
        .color_fmt = EB_YUV420,
        .bit_depth = EB_EIGHT_BIT,
    };
    EbBufferHeaderType in = {
        .size = sizeof in,
        .p_buffer = (uint8_t *)&io,
        .n_filled_len = (uint32_t)(ysz + 2 * csz),
        .n_alloc_len = (uint32_t)(ysz + 2 * csz),
        .pts = (int64_t)e->sent,
        .pic_type = EB_AV1_INVALID_PICTURE, /* the encoder decides: key only as its first */
    };
    EbErrorType r = svt_av1_enc_send_picture(e->svt, &in);
    if (r != EB_ErrorNone)
        return fail(SRV_VIDEO_LIBRARY, err, err_size, "svt_av1_enc_send_picture: 0x%x",
                    (unsigned)r);
    bool had = e->pending;
    e->pending = true;
    /* measured: in low delay without look-ahead, 1.4.1 releases frame n's packet once frame
     * n + 1 has arrived (its low-delay mini-GOP is two frames even at hierarchical_levels 0) */
    return had ? svt_receive(e, false, err, err_size) : SRV_VIDEO_OK;
}

/* ---- the interface ----------------------------------------------------------------------------
 */

static srv_video_result check_bitrate(unsigned kbps, char *err, size_t err_size)
{
    if (kbps < SRV_VIDEO_MIN_KBPS || kbps > SRV_VIDEO_MAX_KBPS)
        return fail(SRV_VIDEO_BAD_BITRATE, err, err_size,
                    "bitrate %u kbit/s is outside %u..%u kbit/s", kbps, SRV_VIDEO_MIN_KBPS,
                    SRV_VIDEO_MAX_KBPS);
    return SRV_VIDEO_OK;
}

static srv_video_result check_desc(srv_video_desc *d, char *err, size_t err_size)
{
    if (!srv_video_codec_name(d->codec))
        return fail(SRV_VIDEO_BAD_CODEC, err, err_size, "unknown video codec %d", (int)d->codec);
    if (d->width < SRV_VIDEO_MIN_SIDE || d->width > SRV_VIDEO_MAX_SIDE ||
        d->height < SRV_VIDEO_MIN_SIDE || d->height > SRV_VIDEO_MAX_SIDE)
        return fail(SRV_VIDEO_BAD_SIZE, err, err_size, "%u x %u is outside %u..%u pixels a side",
                    d->width, d->height, SRV_VIDEO_MIN_SIDE, SRV_VIDEO_MAX_SIDE);
    srv_video_result r = check_bitrate(d->bitrate_kbps, err, err_size);
    if (r) return r;
    if (!d->threads) d->threads = 1;
    if (!d->fps) d->fps = 60;
    static const unsigned speed[][3] = {
        [SRV_VIDEO_VP8] = {SRV_VIDEO_VP8_SPEED, 4, 16},
        [SRV_VIDEO_VP9] = {SRV_VIDEO_VP9_SPEED, 5, 9},
        [SRV_VIDEO_AV1] = {SRV_VIDEO_AV1_SPEED, 8, 13},
    };
    if (!d->speed) d->speed = speed[d->codec][0];
    if (d->threads > SRV_VIDEO_MAX_THREADS || d->fps > 240 || d->speed < speed[d->codec][1] ||
        d->speed > speed[d->codec][2])
        return fail(SRV_VIDEO_BAD_ARG, err, err_size,
                    "threads %u (1..%u), fps %u (1..240) or %s speed %u (%u..%u) out of range",
                    d->threads, SRV_VIDEO_MAX_THREADS, d->fps, srv_video_codec_name(d->codec),
                    d->speed, speed[d->codec][1], speed[d->codec][2]);
    return SRV_VIDEO_OK;
}

static srv_video_result open_codec(srv_video_encoder *e, char *err, size_t err_size)
{
    return e->d.codec == SRV_VIDEO_AV1 ? svt_open(e, err, err_size) : vpx_open(e, err, err_size);
}

srv_video_result srv_video_encoder_create(const srv_video_desc *desc, srv_video_encoder **out,
                                          char *err, size_t err_size)
{
    if (err && err_size) err[0] = '\0';
    if (!out) return fail(SRV_VIDEO_BAD_ARG, err, err_size, "no place for the encoder");
    *out = NULL;
    if (!desc) return fail(SRV_VIDEO_BAD_ARG, err, err_size, "no description");
    srv_video_desc d = *desc;
    srv_video_result r = check_desc(&d, err, err_size);
    if (r) return r;
    srv_video_encoder *e = calloc(1, sizeof *e);
    if (!e) return fail(SRV_VIDEO_NO_MEMORY, err, err_size, "encoder");
    e->d = d;
    e->cw = d.width, e->ch = d.height;
    if (d.codec == SRV_VIDEO_AV1) {
        e->cw = (d.width + 1) & ~1u, e->ch = (d.height + 1) & ~1u;
        if (e->cw < AV1_MIN_SIDE) e->cw = AV1_MIN_SIDE;
        if (e->ch < AV1_MIN_SIDE) e->ch = AV1_MIN_SIDE;
        e->planes = malloc((size_t)e->cw * e->ch * 3 / 2);
        if (!e->planes) {
            free(e);
            return fail(SRV_VIDEO_NO_MEMORY, err, err_size, "picture");
        }
    }
    r = open_codec(e, err, err_size);
    if (r) {
        srv_video_encoder_destroy(e);
        return r;
    }
    *out = e;
    return SRV_VIDEO_OK;
}

void srv_video_encoder_destroy(srv_video_encoder *e)
{
    if (!e) return;
    if (e->vpx_open) vpx_codec_destroy(&e->vpx);
    if (e->img_open) vpx_img_free(&e->img);
    svt_close(e); /* no EOS: SVT-AV1 logs "deinit called without sending EOS" when frames remain */
    free(e->planes);
    free(e->buf);
    free(e);
}

/* Where a frame comes from: RGBA8 pixels (converted here) or I420 planes (copied). */
typedef struct frame_source {
    const uint8_t *rgba;
    size_t stride;
    const uint8_t *y, *cb, *cr;
    size_t y_stride, c_stride;
} frame_source;

static void copy_plane(const uint8_t *src, size_t src_stride, unsigned w, unsigned h, uint8_t *dst,
                       size_t dst_stride)
{
    for (unsigned j = 0; j < h; j++)
        memcpy(dst + j * dst_stride, src + j * src_stride, w);
}

/* The frame into the encoder's planes (Y, Cb, Cr with their strides). */
static void fill_planes(const srv_video_encoder *e, const frame_source *f, uint8_t *y,
                        size_t y_stride, uint8_t *cb, uint8_t *cr, size_t c_stride)
{
    unsigned w = e->d.width, h = e->d.height;
    if (f->rgba) {
        srv_video_rgba_to_i420(f->rgba, f->stride, w, h, y, y_stride, cb, cr, c_stride);
        return;
    }
    copy_plane(f->y, f->y_stride, w, h, y, y_stride);
    copy_plane(f->cb, f->c_stride, (w + 1) / 2, (h + 1) / 2, cb, c_stride);
    copy_plane(f->cr, f->c_stride, (w + 1) / 2, (h + 1) / 2, cr, c_stride);
}

static srv_video_result encode_source(srv_video_encoder *e, const frame_source *f, bool force_key,
                                      srv_video_packet *out, char *err, size_t err_size)
{
    memset(out, 0, sizeof *out);
    unsigned w = e->d.width, h = e->d.height;
    bool key = force_key || e->frames == 0;
    e->buf_size = 0, e->buf_key = false;
    srv_video_result r;
    if (e->d.codec == SRV_VIDEO_AV1) {
        uint8_t *y = e->planes, *cb = y + (size_t)e->cw * e->ch;
        uint8_t *cr = cb + (size_t)e->cw * e->ch / 4;
        unsigned cw = e->cw / 2;
        fill_planes(e, f, y, e->cw, cb, cr, cw);
        pad_plane(y, e->cw, w, h, e->cw, e->ch);
        pad_plane(cb, cw, (w + 1) / 2, (h + 1) / 2, cw, e->ch / 2);
        pad_plane(cr, cw, (w + 1) / 2, (h + 1) / 2, cw, e->ch / 2);
        r = SRV_VIDEO_OK;
        if (e->restart || (key && e->frames > 0)) r = svt_restart(e, err, err_size);
        if (r == SRV_VIDEO_OK) r = svt_encode_frame(e, err, err_size);
    } else {
        vpx_image_t *im = &e->img;
        fill_planes(e, f, im->planes[VPX_PLANE_Y], (size_t)im->stride[VPX_PLANE_Y],
                    im->planes[VPX_PLANE_U], im->planes[VPX_PLANE_V],
                    (size_t)im->stride[VPX_PLANE_U]);
        r = vpx_encode_frame(e, key, err, err_size);
    }
    if (r) return r;
    if (e->buf_size == 0 && e->d.codec != SRV_VIDEO_AV1)
        return fail(SRV_VIDEO_LIBRARY, err, err_size, "%s gave no packet for frame %llu",
                    srv_video_codec_name(e->d.codec), (unsigned long long)e->sent);
    e->frames++, e->sent++;
    out->data = e->buf, out->size = e->buf_size, out->key = e->buf_key;
    out->frame = e->buf_frame;
    return SRV_VIDEO_OK;
}

srv_video_result srv_video_encode(srv_video_encoder *e, const uint8_t *rgba, size_t stride,
                                  bool force_key, srv_video_packet *out, char *err, size_t err_size)
{
    if (err && err_size) err[0] = '\0';
    if (!e || !rgba || !out || stride < (size_t)e->d.width * 4)
        return fail(SRV_VIDEO_BAD_ARG, err, err_size,
                    "no encoder, pixels or packet, or a stride "
                    "under width * 4");
    const frame_source f = {.rgba = rgba, .stride = stride};
    return encode_source(e, &f, force_key, out, err, err_size);
}

srv_video_result srv_video_encode_i420(srv_video_encoder *e, const uint8_t *y, size_t y_stride,
                                       const uint8_t *cb, const uint8_t *cr, size_t c_stride,
                                       bool force_key, srv_video_packet *out, char *err,
                                       size_t err_size)
{
    if (err && err_size) err[0] = '\0';
    if (!e || !y || !cb || !cr || !out || y_stride < e->d.width || c_stride < (e->d.width + 1) / 2)
        return fail(SRV_VIDEO_BAD_ARG, err, err_size,
                    "no encoder, planes or packet, or a stride under the plane's width");
    const frame_source f = {.y = y, .cb = cb, .cr = cr, .y_stride = y_stride, .c_stride = c_stride};
    return encode_source(e, &f, force_key, out, err, err_size);
}

srv_video_result srv_video_flush(srv_video_encoder *e, srv_video_packet *out, char *err,
                                 size_t err_size)
{
    if (err && err_size) err[0] = '\0';
    if (!e || !out) return fail(SRV_VIDEO_BAD_ARG, err, err_size, "no encoder or packet");
    memset(out, 0, sizeof *out);
    e->buf_size = 0, e->buf_key = false;
    if (e->d.codec != SRV_VIDEO_AV1 || !e->pending) return SRV_VIDEO_OK;
    srv_video_result r = svt_drain(e, err, err_size);
    e->restart = true;
    if (r) return r;
    out->data = e->buf, out->size = e->buf_size, out->key = e->buf_key;
    out->frame = e->buf_frame;
    return SRV_VIDEO_OK;
}

unsigned srv_video_delay(const srv_video_encoder *e)
{
    return e->d.codec == SRV_VIDEO_AV1 ? 1 : 0;
}

srv_video_result srv_video_set_bitrate(srv_video_encoder *e, unsigned kbps, char *err,
                                       size_t err_size)
{
    if (err && err_size) err[0] = '\0';
    if (!e) return fail(SRV_VIDEO_BAD_ARG, err, err_size, "no encoder");
    srv_video_result r = check_bitrate(kbps, err, err_size);
    if (r) return r;
    if (e->d.codec != SRV_VIDEO_AV1) {
        unsigned old = e->cfg.rc_target_bitrate;
        e->cfg.rc_target_bitrate = kbps;
        if (vpx_codec_enc_config_set(&e->vpx, &e->cfg) != VPX_CODEC_OK) {
            e->cfg.rc_target_bitrate = old;
            return vpx_fail(e, "vpx_codec_enc_config_set", err, err_size);
        }
        e->d.bitrate_kbps = kbps;
        return SRV_VIDEO_OK;
    }
    e->d.bitrate_kbps = kbps; /* a new stream from the next frame */
    e->restart = true;
    return SRV_VIDEO_OK;
}

void srv_video_coded_size(const srv_video_encoder *e, unsigned *width, unsigned *height)
{
    *width = e->cw, *height = e->ch;
}

srv_video_codec srv_video_encoder_codec(const srv_video_encoder *e)
{
    return e->d.codec;
}
