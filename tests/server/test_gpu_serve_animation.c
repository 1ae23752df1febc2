/* The scene's glTF animations in the daemon, on lavapipe: a box whose translation runs LINEAR
 * from (-1, 0.5, 0) to (1, 0.5, 0) in 2 s, carrying a light. GET /v1/animation describes it and it
 * plays from the start while someone watches (and stands still while nobody does); PATCH pauses,
 * seeks (the node document shows the pose at the time sought) and plays again; probes near the
 * moving box wake while it plays and the field converges again once it is paused; bad bodies change
 * nothing; stream viewers get "animation" events; a scene without animations reports count 0.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "serve_util.h"
#include "test_util.h"

#define DURATION 2.0
#define X0 -1.0 /* the box's x at time 0; at time t it is X0 + t (2 m in 2 s) */

static pc_daemon d = {.token = "s3cret"};

/* A 4 x 4 m floor, a unit box (node "box") with the animation carrying a point light 2 m above
 * it (node "lamp", its child), and a camera; one buffer as a data: URI. */
static void write_scene(const char *path)
{
    uint8_t bin[512];
    const float times[2] = {0, (float)DURATION};
    const float moves[6] = {(float)X0, 0.5f, 0, (float)(X0 + DURATION), 0.5f, 0};
    CHECK(pc_scene_bin(bin) == 228); /* the floor and the box of the other serve tests */
    memcpy(bin + 228, times, 8);
    memcpy(bin + 236, moves, 24);
    char *b64 = test_base64(bin, 260);
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (!f) abort();
    fprintf(
        f,
        "{\"asset\":{\"version\":\"2.0\"},\"extensionsUsed\":[\"KHR_lights_punctual\"],"
        "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"type\":\"point\",\"intensity\":"
        "20}]}},\"scene\":0,\"scenes\":[{\"nodes\":[0,1,3]}],"
        "\"nodes\":[{\"name\":\"floor\",\"mesh\":0},{\"name\":\"box\",\"mesh\":1,"
        "\"translation\":[%g,0.5,0],\"children\":[2]},{\"name\":\"lamp\",\"translation\":[0,2,1],"
        "\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}},"
        "{\"name\":\"cam\",\"camera\":0,\"translation\":[0,1.5,5]}],"
        "\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.8,\"znear\":0.05}}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1}]},"
        "{\"primitives\":[{\"attributes\":{\"POSITION\":2},\"indices\":3}]}],"
        "\"animations\":[{\"name\":\"slide\",\"samplers\":[{\"input\":4,\"output\":5,"
        "\"interpolation\":\"LINEAR\"}],\"channels\":[{\"sampler\":0,\"target\":{\"node\":1,"
        "\"path\":\"translation\"}}]}],"
        "\"buffers\":[{\"byteLength\":260,\"uri\":\"data:application/octet-stream;base64,%s\"}],"
        "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":48},"
        "{\"buffer\":0,\"byteOffset\":48,\"byteLength\":12},"
        "{\"buffer\":0,\"byteOffset\":60,\"byteLength\":96},"
        "{\"buffer\":0,\"byteOffset\":156,\"byteLength\":72},"
        "{\"buffer\":0,\"byteOffset\":228,\"byteLength\":8},"
        "{\"buffer\":0,\"byteOffset\":236,\"byteLength\":24}],"
        "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\","
        "\"min\":[-2,0,-2],\"max\":[2,0,2]},"
        "{\"bufferView\":1,\"componentType\":5123,\"count\":6,\"type\":\"SCALAR\"},"
        "{\"bufferView\":2,\"componentType\":5126,\"count\":8,\"type\":\"VEC3\","
        "\"min\":[-0.5,-0.5,-0.5],\"max\":[0.5,0.5,0.5]},"
        "{\"bufferView\":3,\"componentType\":5123,\"count\":36,\"type\":\"SCALAR\"},"
        "{\"bufferView\":4,\"componentType\":5126,\"count\":2,\"type\":\"SCALAR\","
        "\"min\":[0],\"max\":[%g]},"
        "{\"bufferView\":5,\"componentType\":5126,\"count\":2,\"type\":\"VEC3\"}]}",
        X0 + 0.25, b64, DURATION);
    fclose(f);
    free(b64);
}

/* ---- helpers ------------------------------------------------------------------------------- */

typedef struct anim {
    double count, duration, time;
    bool playing, ok;
} anim;

static anim anim_of(const cJSON *j)
{
    const cJSON *p = cJSON_GetObjectItemCaseSensitive(j, "playing");
    anim a = {.count = pc_json_number(j, "count"),
              .duration = pc_json_number(j, "duration"),
              .time = pc_json_number(j, "time"),
              .playing = cJSON_IsTrue(p),
              .ok = cJSON_IsBool(p) && cJSON_GetArraySize(j) == 4};
    return a;
}

