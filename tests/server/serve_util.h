/* serve_util.h: helpers of the server tests: run the daemon, call its API, build scenes. */
#ifndef PC_SERVE_UTIL_H
#define PC_SERVE_UTIL_H

#include <cjson/cJSON.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

#include "http_client.h"
#include "protocol/stream.h"
#include "socket_util.h"
#include "ws_client.h"

typedef struct pc_daemon {
    pid_t pid;
    unsigned http_port, ws_port;
    const char *token;    /* sent by the helpers below when not NULL */
    const char *log_path; /* when set (before start): the daemon's stderr goes to this file */
} pc_daemon;

/* Starts `probecast serve` with args (NULL-terminated; --http 127.0.0.1:0 is added) and
 * waits for its "probecast serving" line. Returns false on failure. */
bool pc_daemon_start(pc_daemon *d, const char *const *args);
/* SIGTERM, then waits; returns the exit status (or -1 when it did not exit in time / crashed). */
int pc_daemon_stop(pc_daemon *d);
/* True while the process runs. */
bool pc_daemon_alive(pc_daemon *d);
/* A line of the daemon's /proc/PID/status in KiB: "VmRSS" (resident now) or "VmHWM" (its peak);
 * 0 when unreadable. */
unsigned long long pc_daemon_memory_kib(const pc_daemon *d, const char *field);
/* Resets the daemon's VmHWM to its current resident set (/proc/PID/clear_refs, Linux 4.0 and
 * later); false when refused. */
bool pc_daemon_reset_peak(const pc_daemon *d);

/* HTTP call with the daemon's token (auth = true) and a JSON body (may be NULL). */
int pc_api(pc_daemon *d, const char *method, const char *path, const char *json, bool auth,
           pc_http_response *out);
/* GET path and parse the JSON answer (NULL unless status 200). */
cJSON *pc_api_get_json(pc_daemon *d, const char *path);
/* Number member of a JSON object (NaN when absent). */
double pc_json_number(const cJSON *o, const char *name);

/* Opens the stream (token in the query when the daemon has one). */
bool pc_stream_open(pc_daemon *d, pc_ws *ws);

/* Opens the stream with protocol version 2 (a view of its own) and reads the welcome message;
 * *view is the connection's view id. */
bool pc_stream_open_v2(pc_daemon *d, pc_ws *ws, uint32_t *view);
/* A viewer's camera message (protocol/stream.md) with input sequence seq into out. */
void pc_camera_msg(char *out, size_t size, int seq, double px, double py, double pz, double tx,
                   double ty, double tz);
/* The next text message whose "type" is type (any type when NULL), skipping frames and other
 * messages; NULL on timeout. Caller deletes. */
cJSON *pc_stream_next_text(pc_ws *ws, int timeout_ms, const char *type);

typedef struct pc_frame {
    proto_frame_header h;
    uint8_t *rgb; /* width * height * 3, decoded */
    double mean;  /* mean of all channels, 0..255 */
} pc_frame;

/* Receives the next frame (skipping text messages), decodes it and (ack) acknowledges it.
 * Returns false on timeout or error. */
bool pc_stream_next(pc_ws *ws, int timeout_ms, bool ack, pc_frame *f);
void pc_frame_free(pc_frame *f);
/* Mean absolute difference of two same-sized frames, 0..255. */
double pc_frame_diff(const pc_frame *a, const pc_frame *b);

/* The test scene's buffer: floor positions (0, 48 bytes) and u16 indices (48, 12), box
 * positions (60, 96) and u16 indices (156, 72); returns its 228 bytes (bin needs that room). */
size_t pc_scene_bin(uint8_t *bin);
/* A small .glb: a 4 x 4 m grey floor, a red unit box (node 1) at box_x, 0.5, 0, a point light
 * (node 2) of 20 cd at (0, 2.5, 1) and a camera at (0, 1.5, 5). Caller frees. */
uint8_t *pc_make_glb(float box_x, size_t *size);
/* The same scene as a self-contained .gltf (data: URI buffer). Caller frees. */
char *pc_make_gltf(float box_x);

void pc_sleep_ms(int ms);

/* Runs `probecast render MODEL --width w --height h --hdr FILE OPTIONS` (the executable, as a user
 * runs it) and checks that it exits 0 with a w x h image: its luminances (malloc'd; the caller
 * frees) or NULL, and its stdout and stderr in out. */
float *pc_render_luminance(const char *model, const char *options, uint32_t w, uint32_t h,
                           char *out, size_t outlen);

#endif
