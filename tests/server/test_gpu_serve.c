/* probecast serve end to end on lavapipe: upload a scene, watch it over the stream while the
 * camera, a light and a node change, check adaptive quality, idling, a restart that restores
 * the state from --data-dir, and a clean SIGTERM shutdown. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "serve_util.h"
#include "shaders/gpu_types.h"
#include "test_util.h"

/* Tiny and quickly converging: 64x48, 8 probes of 16 rays, hysteresis 0.5 (the field sleeps
 * after some 20-40 updates). */
static const char *const tiny[] = {
    "--no-animate", "--width",      "64",  "--height",  "48", "--probes", "2,2,2",  "--rays",
    "16",           "--hysteresis", "0.5", "--max-fps", "30", "--token",  "s3cret", NULL};

/* Receives frames until pred holds or timeout; keeps the last one in *f. */
typedef bool (*frame_pred)(const pc_frame *f, const void *arg);
static bool wait_frame(pc_ws *ws, int timeout_ms, frame_pred pred, const void *arg, pc_frame *f)
{
    double deadline = pc_now_ms() + timeout_ms;
    while (pc_now_ms() < deadline) {
        pc_frame g;
        if (!pc_stream_next(ws, (int)(deadline - pc_now_ms()), true, &g)) return false;
        pc_frame_free(f);
        *f = g;
        if (pred(f, arg)) return true;
    }
    return false;
}

static bool seq_at_least(const pc_frame *f, const void *arg)
{
    return f->h.input_seq >= *(const uint32_t *)arg;
}
static bool is_still(const pc_frame *f, const void *arg)
{
    (void)arg;
    return f->h.flags & PROTO_STREAM_FLAG_STILL;
}
static bool darker_than(const pc_frame *f, const void *arg)
{
    return f->mean < *(const double *)arg;
}
static bool differs_from(const pc_frame *f, const void *arg)
{
    return pc_frame_diff(f, arg) > 4.0;
}

static int light_id(pc_daemon *d)
{
    cJSON *j = pc_api_get_json(d, "/v1/lights");
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(j, "lights");
    int id = cJSON_GetArraySize(a) > 0 ? (int)pc_json_number(cJSON_GetArrayItem(a, 0), "id") : -1;
    cJSON_Delete(j);
    return id;
}

/* A scene that brings no light (the lamp node is left out of the scene) renders lit by the
 * default key light and environment, reported in GET /v1/scene, until the user adds a light. */
static void test_default_lighting(pc_daemon *d)
{
    char *gltf = pc_make_gltf(0.5f);
    char *nodes = strstr(gltf, "\"nodes\":[0,1,2,3]");
    CHECK(nodes != NULL);
    if (!nodes) {
        free(gltf);
        return;
    }
    memcpy(nodes, "\"nodes\":[0,1,3]  ", 17); /* without node 2, the lamp */
    pc_http_response r;
    CHECK(pc_http("127.0.0.1", d->http_port, "PUT", "/v1/scene",
                  "Authorization: Bearer s3cret\r\nContent-Type: model/gltf+json\r\n", gltf,
                  strlen(gltf), &r, 120000) == 200);
    pc_http_response_free(&r);
    free(gltf);
    cJSON *scene = pc_api_get_json(d, "/v1/scene");
    const cJSON *dl = cJSON_GetObjectItemCaseSensitive(scene, "default_lighting");
    const cJSON *lights = cJSON_GetObjectItemCaseSensitive(scene, "lights");
    CHECKF(cJSON_IsObject(dl), "default lighting reported");
    CHECK(pc_json_number(scene, "light_count") == 1);
    const cJSON *key = cJSON_GetArrayItem(lights, 0);
    CHECK(pc_json_number(key, "id") == pc_json_number(dl, "light"));
    const cJSON *type = cJSON_GetObjectItemCaseSensitive(key, "type");
    CHECK(cJSON_IsString(type) && strcmp(type->valuestring, "directional") == 0);
    const cJSON *sky = cJSON_GetObjectItemCaseSensitive(dl, "sky");
    CHECK(cJSON_GetArraySize(sky) == 3 && cJSON_GetArrayItem(sky, 0)->valuedouble > 0);
    const cJSON *reason = cJSON_GetObjectItemCaseSensitive(dl, "reason");
    CHECKF(cJSON_IsString(reason) &&
               strncmp(reason->valuestring, "no lights, no environment", 25) == 0,
           "why: %s", cJSON_IsString(reason) ? reason->valuestring : "(none)");
    cJSON_Delete(scene);

    pc_ws ws;
    CHECK(pc_stream_open(d, &ws));
    pc_frame lit = {0};
    CHECK(pc_stream_next(&ws, 60000, true, &lit));
    CHECKF(lit.mean > 20, "a light-less upload renders lit: mean %.1f", lit.mean);
    pc_frame_free(&lit);
    pc_ws_close(&ws);

    /* the user's first light replaces the default lighting (key light and environment) */
    CHECK(pc_api(d, "POST", "/v1/lights",
                 "{\"type\":\"point\",\"position\":[0,2.5,1],\"intensity\":20}", true, &r) == 201);
    pc_http_response_free(&r);
    scene = pc_api_get_json(d, "/v1/scene");
    dl = cJSON_GetObjectItemCaseSensitive(scene, "default_lighting");
    lights = cJSON_GetObjectItemCaseSensitive(scene, "lights");
    CHECK(cJSON_IsFalse(dl));
    CHECK(pc_json_number(scene, "light_count") == 1);
    type = cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(lights, 0), "type");
    CHECK(cJSON_IsString(type) && strcmp(type->valuestring, "point") == 0);
    cJSON_Delete(scene);
}

