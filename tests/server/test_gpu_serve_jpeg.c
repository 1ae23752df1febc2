/* The daemon's two JPEG paths end to end on lavapipe (probecast serve --jpeg): the same scene,
 * camera and size served with --jpeg cpu (libjpeg-turbo encodes the pixels) and --jpeg gpu (the
 * JPEG pass in the frame's command buffer, the encoders entropy-code its coefficients):
 *  - both answer GET /v1/frame.jpg with a 4:2:0 JPEG of the view's size (odd, not a multiple of
 *    the 16-pixel MCU) whose quantisation tables are libjpeg's for the quality it announces;
 *  - they decode to nearly the same picture (the GPU path's float DCT against libjpeg-turbo's
 *    fast integer one);
 *  - /v1/stats names the path, and only the GPU daemon counts JPEGs from GPU coefficients;
 *  - on the GPU path, input gives interactive frames at the interactive quality and, once it
 *    stops, a still at the still quality re-encoded from the view's image (nothing rendered),
 *    and a viewer's JPEG cap re-encodes the still under the cap (the stream may carry a lower
 *    lag variant to a slow viewer; GET /v1/frame.jpg?view= gives the still's best one);
 *  - a viewer taking VP9 on the GPU path gets it from the I420 pass, with no JPEG made for its
 *    view's moving frames, and GET /v1/frame.jpg of that view still gets a JPEG;
 *  - a path other than auto, gpu or cpu (flag or $PROBECAST_JPEG) is refused at start (exit 2).
 * The frames here are small, so encoded whole; striped coefficient frames are covered by
 * test_encoder_pool and test_gpu_jpeg, the lag-driven variants by test_gpu_serve_lag run on the
 * GPU path (tests/CMakeLists.txt).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <turbojpeg.h>

#include <jpeglib.h>

#include "serve_util.h"
#include "server/encode/jpeg_coefs.h"
#include "test_util.h"

#define W 97
#define H 61

static const char *const base_args[] = {
    "--no-animate", "--width", "97", "--height", "61", "--gi", "off", "--scene", "builtin:cornell"};

static bool start(pc_daemon *d, const char *path)
{
    const char *args[32];
    unsigned n = 0;
    for (unsigned i = 0; i < sizeof base_args / sizeof base_args[0]; i++)
        args[n++] = base_args[i];
    args[n++] = "--jpeg";
    args[n++] = path;
    args[n] = NULL;
    return pc_daemon_start(d, args);
}

/* The JPEG's quantisation tables are libjpeg's for quality q. */
static bool tables_match(const uint8_t *jpeg, size_t size, unsigned q)
{
    struct jpeg_decompress_struct c;
    struct jpeg_error_mgr e;
    c.err = jpeg_std_error(&e);
    jpeg_create_decompress(&c);
    jpeg_mem_src(&c, jpeg, (unsigned long)size);
    bool ok = jpeg_read_header(&c, TRUE) == JPEG_HEADER_OK;
    uint16_t want[2][64];
    srv_jpeg_quant_tables(q, want);
    for (int t = 0; ok && t < 2; t++)
        for (int k = 0; ok && k < 64; k++)
            ok = c.quant_tbl_ptrs[t] && c.quant_tbl_ptrs[t]->quantval[k] == want[t][k];
    jpeg_destroy_decompress(&c);
    return ok;
}

/* GET path (/v1/frame.jpg[?view=ID]): decoded RGB (caller frees), its announced quality and
 * frame id; NULL on failure. */
