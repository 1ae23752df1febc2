/* The environment image over the API (issue 11 item 6): an OpenEXR upload (written by
 * OpenEXRCore's writer) becomes the environment and GET /v1/scene reports its size; a broken
 * .exr is refused with 422 while the image before it stays; the data directory holds exactly one
 * environment file, named after the format of the last upload (.exr or .hdr); and a restart with
 * the same --data-dir brings the .exr environment back (also when an older .hdr was left beside
 * it). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/time.h>
#include <time.h>
#include <unistd.h>

#include "renderer/exr_writer.h"
#include "serve_util.h"
#include "test_util.h"

static const char *const tiny[] = {
    "--no-animate",    "--width", "64",           "--height", "48",      "--probes", "2,2,2",
    "--rays",          "16",      "--hysteresis", "0.5",      "--token", "s3cret",   "--scene",
    "builtin:cornell", NULL};

static char data_dir[512];

static bool start(pc_daemon *d)
{
    const char *args[32];
    int n = 0;
    for (int i = 0; tiny[i]; i++)
        args[n++] = tiny[i];
    args[n++] = "--data-dir";
    args[n++] = data_dir;
    args[n] = NULL;
    d->token = "s3cret";
    return pc_daemon_start(d, args);
}

/* PUT /v1/environment with the token and a Content-Type; the status (r keeps the answer). */
static int put_environment(pc_daemon *d, const char *type, const void *body, size_t len,
                           pc_http_response *r)
{
    char headers[160];
    snprintf(headers, sizeof headers, "Authorization: Bearer s3cret\r\nContent-Type: %s\r\n", type);
    return pc_http("127.0.0.1", d->http_port, "PUT", "/v1/environment", headers, body, len, r,
                   120000);
}

/* The size GET /v1/scene reports for the environment image (0 x 0 when it names none). */
static void scene_image(pc_daemon *d, int *w, int *h)
{
    cJSON *scene = pc_api_get_json(d, "/v1/scene");
    const cJSON *im = cJSON_GetObjectItemCaseSensitive(scene, "environment_image");
    *w = cJSON_IsObject(im) ? (int)pc_json_number(im, "width") : 0;
    *h = cJSON_IsObject(im) ? (int)pc_json_number(im, "height") : 0;
    cJSON_Delete(scene);
}

static bool file_exists(const char *name)
{
    char path[600];
    snprintf(path, sizeof path, "%s/%s", data_dir, name);
    return access(path, F_OK) == 0;
}

/* Waits (the persister writes on its own thread) until environment.<want> is the only one. */
static bool only_environment_file(const char *want)
{
    char name[32];
    snprintf(name, sizeof name, "environment.%s", want);
    const char *other = strcmp(want, "exr") == 0 ? "environment.hdr" : "environment.exr";
    for (int i = 0; i < 100; i++) {
        if (file_exists(name) && !file_exists(other)) return true;
        pc_sleep_ms(100);
    }
    return false;
}

/* An EXR of w x h HALF texels (R, G, B) with ZIP compression; caller frees. */
static uint8_t *make_exr(uint32_t w, uint32_t h, size_t *size)
{
    float *px = malloc((size_t)w * h * 3 * sizeof *px);
    if (!px) abort();
    for (size_t i = 0; i < (size_t)w * h * 3; i++)
        px[i] = 0.25f * (float)(i % 7);
    pc_exr_desc desc = {.width = w,
                        .height = h,
                        .pixels = px,
                        .type = EXR_PIXEL_HALF,
                        .compression = EXR_COMPRESSION_ZIP};
    uint8_t *file = pc_exr_write(&desc, size);
    free(px);
    return file;
}

