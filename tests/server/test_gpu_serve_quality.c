/* Per-viewer caps end to end on lavapipe (protocol/stream.md, the quality message): a viewer's
 * JPEG cap shows in its frames' header quality, still frames included; its frame-rate cap
 * slows its own view measurably while another viewer's view keeps the global rate; a follower's
 * caps do not change the view it follows; version 1 may not send the message. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "serve_util.h"
#include "test_util.h"

/* No probes: frames cost little and only input renders, so the rate a view gets is its caps'. */
static const char *const args[] = {
    "--no-animate", "--width", "64",      "--height",        "48", "--gi", "off",
    "--max-fps",    "60",      "--scene", "builtin:cornell", NULL};

typedef struct viewer {
    pc_ws ws;
    uint32_t view;
    unsigned frames, q_min, q_max;
    double last_capture_us, min_gap_us; /* between frames rendered (not still re-encodes) */
} viewer;

static void send(viewer *v, const char *json)
{
    CHECKF(pc_ws_send_text(&v->ws, json) == 0, "sent %s", json);
}

static void reset(viewer *v)
{
    v->frames = 0;
    v->q_min = 255;
    v->q_max = 0;
    v->last_capture_us = 0;
    v->min_gap_us = 1e18;
}

/* Takes the frames of v that arrive within ms (acknowledged), counting those of view `view`. */
static void drain(viewer *v, int ms, uint32_t view)
{
    pc_frame f;
    while (pc_stream_next(&v->ws, ms, true, &f)) {
        if (f.h.view_id == view) {
            v->frames++;
            if (f.h.quality < v->q_min) v->q_min = f.h.quality;
            if (f.h.quality > v->q_max) v->q_max = f.h.quality;
            double cap = (double)f.h.capture_us;
            if (cap != v->last_capture_us) { /* a re-encoded still keeps its capture time */
                if (v->last_capture_us && cap - v->last_capture_us < v->min_gap_us)
                    v->min_gap_us = cap - v->last_capture_us;
                v->last_capture_us = cap;
            }
        }
        pc_frame_free(&f);
    }
}

/* Both viewers move their cameras every 10 ms for ms; frames of their own views are counted. */
static void move_both(viewer *a, viewer *b, int ms, int *seq)
{
    reset(a);
    reset(b);
    double end = pc_now_ms() + ms;
    char msg[160];
    for (int i = 0; pc_now_ms() < end; i++) {
        ++*seq;
        pc_camera_msg(msg, sizeof msg, *seq, -1.0 + 0.01 * (i % 200), 1.5, 3.5, 0, 0.5, 0);
        send(a, msg);
        send(b, msg);
        drain(a, 5, a->view);
        drain(b, 5, b->view);
    }
    drain(a, 600, a->view); /* the stills that follow */
    drain(b, 600, b->view);
}

/* Moves both cameras in rounds of 1.5 s until each view got at least n frames (at most four
 * rounds: a loaded machine renders slower, and frame counts in one fixed window made this test
 * fail under load); *a_n and *b_n get the frames, the result is the seconds moved. */
static double move_until(viewer *a, viewer *b, unsigned n, int *seq, unsigned *a_n, unsigned *b_n)
{
    *a_n = *b_n = 0;
    double moved = 0;
    for (int k = 0; k < 4 && (*a_n < n || *b_n < n); k++) {
        move_both(a, b, 1500, seq);
        *a_n += a->frames;
        *b_n += b->frames;
        moved += 1.5;
    }
    return moved;
}