static uint8_t *get_frame(pc_daemon *d, const char *path, unsigned *quality, uint64_t *id,
                          const char *what)
{
    pc_http_response r;
    uint8_t *rgb = NULL;
    CHECKF(pc_api(d, "GET", path, NULL, true, &r) == 200, "%s: a frame", what);
    const char *qh = r.headers ? strstr(r.headers, "X-Frame-Quality: ") : NULL;
    const char *ih = r.headers ? strstr(r.headers, "X-Frame-Id: ") : NULL;
    *quality = qh ? (unsigned)atoi(qh + 17) : 0;
    *id = ih ? strtoull(ih + 12, NULL, 10) : 0;
    tjhandle tj = tjInitDecompress();
    int w = 0, h = 0, sub = -1, cs = -1;
    if (r.status == 200 && tjDecompressHeader3(tj, (const uint8_t *)r.body,
                                               (unsigned long)r.body_len, &w, &h, &sub, &cs) == 0) {
        CHECKF(w == W && h == H && sub == TJSAMP_420, "%s: %dx%d, subsampling %d", what, w, h, sub);
        CHECKF(tables_match((const uint8_t *)r.body, r.body_len, *quality),
               "%s: the tables are libjpeg's for quality %u", what, *quality);
        rgb = malloc((size_t)W * H * 3);
        if (w != W || h != H ||
            tjDecompress2(tj, (const uint8_t *)r.body, (unsigned long)r.body_len, rgb, W, 0, H,
                          TJPF_RGB, 0) != 0) {
            free(rgb);
            rgb = NULL;
        }
    }
    CHECKF(rgb != NULL, "%s: the frame decodes", what);
    tjDestroy(tj);
    pc_http_response_free(&r);
    return rgb;
}

static void check_stats(pc_daemon *d, const char *path, bool from_gpu)
{
    cJSON *st = pc_api_get_json(d, "/v1/stats");
    const cJSON *enc = cJSON_GetObjectItemCaseSensitive(st, "encoder");
    const cJSON *p = cJSON_GetObjectItemCaseSensitive(enc, "path");
    CHECKF(cJSON_IsString(p) && strcmp(p->valuestring, path) == 0, "stats name the %s path", path);
    double n = pc_json_number(enc, "jpegs_from_gpu"), all = pc_json_number(enc, "jpegs_encoded");
    CHECKF(all >= 1 && (from_gpu ? n == all : n == 0), "%s: %g of %g JPEGs from GPU coefficients",
           path, n, all);
    cJSON_Delete(st);
}

/* Waits up to 30 s for the next still of view on ws (acknowledging frames); counts the
 * interactive frames before it and their highest quality. False when none came. */
static bool next_still(pc_ws *ws, uint32_t view, pc_frame *still, unsigned *interactive,
                       unsigned *q_interactive)
{
    double start = pc_now_ms();
    while (pc_now_ms() - start < 30000) {
        pc_frame f;
        if (!pc_stream_next(ws, 5000, true, &f)) continue;
        if (f.h.view_id == view) {
            CHECK(f.h.width == W && f.h.height == H && f.rgb != NULL);
            if (f.h.flags & 1) {
                *still = f;
                return true;
            }
            ++*interactive;
            if (f.h.quality > *q_interactive) *q_interactive = f.h.quality;
        }
        pc_frame_free(&f);
    }
    return false;
}

/* The view's newest frame over HTTP is the still frame_id, whose best variant has quality q
 * (the stream may carry a lower variant to a viewer whose acknowledgements lag). */
static void check_best(pc_daemon *d, uint32_t view, uint64_t frame_id, unsigned q)
{
    char path[64];
    snprintf(path, sizeof path, "/v1/frame.jpg?view=%u", view);
    unsigned quality = 0;
    uint64_t id = 0;
    uint8_t *rgb = get_frame(d, path, &quality, &id, "the still");
    CHECKF(id == frame_id && quality == q, "the still %llu at quality %u: got %llu at %u",
           (unsigned long long)frame_id, q, (unsigned long long)id, quality);
    free(rgb);
}

/* On the GPU daemon: interactive frames at quality 60 (or a lag variant under it), then the
 * still at 90, then (after a JPEG cap of 40 from this viewer) the still again at 40, all
 * decoding to the view's size. */
