/* video_decode.c: libvpx and dav1d decoders behind video_decode.h. */
#include "video_decode.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <vpx/vp8dx.h>
#include <vpx/vpx_decoder.h>
#ifdef PROBECAST_HAVE_DAV1D
#include <dav1d/dav1d.h>
#endif

struct video_decoder {
    srv_video_codec codec;
    vpx_codec_ctx_t vpx;
    bool vpx_open;
#ifdef PROBECAST_HAVE_DAV1D
    Dav1dContext *dav1d;
    Dav1dPicture pic;
    bool have_pic;
#endif
};

bool video_decoder_open(video_decoder **out, srv_video_codec codec, char *err, size_t err_size)
{
    *out = NULL;
    video_decoder *d = calloc(1, sizeof *d);
    if (!d) abort();
    d->codec = codec;
    if (codec == SRV_VIDEO_VP8 || codec == SRV_VIDEO_VP9) {
        vpx_codec_dec_cfg_t cfg = {.threads = 1};
        if (vpx_codec_dec_init(&d->vpx,
                               codec == SRV_VIDEO_VP8 ? vpx_codec_vp8_dx() : vpx_codec_vp9_dx(),
                               &cfg, 0) != VPX_CODEC_OK) {
            snprintf(err, err_size, "vpx_codec_dec_init: %s", vpx_codec_error(&d->vpx));
            free(d);
            return false;
        }
        d->vpx_open = true;
    } else if (codec == SRV_VIDEO_AV1) {
#ifdef PROBECAST_HAVE_DAV1D
        Dav1dSettings s;
        dav1d_default_settings(&s);
        s.n_threads = 1;
        s.max_frame_delay = 1; /* low latency: a picture for every packet */
        if (dav1d_open(&d->dav1d, &s) < 0) {
            snprintf(err, err_size, "dav1d_open failed");
            free(d);
            return false;
        }
#else
        snprintf(err, err_size, "built without dav1d (deploy/install-test-deps.sh installs it)");
        free(d);
        return false;
#endif
    } else {
        snprintf(err, err_size, "unknown codec %d", (int)codec);
        free(d);
        return false;
    }
    *out = d;
    return true;
}

void video_decoder_close(video_decoder *d)
{
    if (!d) return;
    if (d->vpx_open) vpx_codec_destroy(&d->vpx);
#ifdef PROBECAST_HAVE_DAV1D
    if (d->have_pic) dav1d_picture_unref(&d->pic);
    if (d->dav1d) dav1d_close(&d->dav1d);
#endif
    free(d);
}

static bool vpx_decode(video_decoder *d, const uint8_t *data, size_t size, video_picture *pic,
                       char *err, size_t err_size)
{
    /* a key frame, from the bitstream: VP8's frame tag (RFC 6386 9.1: bit 0 clear); VP9's
     * uncompressed header through libvpx (its peek answers UNSUP_BITSTREAM to VP8 inter frames) */
    bool key;
    if (d->codec == SRV_VIDEO_VP8) {
        key = size > 0 && !(data[0] & 1);
    } else {
        vpx_codec_stream_info_t si = {.sz = sizeof si};
        if (vpx_codec_peek_stream_info(vpx_codec_vp9_dx(), data, (unsigned)size, &si) !=
            VPX_CODEC_OK) {
            snprintf(err, err_size, "vpx_codec_peek_stream_info failed");
            return false;
        }
        key = si.is_kf != 0;
    }
    if (vpx_codec_decode(&d->vpx, data, (unsigned)size, NULL, 0) != VPX_CODEC_OK) {
        snprintf(err, err_size, "vpx_codec_decode: %s", vpx_codec_error(&d->vpx));
        return false;
    }
    vpx_codec_iter_t it = NULL;
    vpx_image_t *img = vpx_codec_get_frame(&d->vpx, &it);
    if (!img || img->fmt != VPX_IMG_FMT_I420) {
        snprintf(err, err_size, "no I420 picture from the packet");
        return false;
    }
    *pic = (video_picture){
        .width = img->d_w,
        .height = img->d_h,
        .y = img->planes[VPX_PLANE_Y],
        .cb = img->planes[VPX_PLANE_U],
        .cr = img->planes[VPX_PLANE_V],
        .y_stride = (size_t)img->stride[VPX_PLANE_Y],
        .c_stride = (size_t)img->stride[VPX_PLANE_U],
        .key = key,
    };
    return true;
}

#ifdef PROBECAST_HAVE_DAV1D
static bool av1_decode(video_decoder *d, const uint8_t *data, size_t size, video_picture *pic,
                       char *err, size_t err_size)
{
    if (d->have_pic) dav1d_picture_unref(&d->pic), d->have_pic = false;
    Dav1dData in = {0};
    uint8_t *buf = dav1d_data_create(&in, size);
    if (!buf) abort();
    memcpy(buf, data, size);
    int r;
    while (in.sz > 0) {
        r = dav1d_send_data(d->dav1d, &in);
        if (r < 0 && r != DAV1D_ERR(EAGAIN)) {
            dav1d_data_unref(&in);
            snprintf(err, err_size, "dav1d_send_data: %d", r);
            return false;
        }
        if (r == DAV1D_ERR(EAGAIN)) break; /* a picture is waiting first */
    }
    memset(&d->pic, 0, sizeof d->pic);
    r = dav1d_get_picture(d->dav1d, &d->pic);
    if (in.sz > 0) dav1d_data_unref(&in);
    if (r < 0) {
        snprintf(err, err_size, "dav1d_get_picture: %d (no picture for the packet)", r);
        return false;
    }
    d->have_pic = true;
    if (d->pic.p.bpc != 8 || d->pic.p.layout != DAV1D_PIXEL_LAYOUT_I420) {
        snprintf(err, err_size, "dav1d picture is not 8-bit I420");
        return false;
    }
    *pic = (video_picture){
        .width = (unsigned)d->pic.p.w,
        .height = (unsigned)d->pic.p.h,
        .y = d->pic.data[0],
        .cb = d->pic.data[1],
        .cr = d->pic.data[2],
        .y_stride = (size_t)d->pic.stride[0],
        .c_stride = (size_t)d->pic.stride[1],
        .key = d->pic.frame_hdr->frame_type == DAV1D_FRAME_TYPE_KEY,
    };
    return true;
}
#endif

bool video_decoder_decode(video_decoder *d, const uint8_t *data, size_t size, video_picture *pic,
                          char *err, size_t err_size)
{
    memset(pic, 0, sizeof *pic);
#ifdef PROBECAST_HAVE_DAV1D
    if (d->codec == SRV_VIDEO_AV1) return av1_decode(d, data, size, pic, err, err_size);
#endif
    return vpx_decode(d, data, size, pic, err, err_size);
}
