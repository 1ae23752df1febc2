/* probecast serve keeps its memory bounded whatever an upload asks for (issue 30, item 2):
 * - a small glTF file whose images declare huge sizes (eight 16384 x 4096 one-colour PNGs in
 *   under 1 MiB, 2 GiB as RGBA) is refused from the images' headers once the decode budget of
 *   the file (rd_gltf_decode_limit: 256 MiB for a small file) is spent, the daemon's peak
 *   resident memory grows by a bounded amount, and the scene it had keeps rendering;
 * - a 4 MiB run-length .hdr environment of 8000 x 8000 texels (732 MiB as float RGB) is reduced
 *   while it is decoded and uploaded in slices: accepted, at 4000 x 4000, for a bounded growth
 *   of the peak;
 * - more concurrent uploads than the daemon takes get 503 with Retry-After, and uploads are
 *   taken again once the others end.
 * The peak is read from /proc/PID/status (VmHWM), reset to the current resident set before each
 * case by writing 5 to /proc/PID/clear_refs. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "renderer/gltf/gltf_loader.h"
#include "renderer/gltf_builder.h"
#include "renderer/hdr_writer.h"
#include "serve_util.h"
#include "test_util.h"

static pc_daemon d = {.token = "s3cret"};

/* The bounds hold for the release build. Under AddressSanitizer the daemon's memory has the
 * sanitizer's shadow (an eighth of what is touched) and redzones on top, and freed blocks wait in
 * its quarantine before they are reused: main turns the quarantine off for the daemon, and the
 * bounds get half again (CI measured +681 and +456 MiB there with the quarantine on, against
 * +514 and +315 in the release build). */
#if defined(__SANITIZE_ADDRESS__)
#define SANITIZER_SLACK 1.5
#else
#define SANITIZER_SLACK 1.0
#endif

static int put_scene(const void *body, size_t len, pc_http_response *r)
{
    return pc_http("127.0.0.1", d.http_port, "PUT", "/v1/scene",
                   "Authorization: Bearer s3cret\r\nContent-Type: model/gltf-binary\r\n", body, len,
                   r, 300000);
}

static void test_huge_images(void)
{
    enum { COPIES = 8 };
    bin png[COPIES];
    make_flat_png(&png[0], 16384, 4096);
    for (int i = 1; i < COPIES; i++) {
        png[i].p = png[0].p;
        png[i].n = png[0].n;
    }
    size_t size;
    uint8_t *glb = make_glb_images(png, COPIES, 0, &size);
    CHECK(pc_daemon_reset_peak(&d));
    unsigned long long before = pc_daemon_memory_kib(&d, "VmHWM");
    pc_http_response r;
    int status = put_scene(glb, size, &r);
    unsigned long long after = pc_daemon_memory_kib(&d, "VmHWM");
    CHECKF(status == 422 && r.body && strstr(r.body, "past 256 MiB"),
           "%zu-byte file of %d 16384x4096 images: %d %s", size, COPIES, status,
           r.body ? r.body : "");
    /* what the refusal may cost: the one image decoded (256 MiB) twice over (stb's buffer and the
     * importer's copy) and the decoder's inflate buffer (64 MiB); before the budget the file
     * decoded all eight images: +4162 MiB on lavapipe, against +514 with it (1 GiB leaves the
     * sanitizer build its quarantine) */
    unsigned long long grew_mib = after > before ? (after - before) >> 10 : 0;
    printf("%zu KiB file of %d images of 16384x4096: HTTP %d, daemon peak RSS %llu -> %llu MiB "
           "(+%llu)\n",
           size >> 10, COPIES, status, before >> 10, after >> 10, grew_mib);
    CHECKF(before > 0 && grew_mib < 1024 * SANITIZER_SLACK, "peak RSS grew by %llu MiB", grew_mib);
    pc_http_response_free(&r);
    free(glb);
    free(png[0].p);
    /* nothing already loaded is lost */
    cJSON *scene = pc_api_get_json(&d, "/v1/scene");
    CHECK(scene && pc_json_number(scene, "generation") == 1 &&
          pc_json_number(scene, "triangles") == 14);
    cJSON_Delete(scene);
    CHECK(pc_daemon_alive(&d));
}

static void test_huge_environment(void)
{
    const uint8_t grey[4] = {128, 128, 128, 128}; /* 0.5 */
    pc_bytes hdr = pc_hdr_constant(8000, 8000, grey);
    CHECK(pc_daemon_reset_peak(&d));
    unsigned long long before = pc_daemon_memory_kib(&d, "VmHWM");
    pc_http_response r;
    int status = pc_http("127.0.0.1", d.http_port, "PUT", "/v1/environment",
                         "Authorization: Bearer s3cret\r\nContent-Type: image/vnd.radiance\r\n",
                         hdr.d, hdr.n, &r, 300000);
    unsigned long long after = pc_daemon_memory_kib(&d, "VmHWM");
    CHECKF(status == 200, "8000x8000 .hdr: %d %s", status, r.body ? r.body : "");
    pc_http_response_free(&r);
    unsigned long long grew_mib = after > before ? (after - before) >> 10 : 0;
    printf("%zu KiB .hdr of 8000x8000 texels: HTTP %d, daemon peak RSS %llu -> %llu MiB (+%llu)\n",
           hdr.n >> 10, status, before >> 10, after >> 10, grew_mib);
    cJSON *scene = pc_api_get_json(&d, "/v1/scene");
    const cJSON *env = cJSON_GetObjectItemCaseSensitive(scene, "environment_image");
    CHECKF(pc_json_number(env, "width") == 4000 && pc_json_number(env, "height") == 4000,
           "environment_image %s", env ? cJSON_PrintUnformatted(env) : "(none)");
    cJSON_Delete(scene);
    /* the reduced image's floats (183 MiB, kept for the irradiance projection) and, on
     * lavapipe, its GPU copy as half RGBA (122 MiB) in host memory, converted and uploaded in
     * 4 MiB slices; the full-size image alone would be 732 MiB. +315 MiB measured (+495 when
     * the whole image was converted to halves before the upload) */
    CHECKF(before > 0 && grew_mib < 448 * SANITIZER_SLACK, "peak RSS grew by %llu MiB", grew_mib);
    free(hdr.d);
}

