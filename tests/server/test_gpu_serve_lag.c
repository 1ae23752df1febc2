/* Per-viewer quality from acknowledgement lag (Guacamole's rule): a viewer that acknowledges
 * its frames 250 ms late gets them at quality 30 while a prompt viewer keeps quality 60, from
 * the same stream of frames. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "serve_util.h"
#include "test_util.h"

#define DELAY_MS 250

int main(void)
{
    const char *args[] = {"--no-animate",    "--width", "64", "--height",     "48",  "--probes",
                          "2,2,2",           "--rays",  "16", "--hysteresis", "0.5", "--scene",
                          "builtin:cornell", NULL};
    pc_daemon d = {0};
    if (!pc_daemon_start(&d, args)) {
        CHECK(!"daemon started");
        return test_finish();
    }
    pc_ws a, b;
    CHECK(pc_stream_open(&d, &a));
    CHECK(pc_stream_open(&d, &b));
    struct {
        uint64_t id;
        double due;
    } pending[256];
    unsigned npending = 0, acks_b = 0, frames_a = 0, frames_b_late = 0, q30_b = 0, low_a = 0,
             q60_a = 0;
    uint32_t seq = 0;
    double start = pc_now_ms(), next_input = start;
    while (pc_now_ms() - start < 6000) {
        double now = pc_now_ms();
        if (now >= next_input) { /* viewer A drives the camera, 10 inputs a second */
            char msg[160];
            seq++;
            pc_camera_msg(msg, sizeof msg, (int)seq, (double)(seq % 20) * 0.1 - 1.0, 1.5, 4, 0, 1,
                          0);
            CHECK(pc_ws_send_text(&a, msg) == 0);
            next_input = now + 100;
        }
        pc_frame f;
        while (pc_stream_next(&a, 1, true, &f)) { /* A acknowledges at once */
            frames_a++;
            /* A's lag is a few ms; on a loaded machine it may reach some tens, which caps it a
             * little (90 - (lag - 20)), never down to B's 30 */
            if (!(f.h.flags & PROTO_STREAM_FLAG_STILL)) {
                q60_a += f.h.quality == 60;
                low_a += f.h.quality <= 40;
            }
            pc_frame_free(&f);
        }
        while (pc_stream_next(&b, 1, false, &f)) { /* B acknowledges late */
            if (npending < 256) {
                pending[npending].id = f.h.frame_id;
                pending[npending].due = pc_now_ms() + DELAY_MS;
                npending++;
            }
            if (acks_b >= 3) {
                frames_b_late++;
                q30_b += f.h.quality == 30;
            }
            pc_frame_free(&f);
        }
        for (unsigned i = 0; i < npending;) {
            if (pc_now_ms() < pending[i].due) {
                i++;
                continue;
            }
            char msg[64];
            snprintf(msg, sizeof msg, "{\"type\":\"ack\",\"frame\":%llu}",
                     (unsigned long long)pending[i].id);
            CHECK(pc_ws_send_text(&b, msg) == 0);
            acks_b++;
            pending[i] = pending[--npending];
        }
    }
    fprintf(stderr,
            "A: %u frames (%u interactive at 60, %u at 40 or less); B: %u acks, %u frames after 3 "
            "acks, %u at quality 30\n",
            frames_a, q60_a, low_a, acks_b, frames_b_late, q30_b);
    CHECK(frames_a >= 10 && q60_a >= frames_a / 2 && low_a == 0);
    CHECK(acks_b >= 3 && frames_b_late >= 2 && q30_b >= 1);
    cJSON *stats = pc_api_get_json(&d, "/v1/stats");
    const cJSON *st = cJSON_GetObjectItemCaseSensitive(stats, "stream");
    CHECKF(pc_json_number(st, "lag_ms_max") >= DELAY_MS * 0.8, "lag %g",
           pc_json_number(st, "lag_ms_max"));
    /* input-to-frame stages: one sample per input of A's (its first frame), stages add up */
    const cJSON *lat = cJSON_GetObjectItemCaseSensitive(st, "input_to_frame");
    const cJSON *mean = cJSON_GetObjectItemCaseSensitive(lat, "mean");
    const cJSON *p50 = cJSON_GetObjectItemCaseSensitive(lat, "p50");
    const cJSON *p95 = cJSON_GetObjectItemCaseSensitive(lat, "p95");
    double samples = pc_json_number(lat, "samples");
    CHECKF(samples >= 10 && samples <= seq, "%g latency samples for %u inputs", samples, seq);
    static const char *stages[] = {"queue_ms", "render_ms", "encode_ms", "wait_ms", "transmit_ms"};
    double parts = 0;
    for (int i = 0; i < 5; i++) {
        CHECKF(pc_json_number(mean, stages[i]) >= 0, "%s", stages[i]);
        parts += pc_json_number(mean, stages[i]);
    }
    double total = pc_json_number(mean, "total_ms");
    fprintf(stderr, "input to frame: mean %.2f ms (render %.2f, encode %.2f), p50 %.2f, p95 %.2f\n",
            total, pc_json_number(mean, "render_ms"), pc_json_number(mean, "encode_ms"),
            pc_json_number(p50, "total_ms"), pc_json_number(p95, "total_ms"));
    CHECKF(total > 0 && fabs(parts - total) < 0.01, "stages %g, total %g", parts, total);
    /* every stage is reported in each summary (values are not judged: speed is for benchmarks) */
    for (int i = 0; i < 5; i++)
        CHECKF(cJSON_IsNumber(cJSON_GetObjectItemCaseSensitive(p50, stages[i])) &&
                   cJSON_IsNumber(cJSON_GetObjectItemCaseSensitive(p95, stages[i])),
               "p50 and p95 of %s", stages[i]);
    cJSON_Delete(stats);
    pc_ws_close(&a);
    pc_ws_close(&b);
    CHECKF(pc_daemon_stop(&d) == 0, "clean exit after SIGTERM");
    return test_finish();
}