static anim get_anim(void)
{
    cJSON *j = pc_api_get_json(&d, "/v1/animation");
    anim a = anim_of(j);
    a.ok &= j != NULL;
    cJSON_Delete(j);
    return a;
}

/* PATCH /v1/animation; returns the status and (when 200) the answer in *out. */
static int patch_anim(const char *body, anim *out)
{
    pc_http_response r;
    int s = pc_api(&d, "PATCH", "/v1/animation", body, true, &r);
    cJSON *j = cJSON_Parse(r.body ? r.body : "");
    if (s == 200 && out) *out = anim_of(j);
    if (s >= 400)
        CHECKF(cJSON_IsString(cJSON_GetObjectItemCaseSensitive(j, "error")) &&
                   cJSON_IsString(cJSON_GetObjectItemCaseSensitive(j, "message")),
               "error body of %s: %s", body, r.body ? r.body : "");
    cJSON_Delete(j);
    pc_http_response_free(&r);
    return s;
}

/* Seconds from a to b on a loop of DURATION (b may have wrapped past the end). */
static double loop_delta(double a, double b)
{
    double dt = fmod(b - a, DURATION);
    return dt < 0 ? dt + DURATION : dt;
}

static int node_id(const char *name)
{
    cJSON *scene = pc_api_get_json(&d, "/v1/scene");
    const cJSON *n;
    int id = -1;
    cJSON_ArrayForEach(n, cJSON_GetObjectItemCaseSensitive(scene, "nodes"))
    {
        const cJSON *nm = cJSON_GetObjectItemCaseSensitive(n, "name");
        if (cJSON_IsString(nm) && strcmp(nm->valuestring, name) == 0)
            id = (int)pc_json_number(n, "id");
    }
    cJSON_Delete(scene);
    return id;
}

/* The node's translation x (NaN when unreadable); world_translation must agree (a root). */
static double node_x(int id)
{
    char path[64];
    snprintf(path, sizeof path, "/v1/nodes/%d", id);
    cJSON *j = pc_api_get_json(&d, path);
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(j, "translation");
    const cJSON *w = cJSON_GetObjectItemCaseSensitive(j, "world_translation");
    double x = NAN;
    if (cJSON_GetArraySize(t) == 3 && cJSON_GetArraySize(w) == 3) {
        x = cJSON_GetArrayItem(t, 0)->valuedouble;
        CHECKF(fabs(cJSON_GetArrayItem(w, 0)->valuedouble - x) < 1e-5 &&
                   fabs(cJSON_GetArrayItem(t, 1)->valuedouble - 0.5) < 1e-5 &&
                   fabs(cJSON_GetArrayItem(t, 2)->valuedouble) < 1e-5,
               "node %d: translation and world translation agree", id);
    }
    cJSON_Delete(j);
    return x;
}

/* The x of the first light's position (NaN when unreadable). */
static double light_x(void)
{
    cJSON *j = pc_api_get_json(&d, "/v1/lights");
    const cJSON *l = cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(j, "lights"), 0);
    const cJSON *p = cJSON_GetObjectItemCaseSensitive(l, "position");
    double x = cJSON_GetArraySize(p) == 3 ? cJSON_GetArrayItem(p, 0)->valuedouble : NAN;
    cJSON_Delete(j);
    return x;
}

/* /v1/stats: probes.states.awake and probes.converged. */
static void probe_state(double *awake, bool *converged)
{
    cJSON *s = pc_api_get_json(&d, "/v1/stats");
    const cJSON *p = cJSON_GetObjectItemCaseSensitive(s, "probes");
    *awake = pc_json_number(cJSON_GetObjectItemCaseSensitive(p, "states"), "awake");
    *converged = cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(p, "converged"));
    cJSON_Delete(s);
}

/* The next "animation" event (frames and other messages skipped); ok false on timeout. */
static anim next_anim_event(pc_ws *ws, int timeout_ms)
{
    double deadline = pc_now_ms() + timeout_ms;
    while (pc_now_ms() < deadline) {
        cJSON *ev = pc_stream_next_text(ws, (int)(deadline - pc_now_ms()) + 1, "event");
        if (!ev) break;
        const cJSON *what = cJSON_GetObjectItemCaseSensitive(ev, "what");
        if (cJSON_IsString(what) && strcmp(what->valuestring, "animation") == 0) {
            anim a = anim_of(cJSON_GetObjectItemCaseSensitive(ev, "data"));
            cJSON_Delete(ev);
            return a;
        }
        cJSON_Delete(ev);
    }
    return (anim){.ok = false};
}

/* Keeps the stream read (frames, events) for ms. */
static void drain(pc_ws *ws, int ms)
{
    double until = pc_now_ms() + ms;
    while (pc_now_ms() < until) {
        uint8_t *data;
        size_t len;
        if (pc_ws_recv(ws, (int)(until - pc_now_ms()) + 1, &data, &len) < 0) break;
    }
}