static void check_stills(pc_daemon *d)
{
    pc_ws ws;
    uint32_t view = 0;
    CHECK(pc_stream_open_v2(d, &ws, &view));
    pc_frame f;
    CHECK(pc_stream_next(&ws, 60000, true, &f)); /* the view's first frame */
    pc_frame_free(&f);
    for (int i = 0; i < 5; i++) {
        char msg[160];
        pc_camera_msg(msg, sizeof msg, i + 1, 0.1 * i, 1, 3.5, 0, 1, 0);
        CHECK(pc_ws_send_text(&ws, msg) == 0);
        pc_sleep_ms(30);
    }
    unsigned interactive = 0, q_interactive = 0;
    pc_frame still;
    bool got = next_still(&ws, view, &still, &interactive, &q_interactive);
    CHECKF(got, "a still after the input");
    CHECKF(interactive >= 1 && q_interactive >= 1 && q_interactive <= 60,
           "%u interactive frames, quality up to %u", interactive, q_interactive);
    if (got) {
        CHECKF(still.h.quality >= 1 && still.h.quality <= 90, "the still's quality %u",
               still.h.quality);
        check_best(d, view, still.h.frame_id, 90);
        pc_frame_free(&still);
    }

    /* a JPEG cap while idle: the still again, under the cap */
    CHECK(pc_ws_send_text(&ws, "{\"type\":\"quality\",\"jpeg\":40,\"max_fps\":null}") == 0);
    interactive = q_interactive = 0;
    got = next_still(&ws, view, &still, &interactive, &q_interactive);
    CHECKF(got, "a still under the new cap");
    if (got) {
        CHECKF(still.h.quality >= 1 && still.h.quality <= 40 && still.mean > 5,
               "the capped still: quality %u, mean %.1f", still.h.quality, still.mean);
        check_best(d, view, still.h.frame_id, 40);
        pc_frame_free(&still);
    }
    pc_ws_close(&ws);
}

/* On the GPU daemon, a viewer that takes VP9: its moving frames come as VP9 of the view's (odd)
 * size, made from the GPU's I420 planes with no JPEG (the view's only watcher takes video), and
 * GET /v1/frame.jpg of that view still answers with a JPEG. */
static void check_video(pc_daemon *d)
{
    pc_ws ws;
    uint32_t view = 0;
    CHECK(pc_stream_open_v2(d, &ws, &view));
    CHECK(pc_ws_send_text(&ws, "{\"type\":\"video\",\"codec\":\"vp9\",\"max_kbps\":null}") == 0);
    unsigned vp9 = 0, sized = 0;
    for (int i = 0; i < 40; i++) {
        char msg[160];
        pc_camera_msg(msg, sizeof msg, i + 1, 0.02 * i, 1, 3.5, 0, 1, 0);
        CHECK(pc_ws_send_text(&ws, msg) == 0);
        double end = pc_now_ms() + 40;
        for (int left; (left = (int)(end - pc_now_ms())) > 0;) {
            uint8_t *data;
            size_t len;
            int op = pc_ws_recv(&ws, left, &data, &len);
            if (op <= 0) break;
            proto_frame_header h;
            const uint8_t *payload;
            if (op != 2 || proto_frame_header_unpack(data, len, &h, &payload) != PROTO_OK) continue;
            vp9 += h.format == PROTO_FORMAT_VP9;
            sized += h.format == PROTO_FORMAT_VP9 && h.width == W && h.height == H;
            char ack[96];
            snprintf(ack, sizeof ack, "{\"type\":\"ack\",\"frame\":%llu}",
                     (unsigned long long)h.frame_id);
            pc_ws_send_text(&ws, ack);
        }
    }
    printf("video viewer on the GPU path: %u VP9 frames (%u of %ux%u)\n", vp9, sized, W, H);
    CHECKF(vp9 >= 3 && sized == vp9, "VP9 frames from the GPU's planes: %u (%u sized)", vp9, sized);
    cJSON *stats = pc_api_get_json(d, "/v1/stats");
    const cJSON *enc = cJSON_GetObjectItemCaseSensitive(stats, "encoder");
    CHECKF(pc_json_number(enc, "frames_video_only") >= 1, "frames without JPEG: %g",
           pc_json_number(enc, "frames_video_only"));
    cJSON_Delete(stats);
    char path[64];
    snprintf(path, sizeof path, "/v1/frame.jpg?view=%u", view);
    unsigned quality = 0;
    uint64_t id = 0;
    uint8_t *rgb = get_frame(d, path, &quality, &id, "a JPEG of a video viewer's view");
    CHECK(rgb != NULL && quality >= 1);
    free(rgb);
    pc_ws_close(&ws);
}

