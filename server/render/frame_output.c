/* frame_output.c: a frame's image, copied back and handed to the encoders. */
#include "server/render/frame_output.h"

#include <string.h>

#include "server/base/clock.h"
#include "server/encode/jpeg_coefs.h"
#include "server/base/log.h"

/* readback slots kept for frames in flight: a frame delivered with fewer free is copied out of its
 * slot instead of leasing it (on the CPU path every view holds its last frame's slot) */
#define SLOTS_IN_FLIGHT 8u

/* What travels with a frame's copy (the readback slot keeps it). */
typedef struct output_record {
    srv_frame_info info;
    unsigned quality;   /* before the lag-driven caps */
    unsigned coef_sets; /* 0: RGBA8 pixels; else JPEG coefficients at these qualities */
    unsigned char coef_quality[SRV_MAX_VARIANTS];
    bool i420;  /* I420 planes follow the coefficients */
    bool timed; /* the view's passes ran in the same submission */
} output_record;
_Static_assert(sizeof(output_record) <= RD_READBACK_INFO_MAX, "fits a readback slot");
_Static_assert(SRV_MAX_VARIANTS <= RD_JPEG_MAX_SETS, "one JPEG pass quantises every variant");

bool srv_jpeg_path_parse(const char *s, srv_jpeg_path *out)
{
    static const char *const names[] = {"auto", "cpu", "gpu"};
    for (unsigned i = 0; i < 3; i++)
        if (strcmp(s, names[i]) == 0) {
            *out = (srv_jpeg_path)i;
            return true;
        }
    return false;
}

rd_vk_result srv_frame_output_init(srv_frame_output *o, rd_vk *vk, srv_jpeg_path path,
                                   srv_encoder_pool *encoders, srv_stats_board *stats,
                                   srv_views *views, char *err, size_t errlen)
{
    memset(o, 0, sizeof *o);
    o->vk = vk;
    o->encoders = encoders;
    o->stats = stats;
    o->views = views;
    rd_readback_init(&o->rb, vk);
    o->gpu = path == SRV_JPEG_GPU || (path == SRV_JPEG_AUTO && !vk->is_cpu);
    rd_vk_result r = RD_VK_OK;
    if (o->gpu) {
        r = srv_jpeg_dct_create(vk, &o->dct, err, errlen);
        o->gpu = r == RD_VK_OK;
        if (r != RD_VK_OK && path == SRV_JPEG_AUTO) { /* chosen for the user: fall back */
            srv_warn("render", "JPEG pass unavailable (%s): encoding on the CPU", err);
            r = RD_VK_OK;
        }
    }
    if (o->gpu) { /* without it, video viewers of the GPU path get JPEG */
        char why[256];
        o->i420_ok = rd_video_i420_create(vk, &o->i420, why, sizeof why) == RD_VK_OK;
        if (!o->i420_ok) srv_warn("render", "I420 pass unavailable (%s): video is off", why);
    }
    srv_info("render", "JPEG: %s",
             o->gpu ? "colour, DCT and quantisation on the GPU, entropy coding on the encoders"
                    : "libjpeg-turbo on the encoders");
    return r;
}

void srv_frame_output_dispose(srv_frame_output *o)
{
    if (!o->vk) return;
    rd_readback_dispose(&o->rb);
    rd_jpeg_dct_destroy(o->vk, &o->dct);
    rd_video_i420_destroy(o->vk, &o->i420);
    memset(o, 0, sizeof *o);
}

bool srv_frame_output_ready(const srv_frame_output *o)
{
    return rd_readback_has_free(&o->rb);
}

bool srv_frame_output_busy(const srv_frame_output *o)
{
    return rd_readback_busy(&o->rb) > 0;
}

rd_vk_result srv_frame_output_begin(srv_frame_output *o, rd_cmd **cmd, char *err, size_t errlen)
{
    return rd_readback_begin(&o->rb, cmd, err, errlen);
}

void srv_frame_output_abort(srv_frame_output *o)
{
    rd_readback_abort(&o->rb);
}