/* An upload that has sent its headers and part of its body holds its slot until it ends. */
static int hold_upload(void)
{
    int fd = pc_dial("127.0.0.1", d.http_port, 5000);
    if (fd < 0) return -1;
    char req[512];
    int n = snprintf(req, sizeof req,
                     "PUT /v1/scene HTTP/1.1\r\nHost: 127.0.0.1\r\nAuthorization: Bearer "
                     "s3cret\r\nContent-Type: model/gltf-binary\r\nContent-Length: 4096\r\n\r\n"
                     "glTF");
    if (pc_send_all(fd, req, (size_t)n) != 0) {
        close(fd);
        return -1;
    }
    return fd;
}

static void test_concurrent_uploads(void)
{
    size_t size;
    uint8_t *glb = pc_make_glb(0.3f, &size);
    int held[2];
    for (int i = 0; i < 2; i++)
        held[i] = hold_upload();
    CHECK(held[0] >= 0 && held[1] >= 0);
    pc_sleep_ms(300); /* both requests' headers reach the daemon */
    pc_http_response r;
    int status = put_scene(glb, size, &r);
    char retry[32] = "";
    CHECKF(status == 503 && pc_http_header(&r, "Retry-After", retry, sizeof retry) &&
               atoi(retry) >= 1 && r.body && strstr(r.body, "unavailable"),
           "a third upload beside two: %d (Retry-After '%s') %s", status, retry,
           r.body ? r.body : "");
    pc_http_response_free(&r);
    for (int i = 0; i < 2; i++)
        if (held[i] >= 0) close(held[i]);
    /* the slots come back when the held uploads end */
    double deadline = pc_now_ms() + 10000;
    do {
        pc_sleep_ms(100);
        status = put_scene(glb, size, &r);
        pc_http_response_free(&r);
    } while (status == 503 && pc_now_ms() < deadline);
    CHECKF(status == 200, "an upload after the held ones ended: %d", status);
    free(glb);
}

/* /v1/stats reports the daemon's memory: resident as /proc says, the heap consistent with it */
static void test_stats_memory(void)
{
    unsigned long long rss_kib = pc_daemon_memory_kib(&d, "VmRSS");
    cJSON *s = pc_api_get_json(&d, "/v1/stats");
    const cJSON *m = s ? cJSON_GetObjectItem(s, "memory") : NULL;
    CHECK(m != NULL);
    if (m) {
        double rss = pc_json_number(m, "rss_bytes") / 1024,
               peak = pc_json_number(m, "peak_rss_bytes");
        double in_use = pc_json_number(m, "heap_in_use_bytes");
        double free_b = pc_json_number(m, "heap_free_bytes");
        double mmap_b = pc_json_number(m, "heap_mmap_bytes");
        printf("stats memory: rss %.0f KiB (/proc: %llu), peak %.0f MiB, heap in use %.1f MiB "
               "(mmap %.1f), free %.1f MiB\n",
               rss, rss_kib, peak / 1048576, in_use / 1048576, mmap_b / 1048576, free_b / 1048576);
        CHECKF(rss > 0.8 * (double)rss_kib && rss < 1.25 * (double)rss_kib, "rss %.0f KiB", rss);
        CHECK(peak >= rss * 1024);
        CHECK(in_use >= mmap_b && free_b >= 0);
#if !defined(__SANITIZE_ADDRESS__)
        /* glibc tells: the daemon holds a scene, views and encoders on its heap */
        CHECK(in_use > 1e6 && in_use < rss * 1024 + mmap_b);
#endif
    }
    cJSON_Delete(s);
}

int main(void)
{
#if defined(__SANITIZE_ADDRESS__)
    static char asan[512];
    const char *given = getenv("ASAN_OPTIONS");
    snprintf(asan, sizeof asan, "%s%squarantine_size_mb=0", given ? given : "", given ? ":" : "");
    setenv("ASAN_OPTIONS", asan, 1); /* the daemon inherits it */
#endif
    const char *args[] = {"--no-animate",    "--width", "32", "--height", "32",     "--probes",
                          "2,2,2",           "--rays",  "16", "--token",  "s3cret", "--scene",
                          "builtin:cornell", NULL};
    if (!pc_daemon_start(&d, args)) {
        CHECK(!"daemon started");
        return test_finish();
    }
    size_t size;
    uint8_t *glb = pc_make_glb(0.8f, &size);
    pc_http_response r;
    CHECK(put_scene(glb, size, &r) == 200);
    pc_http_response_free(&r);
    free(glb);

    test_stats_memory();
    test_huge_images();
    test_huge_environment();
    test_concurrent_uploads();

    CHECK(pc_daemon_stop(&d) == 0);
    return test_finish();
}