/* probecast serve with a bad --jpeg or $PROBECAST_JPEG exits 2 with a message naming it. */
static void check_refused(const char *env, const char *flag)
{
    char cmd[1024];
    snprintf(cmd, sizeof cmd, "%s%s '%s' serve --http 127.0.0.1:0 %s 2>&1 | grep -q %s", env,
             env[0] ? " " : "", PROBECAST_EXE, flag, env[0] ? "PROBECAST_JPEG" : "-e --jpeg");
    CHECKF(system(cmd) == 0, "refused with a message: %s", cmd);
    snprintf(cmd, sizeof cmd, "%s%s '%s' serve --http 127.0.0.1:0 %s >/dev/null 2>&1", env,
             env[0] ? " " : "", PROBECAST_EXE, flag);
    int status = system(cmd);
    CHECKF(WIFEXITED(status) && WEXITSTATUS(status) == 2, "exit status 2: %s", cmd);
}

int main(void)
{
    check_refused("", "--jpeg fast");
    check_refused("PROBECAST_JPEG=fast", "");
    pc_daemon cpu = {0}, gpu = {0};
    if (!start(&cpu, "cpu") || !start(&gpu, "gpu")) {
        CHECK(!"daemons started");
        pc_daemon_stop(&cpu);
        pc_daemon_stop(&gpu);
        return test_finish();
    }
    unsigned q_cpu = 0, q_gpu = 0;
    uint64_t id_cpu = 0, id_gpu = 0;
    uint8_t *a = get_frame(&cpu, "/v1/frame.jpg", &q_cpu, &id_cpu, "--jpeg cpu");
    uint8_t *b = get_frame(&gpu, "/v1/frame.jpg", &q_gpu, &id_gpu, "--jpeg gpu");
    CHECKF(q_cpu == q_gpu && q_gpu >= 1, "qualities %u and %u", q_cpu, q_gpu);
    if (a && b) {
        double sum = 0, se = 0;
        int worst = 0;
        for (size_t i = 0; i < (size_t)W * H * 3; i++) {
            int diff = abs((int)a[i] - (int)b[i]);
            sum += diff;
            se += (double)diff * diff;
            if (diff > worst) worst = diff;
        }
        double mean = sum / (W * H * 3), psnr = 10 * log10(255.0 * 255.0 / (se / (W * H * 3)));
        printf("cpu vs gpu path, quality %u: mean difference %.3f, max %d, PSNR %.1f dB\n", q_gpu,
               mean, worst, psnr);
        CHECKF(mean < 1.5 && psnr > 35, "the paths decode alike: mean %.3f, PSNR %.1f dB", mean,
               psnr);
    }
    free(a);
    free(b);
    check_stats(&cpu, "cpu", false);
    check_stats(&gpu, "gpu", true);
    check_stills(&gpu);
    check_video(&gpu);
    check_stats(&gpu, "gpu", true);
    CHECKF(pc_daemon_stop(&cpu) == 0, "the cpu daemon exits cleanly");
    CHECKF(pc_daemon_stop(&gpu) == 0, "the gpu daemon exits cleanly");
    return test_finish();
}