int main(void)
{
    snprintf(data_dir, sizeof data_dir, "%s", test_tmp_path("serve-environment"));
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", data_dir);
    CHECK(system(cmd) == 0);
    size_t exr_size = 0, small_size = 0;
    uint8_t *exr = make_exr(16, 8, &exr_size), *small = make_exr(8, 4, &small_size);
    CHECK(exr && small);
    pc_daemon d = {0};
    if (!exr || !small || !start(&d)) {
        CHECK(!"daemon started");
        return test_finish();
    }
    pc_http_response r;
    int w, h;

    /* an .exr as image/x-exr: the answer and the scene name its size */
    CHECK(put_environment(&d, "image/x-exr", exr, exr_size, &r) == 200);
    cJSON *j = cJSON_Parse(r.body);
    CHECKF(pc_json_number(j, "width") == 16 && pc_json_number(j, "height") == 8, "answer %s",
           r.body);
    const cJSON *mode = cJSON_GetObjectItemCaseSensitive(j, "sky_mode");
    CHECK(cJSON_IsString(mode) && strcmp(mode->valuestring, "image") == 0);
    cJSON_Delete(j);
    pc_http_response_free(&r);
    scene_image(&d, &w, &h);
    CHECKF(w == 16 && h == 8, "GET /v1/scene: %dx%d", w, h);
    CHECK(only_environment_file("exr"));

    /* a broken .exr (its last chunk cut short; no R, G, B) is refused with 422 and a message, and
     * the image before it stays */
    CHECK(put_environment(&d, "image/x-exr", exr, exr_size - 16, &r) == 422);
    CHECKF(strstr(r.body, "\"message\"") && strstr(r.body, "EXR"), "422 body %s", r.body);
    pc_http_response_free(&r);
    static const char *const z_only[] = {"Z"};
    float zs[8] = {0};
    pc_exr_desc no_rgb = {.width = 4,
                          .height = 2,
                          .pixels = zs,
                          .type = EXR_PIXEL_FLOAT,
                          .channel_count = 1,
                          .channels = z_only};
    size_t nz = 0;
    uint8_t *z = pc_exr_write(&no_rgb, &nz);
    CHECK(z != NULL);
    if (z) {
        CHECK(put_environment(&d, "application/octet-stream", z, nz, &r) == 422);
        CHECKF(strstr(r.body, "R, G and B"), "422 body %s", r.body);
        pc_http_response_free(&r);
        free(z);
    }
    CHECK(put_environment(&d, "image/png", exr, exr_size, &r) == 415);
    pc_http_response_free(&r);
    scene_image(&d, &w, &h);
    CHECKF(w == 16 && h == 8, "after the refused uploads: %dx%d", w, h);
    CHECK(pc_daemon_alive(&d));

    /* application/octet-stream is read by its first bytes too */
    CHECK(put_environment(&d, "application/octet-stream", small, small_size, &r) == 200);
    pc_http_response_free(&r);
    scene_image(&d, &w, &h);
    CHECKF(w == 8 && h == 4, "octet-stream .exr: %dx%d", w, h);

    /* a Radiance file replaces environment.exr by environment.hdr, and back */
    static const char hdr[] = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n"
                              "\x80\x40\x20\x81\x00\x00\x00\x00";
    CHECK(put_environment(&d, "image/vnd.radiance", hdr, sizeof hdr - 1, &r) == 200);
    pc_http_response_free(&r);
    CHECK(only_environment_file("hdr"));
    CHECK(put_environment(&d, "image/x-exr", exr, exr_size, &r) == 200);
    pc_http_response_free(&r);
    CHECK(only_environment_file("exr"));
    CHECKF(pc_daemon_stop(&d) == 0, "clean exit after SIGTERM");

    /* a run killed between saving environment.exr and removing the older environment.hdr
     * leaves both: the restart takes the newer and removes the other */
    char stale[600];
    snprintf(stale, sizeof stale, "%s/environment.hdr", data_dir);
    FILE *f = fopen(stale, "wb");
    CHECK(f && fwrite(hdr, 1, sizeof hdr - 1, f) == sizeof hdr - 1);
    if (f) fclose(f);
    struct timeval old[2] = {{.tv_sec = time(NULL) - 3600}, {.tv_sec = time(NULL) - 3600}};
    CHECK(utimes(stale, old) == 0);

    /* a restart with the same data directory: the .exr environment is back */
    pc_daemon d2 = {0};
    if (!start(&d2)) {
        CHECK(!"daemon restarted");
        return test_finish();
    }
    w = h = 0;
    for (int i = 0; i < 600 && !(w == 16 && h == 8); i++) {
        scene_image(&d2, &w, &h);
        if (!(w == 16 && h == 8)) pc_sleep_ms(100);
    }
    CHECKF(w == 16 && h == 8, "after the restart: %dx%d", w, h);
    CHECK(only_environment_file("exr"));
    cJSON *s = pc_api_get_json(&d2, "/v1/settings");
    mode = cJSON_GetObjectItemCaseSensitive(s, "sky_mode");
    CHECK(cJSON_IsString(mode) && strcmp(mode->valuestring, "image") == 0);
    cJSON_Delete(s);

    /* DELETE removes it, from the data directory too */
    CHECK(pc_api(&d2, "DELETE", "/v1/environment", NULL, true, &r) == 204);
    pc_http_response_free(&r);
    scene_image(&d2, &w, &h);
    CHECK(w == 0 && h == 0);
    bool gone = false;
    for (int i = 0; i < 100 && !gone; i++) {
        gone = !file_exists("environment.exr") && !file_exists("environment.hdr");
        if (!gone) pc_sleep_ms(100);
    }
    CHECK(gone);
    CHECKF(pc_daemon_stop(&d2) == 0, "clean exit after SIGTERM");
    free(exr);
    free(small);
    return test_finish();
}