rd_vk_result srv_frame_output_finish(srv_frame_output *o, srv_view *v, const srv_frame_info *info,
                                     unsigned quality, bool timed, char *err, size_t errlen)
{
    output_record r = {.info = *info, .quality = quality, .timed = timed};
    rd_view *g = &v->gpu;
    if (!o->gpu) { /* the pixels: libjpeg-turbo and the video encoders both take them */
        const rd_readback_part px = {&g->rgba8, (size_t)g->width * g->height * 4};
        return rd_readback_finish_parts(&o->rb, &px, 1, g->width, g->height, &r, sizeof r, err,
                                        errlen);
    }
    /* what the encoders need: JPEG coefficients unless every watcher takes video, I420 planes
     * when some watcher does (never for a still: it goes out as JPEG) */
    r.i420 = o->i420_ok && v->video_watchers > 0 && !info->still;
    if (!r.i420) r.info.video_only = false;
    rd_readback_part parts[2];
    unsigned n_parts = 0;
    rd_vk_result vr = RD_VK_OK;
    if (!r.info.video_only) {
        unsigned q[SRV_MAX_VARIANTS];
        unsigned n = srv_encoder_qualities(o->encoders, quality, q);
        vr = rd_jpeg_dct_record_view(&o->dct, g, &o->rb.open->cmd, q, n, timed, err, errlen);
        r.coef_sets = n;
        for (unsigned i = 0; i < n; i++)
            r.coef_quality[i] = (unsigned char)q[i];
        parts[n_parts++] =
            (rd_readback_part){&g->jpeg_coefs, (size_t)n * rd_jpeg_coef_bytes(g->width, g->height)};
    }
    if (vr == RD_VK_OK && r.i420) {
        vr = rd_video_i420_record_view(&o->i420, g, &o->rb.open->cmd, timed, err, errlen);
        parts[n_parts++] =
            (rd_readback_part){&g->i420, (size_t)rd_i420_layout_of(g->width, g->height).bytes};
    }
    if (vr != RD_VK_OK) {
        rd_readback_abort(&o->rb);
        return vr;
    }
    return rd_readback_finish_parts(&o->rb, parts, n_parts, g->width, g->height, &r, sizeof r, err,
                                    errlen);
}

bool srv_frame_output_again(srv_frame_output *o, srv_view *v, const srv_frame_info *info,
                            unsigned quality)
{
    if (!o->gpu) {
        if (!v->last_image) return false;
        srv_encoder_submit(o->encoders, v->last_image, info, quality);
        return true;
    }
    /* the view's image still holds its last frame unless it was resized since */
    if (!v->gpu_ok || !v->last_frame_id || v->gpu.width != v->width || v->gpu.height != v->height)
        return false;
    char err[256];
    rd_cmd *cmd;
    rd_vk_result vr = srv_frame_output_begin(o, &cmd, err, sizeof err);
    if (vr == RD_VK_OK) vr = srv_frame_output_finish(o, v, info, quality, false, err, sizeof err);
    if (vr != RD_VK_OK) {
        srv_error("render", "still of view %u failed: %s", v->id, err);
        srv_stats_board_error(o->stats, err, o->vk->device_lost);
        return false;
    }
    return true;
}

static void release_slot(void *ctx, unsigned slot)
{
    rd_readback_release(&((srv_frame_output *)ctx)->rb, slot);
}

/* A frame's copy is done: the encoders read it in the readback slot itself (leased until the last
 * reference to the image goes), unless too few slots would be left for frames in flight; then
 * it is copied out. */
static bool on_copy(void *user, const void *blob, unsigned w, unsigned h, const uint8_t *data,
                    size_t bytes, unsigned slot)
{
    srv_frame_output *o = user;
    output_record r;
    memcpy(&r, blob, sizeof r);
    srv_view *v = srv_views_find(o->views, r.info.view_id);
    if (!v) return false;          /* the view went away while its frame was copied */
    if (r.timed && v->in_flight) { /* the view's GPU times are ready now */
        v->in_flight = false;
        char err[256];
        if (rd_view_collect(&v->gpu, err, sizeof err) != RD_VK_OK)
            srv_warn("render", "view %u: frame statistics lost: %s", v->id, err);
        srv_stats_board_frame(o->stats, &v->gpu.stats, w, h, v->last_render_ms,
                              srv_mono_ms() - v->last_render_ms);
    }
    bool lease = rd_readback_free_count(&o->rb) > SLOTS_IN_FLIGHT;
    srv_image *img;
    if (lease) {
        img = srv_image_wrap(w, h, (uint8_t *)data, release_slot, o, slot);
    } else {
        img = srv_image_alloc(w, h, bytes);
        memcpy(img->data, data, bytes);
    }
    img->coef_sets = r.coef_sets;
    for (unsigned i = 0; i < r.coef_sets; i++)
        img->coef_quality[i] = r.coef_quality[i];
    if (r.i420) {
        rd_i420_layout il = rd_i420_layout_of(w, h);
        img->i420_at = (size_t)r.coef_sets * rd_jpeg_coef_bytes(w, h);
        img->i420_y_stride = il.y_stride;
        img->i420_c_stride = il.c_stride;
    }
    r.info.ready_us = srv_unix_us();
    v->last_info = r.info;
    srv_encoder_submit(o->encoders, img, &r.info, r.quality);
    /* the CPU path re-encodes stills from the last image; the GPU path from the view's image */
    srv_image_unref(v->last_image);
    v->last_image = o->gpu ? NULL : srv_image_ref(img);
    srv_image_unref(img);
    return lease;
}

void srv_frame_output_poll(srv_frame_output *o, uint64_t timeout_ns)
{
    char err[256];
    if (rd_readback_poll(&o->rb, timeout_ns, on_copy, o, err, sizeof err) != RD_VK_OK) {
        srv_error("render", "frame readback failed: %s", err);
        srv_stats_board_error(o->stats, err, o->vk->device_lost);
    }
}