/* ---- the test ------------------------------------------------------------------------------- */

static void test_bad_inputs(int box, const anim *before)
{
    const char *bad[] = {"{",
                         "{}",
                         "[]",
                         "{\"time\":-0.5}",
                         "{\"time\":\"1\"}",
                         "{\"time\":null}",
                         "{\"time\":1e999}",
                         "{\"playing\":1}",
                         "{\"playing\":\"false\"}",
                         "{\"playing\":true,\"time\":-1}", /* all or nothing */
                         "{\"time\":1,\"time\":1}",
                         "{\"speed\":2}",
                         NULL};
    double x = node_x(box);
    for (int i = 0; bad[i]; i++)
        CHECKF(patch_anim(bad[i], NULL) == 400, "PATCH %s is refused with 400", bad[i]);
    anim a = get_anim();
    CHECKF(a.ok && a.playing == before->playing && a.time == before->time,
           "bad bodies change nothing (playing %d, time %g)", a.playing, a.time);
    CHECK(node_x(box) == x);
    /* no token */
    pc_http_response r;
    CHECK(pc_api(&d, "PATCH", "/v1/animation", "{\"playing\":true}", false, &r) == 401);
    pc_http_response_free(&r);
    CHECK(pc_api(&d, "DELETE", "/v1/animation", NULL, true, &r) == 405);
    pc_http_response_free(&r);
    a = get_anim();
    CHECK(a.ok && !a.playing && a.time == before->time);
}