int main(void)
{
    const char *data_dir = test_tmp_path("serve-data");
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", data_dir);
    CHECK(system(cmd) == 0);
    const char *args[32];
    int n = 0;
    for (int i = 0; tiny[i]; i++)
        args[n++] = tiny[i];
    args[n++] = "--data-dir";
    args[n++] = data_dir;
    args[n++] = "--scene";
    args[n++] = "builtin:cornell";
    args[n] = NULL;

    pc_daemon d = {.token = "s3cret"};
    if (!pc_daemon_start(&d, args)) {
        CHECK(!"daemon started");
        return test_finish();
    }
    pc_http_response r;

    /* health answers without a token and names the stream port */
    cJSON *health = pc_api_get_json(&d, "/v1/health");
    const cJSON *stream = cJSON_GetObjectItemCaseSensitive(health, "stream");
    CHECK(health && pc_json_number(stream, "port") == d.ws_port);
    cJSON_Delete(health);

    /* upload the test scene */
    size_t glb_size;
    uint8_t *glb = pc_make_glb(0.8f, &glb_size);
    CHECK(pc_http("127.0.0.1", d.http_port, "PUT", "/v1/scene",
                  "Authorization: Bearer s3cret\r\nContent-Type: model/gltf-binary\r\n", glb,
                  glb_size, &r, 120000) == 200);
    pc_http_response_free(&r);
    free(glb);
    cJSON *scene = pc_api_get_json(&d, "/v1/scene");
    CHECK(scene && pc_json_number(scene, "triangles") == 14 &&
          pc_json_number(scene, "node_count") == 4);
    CHECK(pc_json_number(scene, "light_count") == 1);
    const cJSON *probes = cJSON_GetObjectItemCaseSensitive(scene, "probes");
    CHECK(pc_json_number(probes, "total") == 8);
    CHECK(cJSON_GetObjectItemCaseSensitive(scene, "bvh") != NULL);
    cJSON_Delete(scene);

    /* the stream: first a frame of the new scene */
    pc_ws ws;
    CHECK(pc_stream_open(&d, &ws));
    pc_frame a = {0}, b = {0};
    CHECK(pc_stream_next(&ws, 60000, true, &a));
    CHECK(a.h.width == 64 && a.h.height == 48 && a.h.view_id == 0);
    CHECK(a.h.capture_us > 0 && a.h.encode_us >= a.h.capture_us && a.h.send_us >= a.h.encode_us);
    CHECK(a.mean > 5); /* lit */

    /* camera input: a frame reflecting seq 5 arrives, differs, and is encoded for interaction.
     * A frame rendered after the still delay is rightly a still; under ASan on a loaded machine
     * (cold pipelines, a world tick in the way) the render thread can take seconds to reach the
     * input, so the delay is raised to its maximum until the interactive frame has arrived. */
    CHECK(pc_api(&d, "PATCH", "/v1/settings", "{\"still_delay_ms\":10000}", true, &r) == 200);
    pc_http_response_free(&r);
    CHECK(pc_ws_send_text(
              &ws, "{\"type\":\"camera\",\"seq\":5,\"position\":[2.5,2,3],\"target\":[0,0.5,0]}") ==
          0);
    uint32_t want = 5;
    CHECK(wait_frame(&ws, 60000, seq_at_least, &want, &b));
    CHECKF(b.h.input_seq == 5, "input_seq %u", b.h.input_seq);
    CHECKF(pc_frame_diff(&a, &b) > 4.0, "diff %.2f", pc_frame_diff(&a, &b));
    CHECKF(!(b.h.flags & PROTO_STREAM_FLAG_STILL) && b.h.quality == 60, "flags %u quality %u",
           (unsigned)b.h.flags, (unsigned)b.h.quality);
    CHECK(pc_api(&d, "PATCH", "/v1/settings", "{\"still_delay_ms\":150}", true, &r) == 200);
    pc_http_response_free(&r);
    /* once input stops: one full-quality still */
    CHECK(wait_frame(&ws, 60000, is_still, NULL, &b));
    CHECK(b.h.quality == 90 && b.h.input_seq == 5);
    cJSON *cam = pc_api_get_json(&d, "/v1/camera");
    const cJSON *pos = cJSON_GetObjectItemCaseSensitive(cam, "position");
    CHECK(cJSON_GetArraySize(pos) == 3 && cJSON_GetArrayItem(pos, 0)->valuedouble == 2.5);
    cJSON_Delete(cam);

    /* a second input: seq advances */
    CHECK(pc_ws_send_text(
              &ws,
              "{\"type\":\"camera\",\"seq\":6,\"position\":[-2.5,2,3],\"target\":[0,0.5,0]}") == 0);
    want = 6;
    pc_frame c = {0};
    CHECK(wait_frame(&ws, 60000, seq_at_least, &want, &c));
    CHECK(c.h.input_seq == 6 && c.h.frame_id > b.h.frame_id);
    CHECK(wait_frame(&ws, 60000, is_still, NULL, &c));

    /* light off: the image goes (nearly) black */
    int lid = light_id(&d);
    CHECK(lid >= 0);
    char path[64];
    snprintf(path, sizeof path, "/v1/lights/%d", lid);
    CHECK(pc_api(&d, "PATCH", path, "{\"intensity\":0}", true, &r) == 200);
    pc_http_response_free(&r);
    double dark = c.mean * 0.2;
    pc_frame off = {0};
    CHECKF(wait_frame(&ws, 60000, darker_than, &dark, &off), "mean %.2f before, %.2f after", c.mean,
           off.mean);
    CHECK(pc_api(&d, "PATCH", path, "{\"intensity\":40,\"color\":[1,0.9,0.8]}", true, &r) == 200);
    pc_http_response_free(&r);
    pc_frame on = {0};
    CHECK(wait_frame(&ws, 60000, differs_from, &off, &on));
    CHECK(on.mean > off.mean + 5);

    /* move the box (node 1): the picture changes and the node reports its new place */
    CHECK(wait_frame(&ws, 60000, is_still, NULL, &on));
    CHECK(pc_api(&d, "PATCH", "/v1/nodes/1", "{\"translation\":[-0.8,0.5,0.3]}", true, &r) == 200);
    pc_http_response_free(&r);
    pc_frame moved = {0};
    CHECK(wait_frame(&ws, 60000, differs_from, &on, &moved));
    cJSON *node = pc_api_get_json(&d, "/v1/nodes/1");
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(node, "translation");
    CHECK(t && fabs(cJSON_GetArrayItem(t, 0)->valuedouble + 0.8) < 1e-6);
    cJSON_Delete(node);

    /* settings: a new still quality shows in the stream */
    CHECK(pc_api(&d, "PATCH", "/v1/settings", "{\"quality_still\":85}", true, &r) == 200);
    pc_http_response_free(&r);
    pc_frame q = {0};
    CHECK(pc_ws_send_text(
              &ws, "{\"type\":\"camera\",\"seq\":7,\"position\":[0,2,4],\"target\":[0,0.5,0]}") ==
          0);
    want = 7;
    CHECK(wait_frame(&ws, 60000, seq_at_least, &want, &q));
    CHECK(wait_frame(&ws, 60000, is_still, NULL, &q));
    CHECK(q.h.quality == 85);

    /* idle: once the field has converged by its own measure nothing changes, so no probe is
     * updated, nothing is rendered and nothing is sent */
    for (int i = 0; i < 600; i++) { /* the field sleeps (some 20-40 updates), frames go out */
        cJSON *s = pc_api_get_json(&d, "/v1/stats");
        bool busy = !cJSON_IsFalse(cJSON_GetObjectItemCaseSensitive(s, "rendering"));
        cJSON_Delete(s);
        if (!busy) break;
        pc_sleep_ms(100);
    }
    pc_sleep_ms(300);
    pc_frame idle = {0};
    while (pc_stream_next(&ws, 500, true, &idle)) /* drain what was sent meanwhile */
        pc_frame_free(&idle);
    cJSON *s1 = pc_api_get_json(&d, "/v1/stats");
    bool got = pc_stream_next(&ws, 1500, true, &idle);
    cJSON *s2 = pc_api_get_json(&d, "/v1/stats");
    CHECKF(pc_json_number(s1, "frames_rendered") == pc_json_number(s2, "frames_rendered"),
           "%g -> %g frames", pc_json_number(s1, "frames_rendered"),
           pc_json_number(s2, "frames_rendered"));
    CHECK(!got);
    CHECK(cJSON_IsFalse(cJSON_GetObjectItemCaseSensitive(s2, "rendering")));
    const cJSON *w1 = cJSON_GetObjectItemCaseSensitive(s1, "world");
    const cJSON *w2 = cJSON_GetObjectItemCaseSensitive(s2, "world");
    CHECKF(pc_json_number(w1, "probe_updates") > 0 &&
               pc_json_number(w1, "probe_updates") == pc_json_number(w2, "probe_updates"),
           "probe updates while idle: %g -> %g", pc_json_number(w1, "probe_updates"),
           pc_json_number(w2, "probe_updates"));
    const cJSON *pr = cJSON_GetObjectItemCaseSensitive(s2, "probes");
    const cJSON *states = cJSON_GetObjectItemCaseSensitive(pr, "states");
    CHECK(cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(pr, "converged")));
    CHECKF(pc_json_number(states, "awake") == 0 &&
               pc_json_number(states, "sleeping") + pc_json_number(states, "off") == 8,
           "probe states when idle: %g awake, %g sleeping, %g off", pc_json_number(states, "awake"),
           pc_json_number(states, "sleeping"), pc_json_number(states, "off"));
    CHECK(pc_json_number(pr, "convergence") == 1);
    /* 8 probes x 16 rays shade 128 hits an update: a light's distance map (98304 rays) would
     * pay only after some 768 updates of shadow rays, so none is built and none takes memory */
    const cJSON *sm = cJSON_GetObjectItemCaseSensitive(pr, "shadow_maps");
    CHECKF(sm && pc_json_number(sm, "lights") == 0 && pc_json_number(sm, "builds") == 0 &&
               pc_json_number(sm, "bytes") == 0,
           "shadow maps of a tiny probe grid: %g lights, %g builds, %g bytes",
           pc_json_number(sm, "lights"), pc_json_number(sm, "builds"), pc_json_number(sm, "bytes"));
    const cJSON *st = cJSON_GetObjectItemCaseSensitive(s2, "stream");
    CHECK(pc_json_number(st, "viewers") == 1 && pc_json_number(st, "frames_sent") >= 5);
    CHECK(pc_json_number(cJSON_GetObjectItemCaseSensitive(s2, "encoder"), "jpegs_encoded") >= 5);
    double frames_idle = pc_json_number(s2, "frames_rendered");
    cJSON_Delete(s1);
    cJSON_Delete(s2);
    pc_frame_free(&idle);

    /* near-field rays (off on a CPU device): turned on, the resting view renders on until its
     * history has settled (PC_NEAR_SETTLE_FRAMES frames), then nothing again */
    CHECK(pc_api(&d, "PATCH", "/v1/settings", "{\"near_field\":\"on\"}", true, &r) == 200);
    pc_http_response_free(&r);
    pc_sleep_ms(300);
    for (int i = 0; i < 1200; i++) {
        cJSON *s = pc_api_get_json(&d, "/v1/stats");
        bool busy = !cJSON_IsFalse(cJSON_GetObjectItemCaseSensitive(s, "rendering"));
        cJSON_Delete(s);
        if (!busy) break;
        pc_sleep_ms(100);
    }
    s1 = pc_api_get_json(&d, "/v1/stats");
    pc_sleep_ms(1000);
    s2 = pc_api_get_json(&d, "/v1/stats");
    double settled = pc_json_number(s1, "frames_rendered");
    CHECKF(settled - frames_idle >= PC_NEAR_SETTLE_FRAMES,
           "near-field rays on: %g frames to settle (%u expected)", settled - frames_idle,
           PC_NEAR_SETTLE_FRAMES);
    CHECKF(pc_json_number(s2, "frames_rendered") == settled, "settled, yet %g -> %g frames",
           settled, pc_json_number(s2, "frames_rendered"));
    cJSON_Delete(s1);
    cJSON_Delete(s2);
    CHECK(pc_api(&d, "PATCH", "/v1/settings", "{\"near_field\":\"off\"}", true, &r) == 200);
    pc_http_response_free(&r);
    while (pc_stream_next(&ws, 500, true, &idle)) /* drain the settling frames */
        pc_frame_free(&idle);

    /* /v1/frame.jpg needs the token and is a JPEG */
    CHECK(pc_api(&d, "GET", "/v1/frame.jpg", NULL, false, &r) == 401);
    pc_http_response_free(&r);
    CHECK(pc_api(&d, "GET", "/v1/frame.jpg", NULL, true, &r) == 200);
    CHECK(r.body_len > 100 && (uint8_t)r.body[0] == 0xff && (uint8_t)r.body[1] == 0xd8);
    pc_http_response_free(&r);

    pc_ws_close(&ws);
    pc_frame_free(&a);
    pc_frame_free(&b);
    pc_frame_free(&c);
    pc_frame_free(&off);
    pc_frame_free(&on);
    pc_frame_free(&moved);
    pc_frame_free(&q);
    pc_sleep_ms(600); /* let the state be saved (written at most every 250 ms) */
    CHECKF(pc_daemon_stop(&d) == 0, "clean exit after SIGTERM");

    /* restart without --scene: the upload, camera, light, node and settings come back */
    args[n - 2] = NULL;
    pc_daemon d2 = {.token = "s3cret"};
    if (!pc_daemon_start(&d2, args)) {
        CHECK(!"daemon restarted");
        return test_finish();
    }
    scene = pc_api_get_json(&d2, "/v1/scene");
    const cJSON *src = cJSON_GetObjectItemCaseSensitive(scene, "source");
    CHECK(cJSON_IsString(src) && strcmp(src->valuestring, "upload") == 0);
    CHECK(pc_json_number(scene, "triangles") == 14);
    cJSON_Delete(scene);
    cam = pc_api_get_json(&d2, "/v1/camera");
    pos = cJSON_GetObjectItemCaseSensitive(cam, "position");
    CHECK(cJSON_GetArraySize(pos) == 3 && cJSON_GetArrayItem(pos, 2)->valuedouble == 4);
    cJSON_Delete(cam);
    cJSON *light = pc_api_get_json(&d2, path);
    CHECK(pc_json_number(light, "intensity") == 40);
    cJSON_Delete(light);
    node = pc_api_get_json(&d2, "/v1/nodes/1");
    t = cJSON_GetObjectItemCaseSensitive(node, "translation");
    CHECK(t && fabs(cJSON_GetArrayItem(t, 2)->valuedouble - 0.3) < 1e-6);
    cJSON_Delete(node);
    cJSON *settings = pc_api_get_json(&d2, "/v1/settings");
    CHECK(pc_json_number(settings, "quality_still") == 85 &&
          pc_json_number(settings, "width") == 64);
    cJSON_Delete(settings);
    /* and it streams */
    CHECK(pc_stream_open(&d2, &ws));
    pc_frame again = {0};
    CHECK(pc_stream_next(&ws, 60000, true, &again));
    CHECK(again.h.width == 64 && again.mean > 5);
    pc_frame_free(&again);
    pc_ws_close(&ws);
    test_default_lighting(&d2);
    CHECKF(pc_daemon_stop(&d2) == 0, "clean exit after SIGTERM");
    return test_finish();
}