int main(void)
{
    pc_daemon d = {0};
    if (!pc_daemon_start(&d, args)) {
        CHECK(!"daemon started");
        return test_finish();
    }
    viewer a = {0}, b = {0}, c = {0};
    CHECK(pc_stream_open_v2(&d, &a.ws, &a.view));
    CHECK(pc_stream_open_v2(&d, &b.ws, &b.view));
    reset(&a);
    drain(&a, 1500, a.view);
    drain(&b, 500, b.view);
    int seq = 0;

    /* uncapped, both get about the same rate (the global cap or what lavapipe manages) */
    unsigned a_free, b_free;
    double moved = move_until(&a, &b, 12, &seq, &a_free, &b_free);
    double rate = (a_free < b_free ? a_free : b_free) / moved; /* frames a second a view gets */
    printf("uncapped: A %u frames, B %u frames in %.1f s (%.1f a second)\n", a_free, b_free, moved,
           rate);
    CHECKF(a_free >= 12 && b_free >= 12, "uncapped: A %u, B %u frames in %.1f s", a_free, b_free,
           moved);

    /* A caps its view at JPEG quality 40 and 4 frames per second */
    send(&a, "{\"type\":\"quality\",\"jpeg\":40,\"max_fps\":4}");
    reset(&a);
    drain(&a, 500, a.view); /* the still re-encoded under the new cap */
    CHECKF(a.frames >= 1 && a.q_max <= 40, "A's still under its new cap: %u frames, quality %u",
           a.frames, a.q_max);
    move_both(&a, &b, 2500, &seq);
    printf("A capped at 4 fps: A %u frames (quality %u..%u, frames >= %.0f ms apart), B %u "
           "frames (quality %u..%u)\n",
           a.frames, a.q_min, a.q_max, a.min_gap_us / 1000, b.frames, b.q_min, b.q_max);
    CHECKF(a.frames >= 4 && a.frames <= 15, "A capped at 4 fps: %u frames in 2.5 s (+ stills)",
           a.frames);
    CHECKF(a.min_gap_us >= 200000, "A's frames %.0f ms apart at least (250 expected)",
           a.min_gap_us / 1000);
    CHECKF(a.q_max <= 40, "A's frames at quality 40 at most (got up to %u)", a.q_max);
    /* B keeps the uncapped rate: twice A's where the machine renders 10 or more frames a second
     * a view, at least A's where it renders fewer (a loaded machine may be near A's cap itself) */
    if (rate >= 10)
        CHECKF(b.frames >= 2 * a.frames && b.frames >= 20,
               "B is not capped: %u frames beside A's %u", b.frames, a.frames);
    else
        CHECKF(b.frames >= a.frames, "B is not capped: %u frames beside A's %u (%.1f a second)",
               b.frames, a.frames, rate);
    CHECKF(b.q_max > 40, "B's frames keep the server's qualities (up to %u)", b.q_max);

    /* C follows A and sets caps of its own: A's view keeps A's */
    CHECK(pc_stream_open_v2(&d, &c.ws, &c.view));
    char msg[96];
    snprintf(msg, sizeof msg, "{\"type\":\"follow\",\"view\":%u}", a.view);
    send(&c, msg);
    cJSON *fol = pc_stream_next_text(&c.ws, 10000, "following");
    CHECK(pc_json_number(fol, "view") == a.view);
    cJSON_Delete(fol);
    send(&c, "{\"type\":\"quality\",\"jpeg\":20,\"max_fps\":null}");
    reset(&c);
    drain(&c, 800, a.view);
    move_both(&a, &b, 1500, &seq);
    CHECKF(a.frames >= 2 && a.frames <= 9 && a.q_max <= 40 && a.q_min > 20,
           "A's caps after C's message: %u frames, quality %u..%u", a.frames, a.q_min, a.q_max);
    pc_ws_close(&c.ws);

    /* caps lifted: the still comes back at the server's still quality */
    send(&a, "{\"type\":\"quality\",\"jpeg\":null,\"max_fps\":null}");
    reset(&a);
    drain(&a, 800, a.view);
    CHECKF(a.frames >= 1 && a.q_max > 40, "caps lifted: %u frames, quality up to %u", a.frames,
           a.q_max);
    unsigned a_lifted, b_lifted;
    moved = move_until(&a, &b, 12, &seq, &a_lifted, &b_lifted);
    /* faster than the lifted 4 fps cap allows (its frames and stills come to under 5 a second),
     * where the machine renders clearly faster than that */
    CHECKF(a_lifted >= 12 && (a_lifted / moved > 6.0 || rate < 7.5),
           "caps lifted: A %u frames in %.1f s (uncapped %.1f a second)", a_lifted, moved, rate);

    /* an invalid quality message closes the connection (1008) */
    send(&b, "{\"type\":\"quality\",\"jpeg\":0,\"max_fps\":null}");
    uint8_t *data;
    size_t len;
    int op;
    while ((op = pc_ws_recv(&b.ws, 5000, &data, &len)) > 0 && op != 8) {
    }
    CHECKF(op == 8 && b.ws.close_code == 1008, "invalid quality: close %d", b.ws.close_code);
    pc_ws_close(&b.ws);

    /* version 1 shares view 0: no caps for it */
    pc_ws v1;
    CHECK(pc_stream_open(&d, &v1));
    CHECK(pc_ws_send_text(&v1, "{\"type\":\"quality\",\"jpeg\":50,\"max_fps\":null}") == 0);
    while ((op = pc_ws_recv(&v1, 5000, &data, &len)) > 0 && op != 8) {
    }
    CHECKF(op == 8 && v1.close_code == 1008, "version 1 quality message: close %d", v1.close_code);
    pc_ws_close(&v1);

    pc_ws_close(&a.ws);
    CHECKF(pc_daemon_stop(&d) == 0, "clean exit after SIGTERM");
    return test_finish();
}
