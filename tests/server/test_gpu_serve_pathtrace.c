/* probecast serve in gi_mode pathtrace: while a viewer watches, frames accumulate samples
 * progressively until the target count (GET /v1/stats "pathtrace"), then the daemon idles; a
 * camera move restarts the accumulation; a view nobody watches is not rendered. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "serve_util.h"
#include "test_util.h"

static const char *const args[] = {"--no-animate", "--width", "48", "--height", "32",
                                   "--max-fps", "60", "--scene", "builtin:cornell", NULL};

/* Polls /v1/stats until rendering stops; returns frames rendered (NaN on timeout). */
static double wait_idle(pc_daemon *d, int timeout_ms)
{
    double deadline = pc_now_ms() + timeout_ms;
    while (pc_now_ms() < deadline) {
        pc_sleep_ms(300);
        cJSON *s = pc_api_get_json(d, "/v1/stats");
        const cJSON *rendering = cJSON_GetObjectItemCaseSensitive(s, "rendering");
        double frames = pc_json_number(s, "frames_rendered");
        bool idle = cJSON_IsFalse(rendering);
        cJSON_Delete(s);
        if (idle) return frames;
    }
    return NAN;
}

int main(void)
{
    pc_daemon d = {0};
    if (!pc_daemon_start(&d, args)) {
        CHECK(!"daemon started");
        return test_finish();
    }
    pc_http_response r;
    /* a viewer watches the default view: only watched views are rendered */
    pc_ws ws;
    pc_frame f = {0};
    CHECK(pc_stream_open(&d, &ws));
    cJSON *s = pc_api_get_json(&d, "/v1/stats");
    CHECKF(cJSON_IsNull(cJSON_GetObjectItemCaseSensitive(s, "pathtrace")),
           "no sample count outside path tracing");
    cJSON_Delete(s);
    CHECK(pc_api(&d, "PATCH", "/v1/settings", "{\"gi_mode\":\"pathtrace\"}", false, &r) == 200);
    CHECK(r.body && strstr(r.body, "\"pathtrace\""));
    pc_http_response_free(&r);
    double before = wait_idle(&d, 240000);
    CHECKF(before >= 64, "path tracing stopped after %g frames (64 samples expected)", before);

    s = pc_api_get_json(&d, "/v1/stats");
    const cJSON *gpu = cJSON_GetObjectItemCaseSensitive(s, "gpu_ms");
    CHECK(cJSON_GetObjectItemCaseSensitive(gpu, "path trace") != NULL);
    /* the sample count reached its target, for the watched view 0 and over all */
    const cJSON *pt = cJSON_GetObjectItemCaseSensitive(s, "pathtrace");
    double samples = pc_json_number(pt, "samples"), target = pc_json_number(pt, "target");
    CHECKF(target >= 64 && samples == target, "path trace: %g of %g samples once idle", samples,
           target);
    const cJSON *v0 = cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(pt, "views"), 0);
    CHECKF(pc_json_number(v0, "view") == 0 && pc_json_number(v0, "samples") == target,
           "view 0: %g samples", pc_json_number(v0, "samples"));
    cJSON_Delete(s);

    pc_ws ws2;
    CHECK(pc_stream_open(&d, &ws2));
    CHECK(pc_stream_next(&ws2, 60000, true, &f)); /* a new viewer gets the current frame */
    CHECK(f.mean > 5);                              /* lit, not black */
    pc_frame_free(&f);
    pc_ws_close(&ws2);

    /* a camera move restarts the accumulation: 64 more frames, then idle again. The count
     * restarts when the view's next frame is rendered, after the PATCH has returned, so the
     * stats are polled for it; at --max-fps 60 the 64 samples take over a second to come back,
     * far longer than a poll. */
    CHECK(pc_api(&d, "PATCH", "/v1/camera", "{\"position\":[0.5,1,3.9]}", false, &r) == 200);
    pc_http_response_free(&r);
    double restart_deadline = pc_now_ms() + 20000;
    do {
        s = pc_api_get_json(&d, "/v1/stats");
        samples = pc_json_number(cJSON_GetObjectItemCaseSensitive(s, "pathtrace"), "samples");
        cJSON_Delete(s);
        if (samples < target) break;
        pc_sleep_ms(10);
    } while (pc_now_ms() < restart_deadline);
    CHECKF(samples < target, "a camera move restarts the count: %g of %g", samples, target);
    double after = wait_idle(&d, 240000);
    CHECKF(after >= before + 64, "camera move: %g frames after %g", after, before);
    s = pc_api_get_json(&d, "/v1/stats");
    samples = pc_json_number(cJSON_GetObjectItemCaseSensitive(s, "pathtrace"), "samples");
    CHECKF(samples == target, "after the move: %g of %g samples once idle", samples, target);
    cJSON_Delete(s);
    pc_ws_close(&ws);

    /* nobody watching: a change renders nothing */
    pc_sleep_ms(300);
    CHECK(pc_api(&d, "PATCH", "/v1/camera", "{\"position\":[0.4,1,3.9]}", false, &r) == 200);
    pc_http_response_free(&r);
    double unwatched = wait_idle(&d, 240000);
    CHECKF(unwatched == after, "unwatched view: %g frames after %g", unwatched, after);

    /* views that need probes are refused in this mode */
    CHECK(pc_api(&d, "PATCH", "/v1/settings", "{\"view\":\"probes\"}", false, &r) == 400);
    pc_http_response_free(&r);
    CHECK(pc_daemon_stop(&d) == 0);
    return test_finish();
}