int main(void)
{
    const char *scene_path = test_tmp_path("animated-box.gltf");
    write_scene(scene_path);
    const char *args[] = {"--no-animate", "--width",   "64", "--height",     "48",       "--probes",
                          "2,2,2",        "--rays",    "16", "--hysteresis", "0.5",      "--token",
                          "s3cret",       "--max-fps", "30", "--scene",      scene_path, NULL};
    if (!pc_daemon_start(&d, args)) {
        CHECK(!"daemon started");
        return test_finish();
    }

    /* the clip as loaded: playing, but nobody watches, so the time stands at 0 */
    anim a = get_anim();
    CHECKF(a.ok && a.count == 1 && a.duration == DURATION && a.playing && a.time == 0,
           "GET /v1/animation: count %g, duration %g, playing %d, time %g", a.count, a.duration,
           a.playing, a.time);
    int box = node_id("box");
    CHECK(box >= 0);
    CHECKF(fabs(node_x(box) - X0) < 1e-5, "the box is posed at time 0 (x %g)", node_x(box));
    CHECKF(fabs(light_x() - X0) < 1e-5, "the lamp follows the box (x %g)", light_x());

    /* a viewer: the clip runs, probes near the box wake */
    pc_ws ws;
    uint32_t view;
    CHECK(pc_stream_open_v2(&d, &ws, &view));
    anim ev = next_anim_event(&ws, 10000);
    CHECKF(ev.ok && ev.count == 1 && ev.playing, "an animation event after the welcome");
    double awake_max = 0, t_first = NAN, t_last = NAN, start = pc_now_ms();
    while (pc_now_ms() - start < 20000 && (awake_max == 0 || pc_now_ms() - start < 1500)) {
        drain(&ws, 100);
        double awake;
        bool converged;
        probe_state(&awake, &converged);
        if (awake > awake_max) awake_max = awake;
        a = get_anim();
        CHECK(a.ok && a.playing && a.time >= 0 && a.time < DURATION);
        if (isnan(t_first)) t_first = a.time;
        t_last = a.time;
    }
    CHECKF(awake_max > 0, "probes woke while the box moved (most awake: %g)", awake_max);
    CHECKF(t_first != t_last, "the time moves while playing (%g, then %g)", t_first, t_last);

    /* pause: the time stays, the node shows the pose at that time */
    CHECK(patch_anim("{\"playing\":false}", &a) == 200);
    CHECK(a.ok && !a.playing && a.count == 1 && a.time >= 0 && a.time < DURATION);
    double paused = a.time;
    CHECKF(fabs(node_x(box) - (X0 + paused)) < 1e-3, "paused at %g: x %g", paused, node_x(box));
    drain(&ws, 400);
    a = get_anim();
    CHECKF(a.ok && !a.playing && a.time == paused, "paused at %g, later %g", paused, a.time);

    /* seek: the answer, the event and the node document agree with the animation at T */
    CHECK(patch_anim("{\"time\":0.5}", &a) == 200);
    CHECK(a.ok && !a.playing && a.time == 0.5);
    ev = next_anim_event(&ws, 10000);
    while (ev.ok && ev.time != 0.5)
        ev = next_anim_event(&ws, 10000); /* the pause's event may come first */
    CHECKF(ev.ok && !ev.playing && ev.time == 0.5, "the seek's animation event");
    CHECKF(fabs(node_x(box) - (X0 + 0.5)) < 1e-5, "x at 0.5 s: %g", node_x(box));
    CHECKF(fabs(light_x() - (X0 + 0.5)) < 1e-5, "the lamp at 0.5 s: x %g", light_x());
    /* a time past the end wraps into the loop */
    CHECK(patch_anim("{\"time\":5.25}", &a) == 200);
    CHECKF(a.ok && fabs(a.time - 1.25) < 1e-9, "5.25 s wraps to %g", a.time);
    CHECKF(fabs(node_x(box) - (X0 + 1.25)) < 1e-5, "x at 1.25 s: %g", node_x(box));
    CHECK(patch_anim("{\"time\":0.5}", &a) == 200);
    /* the lamp leaves the box (a light given a position is detached from its node), so what
     * wakes probes below is the moving box alone (a moving light wakes every probe) */
    cJSON *lights = pc_api_get_json(&d, "/v1/lights");
    int lamp = (int)pc_json_number(
        cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(lights, "lights"), 0), "id");
    cJSON_Delete(lights);
    char path[64];
    snprintf(path, sizeof path, "/v1/lights/%d", lamp);
    pc_http_response r;
    CHECK(pc_api(&d, "PATCH", path, "{\"position\":[0,2.5,1]}", true, &r) == 200);
    pc_http_response_free(&r);

    /* paused, the probe field converges again */
    bool converged = false;
    double awake = -1;
    start = pc_now_ms();
    while (!converged && pc_now_ms() - start < 120000) {
        drain(&ws, 200);
        probe_state(&awake, &converged);
    }
    CHECKF(converged && awake == 0, "converged after the pause (awake %g)", awake);

    test_bad_inputs(box, &a);

    /* play again: the time advances from 0.5 s */
    double t0 = pc_now_ms();
    CHECK(patch_anim("{\"playing\":true}", &a) == 200);
    CHECK(a.ok && a.playing && fabs(a.time - 0.5) < 0.2);
    drain(&ws, 500);
    anim b = get_anim();
    double elapsed = (pc_now_ms() - t0) / 1000.0;
    CHECKF(b.ok && b.playing && loop_delta(0.5, b.time) > 0.4 &&
               loop_delta(0.5, b.time) < elapsed + 0.05,
           "0.5 s, then %g after %.2f s", b.time, elapsed);
    /* the field stays awake while it plays... */
    awake_max = 0;
    start = pc_now_ms();
    while (awake_max == 0 && pc_now_ms() - start < 20000) {
        drain(&ws, 100);
        probe_state(&awake, &converged);
        if (awake > awake_max) awake_max = awake;
    }
    CHECKF(awake_max > 0, "probes wake again when it plays");
    /* ...and the pause pose is where the clock stopped; the lamp stays where it was put */
    CHECK(patch_anim("{\"playing\":false}", &a) == 200);
    CHECKF(fabs(node_x(box) - (X0 + a.time)) < 1e-3, "paused at %g: x %g", a.time, node_x(box));
    CHECK(light_x() == 0);
    converged = false;
    start = pc_now_ms();
    while (!converged && pc_now_ms() - start < 120000) {
        drain(&ws, 200);
        probe_state(&awake, &converged);
    }
    CHECKF(converged, "converged after the second pause");

    /* nobody watches: playing, but the clip stands still */
    CHECK(patch_anim("{\"playing\":true}", &a) == 200);
    pc_ws_close(&ws);
    pc_sleep_ms(500);
    a = get_anim();
    pc_sleep_ms(400);
    b = get_anim();
    CHECKF(a.ok && b.ok && a.playing && b.playing && a.time == b.time,
           "no viewer: the time stays (%g, then %g)", a.time, b.time);

    /* a scene without animations: count 0; playing may be set, the time stays 0 */
    size_t glb_size;
    uint8_t *glb = pc_make_glb(0.3f, &glb_size);
    CHECK(pc_http("127.0.0.1", d.http_port, "PUT", "/v1/scene",
                  "Authorization: Bearer s3cret\r\nContent-Type: model/gltf-binary\r\n", glb,
                  glb_size, &r, 120000) == 200);
    pc_http_response_free(&r);
    free(glb);
    a = get_anim();
    CHECKF(a.ok && a.count == 0 && a.duration == 0 && !a.playing && a.time == 0,
           "no animations: count %g, playing %d", a.count, a.playing);
    CHECK(patch_anim("{\"playing\":true,\"time\":1}", &a) == 200);
    CHECK(a.ok && a.count == 0 && a.playing && a.time == 0);

    CHECK(pc_daemon_alive(&d));
    CHECKF(pc_daemon_stop(&d) == 0, "clean exit after SIGTERM");
    return test_finish();
}
