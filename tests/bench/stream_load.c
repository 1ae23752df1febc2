/* probecast_loadtest: input-to-frame latency and sustained frame rate of a running
 * `probecast serve` with 1..N viewers on the stream, at several resolutions.
 *
 * --mode own (default): every viewer connects with protocol version 2, so it owns a view; it
 * resizes its view to the run's size and orbits its own camera in a closed loop: it sends
 * {"type":"camera","seq":s,...}, waits for the first frame whose header reflects seq s, records
 * the time between (input-to-frame latency), and sends the next. All viewers share one world.
 * --mode shared: the version-1 behaviour: one shared view sized through PATCH /v1/settings;
 * viewer 0 drives the camera, the others watch.
 * Every viewer acknowledges every frame (as the browser viewer does). After a warm-up, frames
 * and bytes per viewer are counted for --seconds; /v1/stats gives the GPU time of a view's
 * frame and of a world update. --format video (own mode) asks every viewer's frames as VP9
 * (protocol/stream.md, the video message; stills stay JPEG); the table's Mbit/s/viewer column
 * compares it with JPEG. Prints a table and writes a CSV. A benchmark, not a test:
 * nothing is asserted. For many large views start the daemon with enough --max-views and
 * --max-total-pixels (50 views of 1920x1080 need 104 M pixels).
 *
 *   probecast_loadtest [--http 127.0.0.1:8080] [--ws H:P (default: the --http address)] [--token T]
 *                      [--mode own|shared] [--sizes 1280x720,1920x1080] [--viewers 1,10,50]
 *                      [--seconds 10] [--warmup 2] [--format jpeg|video]
 *                      [--csv tests/bench/results/stream_load.csv]
 */
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "protocol/stream.h"
#include "tests/server/http_client.h"
#include "tests/server/socket_util.h"
#include "tests/server/ws_client.h"

#define MAX_VIEWERS 200
#define MAX_SAMPLES 100000

static char http_host[64] = "127.0.0.1", ws_host[64] = "127.0.0.1";
static unsigned http_port = 8080, ws_port = 0; /* 0: the stream at the --http address */
static bool ws_given = false;
static const char *token = NULL;
static bool own_views = true;
static bool video = false; /* --format video: own-view viewers ask for VP9 */

typedef struct viewer {
    int index;
    pthread_t thread;
    pc_ws ws;
    bool connected;
    atomic_bool measuring, stop;
    uint64_t frames, bytes; /* while measuring */
    double first_ms, last_ms;
    unsigned w, h; /* own mode: the size it asks for */
    /* drivers only */
    double *latency;
    unsigned latency_count;
} viewer;

static void ack(viewer *v, uint64_t id)
{
    char msg[64];
    snprintf(msg, sizeof msg, "{\"type\":\"ack\",\"frame\":%llu}", (unsigned long long)id);
    pc_ws_send_text(&v->ws, msg);
}

/* Receives one frame; returns its header (false on timeout/close). */
static bool next_frame(viewer *v, int timeout_ms, proto_frame_header *h)
{
    uint8_t *data;
    size_t len;
    for (;;) {
        int op = pc_ws_recv(&v->ws, timeout_ms, &data, &len);
        if (op <= 0 || op == 8) return false;
        if (op != 2) continue;
        if (proto_frame_header_unpack(data, len, h, NULL) != PROTO_OK) return false;
        ack(v, h->frame_id);
        if (atomic_load(&v->measuring)) {
            double t = pc_now_ms();
            if (!v->frames) v->first_ms = t;
            v->last_ms = t;
            v->frames++;
            v->bytes += len;
        }
        return true;
    }
}

static void *viewer_main(void *arg)
{
    viewer *v = arg;
    proto_frame_header h;
    if (own_views) {
        char msg[128];
        snprintf(msg, sizeof msg, "{\"type\":\"resize\",\"width\":%u,\"height\":%u,\"dpr\":1}",
                 v->w, v->h);
        pc_ws_send_text(&v->ws, msg);
        if (video)
            pc_ws_send_text(&v->ws, "{\"type\":\"video\",\"codec\":\"vp9\",\"max_kbps\":null}");
    } else if (v->index != 0) {
        while (!atomic_load(&v->stop))
            next_frame(v, 500, &h);
        return NULL;
    }
    /* a driver: orbit the camera, one input at a time, timing each until its frame arrives;
     * each viewer starts at its own angle */
    uint32_t seq = 0;
    while (!atomic_load(&v->stop)) {
        seq++;
        double a = seq * 0.05 + v->index * 0.7;
        char msg[256];
        snprintf(
            msg, sizeof msg,
            "{\"type\":\"camera\",\"seq\":%u,\"position\":[%.4f,1.2,%.4f],\"target\":[0,0.9,0]}",
            seq, 3.6 * sin(a), 3.6 * cos(a));
        double t0 = pc_now_ms();
        if (pc_ws_send_text(&v->ws, msg) != 0) break;
        bool got = false;
        while (!atomic_load(&v->stop) && !got) {
            if (!next_frame(v, 500, &h)) {
                if (pc_now_ms() - t0 > 60000) break;
                continue;
            }
            got = h.input_seq >= seq;
        }
        if (got && atomic_load(&v->measuring) && v->latency_count < MAX_SAMPLES)
            v->latency[v->latency_count++] = pc_now_ms() - t0;
    }
    return NULL;
}

static bool split_addr(const char *s, char *host, size_t hostlen, unsigned *port)
{
    const char *c = strrchr(s, ':');
    if (!c || (size_t)(c - s) >= hostlen) return false;
    memcpy(host, s, (size_t)(c - s));
    host[c - s] = 0;
    *port = (unsigned)atoi(c + 1);
    return *port > 0;
}

static int api(const char *method, const char *path, const char *json, pc_http_response *r)
{
    char headers[256] = "";
    int n = 0;
    if (token)
        n += snprintf(headers + n, sizeof headers - (size_t)n, "Authorization: Bearer %s\r\n",
                      token);
    if (json)
        snprintf(headers + n, sizeof headers - (size_t)n, "Content-Type: application/json\r\n");
    return pc_http(http_host, http_port, method, path, headers, json, json ? strlen(json) : 0, r,
                   60000);
}

static double json_number(const char *body, const char *key)
{
    const char *p = body ? strstr(body, key) : NULL;
    return p ? atof(p + strlen(key)) : NAN;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double percentile(double *v, unsigned n, double p)
{
    if (!n) return NAN;
    qsort(v, n, sizeof *v, cmp_double);
    unsigned i = (unsigned)floor(p * (n - 1) + 0.5);
    return v[i];
}

typedef struct row {
    unsigned w, h, viewers, connected;
    double fps_mean, fps_min, lat_p50, lat_p99, lat_max, mbps;
    unsigned samples;
    double server_fps, gpu_ms, world_ms, ticks_per_s, encode_ms;
} row;

/* A number inside the "world" object of /v1/stats. */
static double world_number(const char *body, const char *key)
{
    const char *w = body ? strstr(body, "\"world\":") : NULL;
    return w ? json_number(w, key) : NAN;
}

static bool run(unsigned w, unsigned h, unsigned nviewers, double seconds, double warmup, row *out)
{
    memset(out, 0, sizeof *out);
    out->w = w, out->h = h, out->viewers = nviewers;
    char body[128];
    pc_http_response r = {0};
    if (!own_views) {
        snprintf(body, sizeof body, "{\"width\":%u,\"height\":%u}", w, h);
        int s = api("PATCH", "/v1/settings", body, &r);
        if (s != 200) {
            fprintf(stderr, "PATCH /v1/settings %s: %d %s\n", body, s, r.body ? r.body : "");
            pc_http_response_free(&r);
            return false;
        }
        pc_http_response_free(&r);
    }
    viewer *v = calloc(nviewers, sizeof *v);
    char path[256];
    if (token)
        snprintf(path, sizeof path, "/v1/stream?token=%s", token);
    else
        snprintf(path, sizeof path, "/v1/stream");
    for (unsigned i = 0; i < nviewers; i++) {
        v[i].index = (int)i;
        v[i].w = w, v[i].h = h;
        v[i].connected =
            pc_ws_connect(&v[i].ws, ws_host, ws_port, path,
                          own_views ? "Sec-WebSocket-Protocol: probecast.v2\r\n" : NULL,
                          10000) == 0;
        if (!v[i].connected) {
            fprintf(stderr, "viewer %u could not connect (status %d)\n", i, v[i].ws.http_status);
            continue;
        }
        out->connected++;
        if (i == 0 || own_views) v[i].latency = calloc(MAX_SAMPLES, sizeof(double));
        pthread_create(&v[i].thread, NULL, viewer_main, &v[i]);
    }
    struct timespec ts = {(time_t)warmup, (long)((warmup - floor(warmup)) * 1e9)};
    nanosleep(&ts, NULL);
    for (unsigned i = 0; i < nviewers; i++)
        atomic_store(&v[i].measuring, true);
    pc_http_response_free(&r);
    api("GET", "/v1/stats", NULL, &r);
    double frames0 = json_number(r.body, "\"frames_rendered\":");
    double ticks0 = world_number(r.body, "\"ticks\":");
    pc_http_response_free(&r);
    double t0 = pc_now_ms();
    ts = (struct timespec){(time_t)seconds, (long)((seconds - floor(seconds)) * 1e9)};
    nanosleep(&ts, NULL);
    double elapsed = (pc_now_ms() - t0) / 1000.0;
    api("GET", "/v1/stats", NULL, &r);
    double frames1 = json_number(r.body, "\"frames_rendered\":");
    out->gpu_ms = json_number(r.body, "\"gpu_ms_total\":");
    out->world_ms = world_number(r.body, "\"gpu_ms_total\":");
    out->ticks_per_s = (world_number(r.body, "\"ticks\":") - ticks0) / elapsed;
    out->encode_ms = json_number(r.body, "\"encode_ms\":");
    pc_http_response_free(&r);
    out->server_fps = (frames1 - frames0) / elapsed;
    for (unsigned i = 0; i < nviewers; i++) {
        atomic_store(&v[i].measuring, false);
        atomic_store(&v[i].stop, true);
    }
    double fps_sum = 0, bytes = 0;
    out->fps_min = INFINITY;
    for (unsigned i = 0; i < nviewers; i++) {
        if (!v[i].connected) continue;
        pthread_join(v[i].thread, NULL);
        double fps = v[i].frames / elapsed;
        fps_sum += fps;
        if (fps < out->fps_min) out->fps_min = fps;
        bytes += (double)v[i].bytes;
        pc_ws_close(&v[i].ws);
    }
    if (out->connected) {
        out->fps_mean = fps_sum / out->connected;
        out->mbps = bytes * 8 / elapsed / 1e6;
    }
    /* every driver's samples together */
    unsigned total = 0;
    for (unsigned i = 0; i < nviewers; i++)
        total += v[i].latency_count;
    double *all = calloc(total ? total : 1, sizeof *all);
    for (unsigned i = 0; i < nviewers; i++) {
        if (v[i].latency_count)
            memcpy(all + out->samples, v[i].latency, v[i].latency_count * sizeof *all);
        out->samples += v[i].latency_count;
        free(v[i].latency);
    }
    out->lat_max = out->samples ? percentile(all, out->samples, 1.0) : NAN;
    out->lat_p50 = percentile(all, out->samples, 0.5);
    out->lat_p99 = percentile(all, out->samples, 0.99);
    free(all);
    free(v);
    return true;
}

static int parse_list(const char *s, unsigned *out, int max)
{
    int n = 0;
    for (const char *p = s; *p && n < max;) {
        out[n++] = (unsigned)strtoul(p, (char **)&p, 10);
        if (*p == ',')
            p++;
        else
            break;
    }
    return n;
}

int main(int argc, char **argv)
{
    unsigned viewers[16] = {1, 10, 50}, sizes[16][2] = {{1280, 720}, {1920, 1080}};
    int nviewers = 3, nsizes = 2;
    double seconds = 10, warmup = 2;
    const char *csv = "stream_load.csv";
    for (int i = 1; i < argc; i++) {
        const char *o = argv[i], *v = i + 1 < argc ? argv[i + 1] : "";
        if (strcmp(o, "--http") == 0 && ++i) {
            if (!split_addr(v, http_host, sizeof http_host, &http_port)) return 2;
        } else if (strcmp(o, "--ws") == 0 && ++i) {
            if (!split_addr(v, ws_host, sizeof ws_host, &ws_port)) return 2;
            ws_given = true;
        } else if (strcmp(o, "--token") == 0 && ++i) {
            token = v;
        } else if (strcmp(o, "--mode") == 0 && ++i) {
            if (strcmp(v, "own") != 0 && strcmp(v, "shared") != 0) return 2;
            own_views = strcmp(v, "own") == 0;
        } else if (strcmp(o, "--viewers") == 0 && ++i) {
            nviewers = parse_list(v, viewers, 16);
        } else if (strcmp(o, "--sizes") == 0 && ++i) {
            nsizes = 0;
            for (const char *p = v; *p && nsizes < 16;) {
                sizes[nsizes][0] = (unsigned)strtoul(p, (char **)&p, 10);
                if (*p++ != 'x') return 2;
                sizes[nsizes][1] = (unsigned)strtoul(p, (char **)&p, 10);
                nsizes++;
                if (*p == ',') p++;
            }
        } else if (strcmp(o, "--seconds") == 0 && ++i) {
            seconds = atof(v);
        } else if (strcmp(o, "--warmup") == 0 && ++i) {
            warmup = atof(v);
        } else if (strcmp(o, "--format") == 0 && ++i) {
            if (strcmp(v, "jpeg") != 0 && strcmp(v, "video") != 0) return 2;
            video = strcmp(v, "video") == 0;
        } else if (strcmp(o, "--csv") == 0 && ++i) {
            csv = v;
        } else {
            fprintf(stderr,
                    "usage: probecast_loadtest [--http H:P] [--ws H:P] [--token T] [--mode "
                    "own|shared]\n"
                    "                          [--sizes WxH,...] [--viewers N,...] [--seconds S]\n"
                    "                          [--warmup S] [--format jpeg|video] [--csv FILE]\n");
            return strcmp(o, "--help") == 0 ? 0 : 2;
        }
    }
    if (!ws_given) {
        snprintf(ws_host, sizeof ws_host, "%s", http_host);
        ws_port = http_port;
    }
    if (!token) token = getenv("PROBECAST_TOKEN");
    for (int i = 0; i < nviewers; i++)
        if (viewers[i] < 1 || viewers[i] > MAX_VIEWERS) return 2;
    pc_http_response r;
    if (api("GET", "/v1/health", NULL, &r) != 200) {
        fprintf(stderr, "no probecast server at %s:%u\n", http_host, http_port);
        return 1;
    }
    printf("server: %s\n", r.body);
    pc_http_response_free(&r);
    api("GET", "/v1/settings", NULL, &r);
    printf("settings: %s\n", r.body);
    pc_http_response_free(&r);

    FILE *f = fopen(csv, "w");
    if (f)
        fprintf(
            f,
            "mode,format,width,height,viewers,connected,viewer_fps_mean,viewer_fps_min,server_fps,"
            "latency_p50_ms,latency_p99_ms,latency_max_ms,latency_samples,stream_mbit_s,"
            "view_gpu_ms,world_gpu_ms,world_ticks_per_s,encode_ms,mbit_s_per_viewer\n");
    if (video && !own_views) {
        fprintf(stderr, "--format video needs --mode own (version-2 viewers)\n");
        return 2;
    }
    printf("mode: %s; format: %s\n",
           own_views ? "own (every viewer its own view and camera)"
                     : "shared (one view, viewer 0 drives)",
           video ? "video (VP9; stills JPEG)" : "jpeg");
    printf("\n%-10s %7s %10s %10s %10s %9s %9s %9s %8s %9s %9s %8s %8s %8s %9s\n", "size",
           "viewers", "fps/viewer", "fps(min)", "server fps", "lat p50", "lat p99", "lat max",
           "samples", "Mbit/s", "Mb/s/vwr", "view ms", "world ms", "ticks/s", "encode ms");
    for (int s = 0; s < nsizes; s++) {
        for (int k = 0; k < nviewers; k++) {
            row rw;
            if (!run(sizes[s][0], sizes[s][1], viewers[k], seconds, warmup, &rw)) continue;
            char size[24];
            snprintf(size, sizeof size, "%ux%u", rw.w, rw.h);
            double per_viewer = rw.connected ? rw.mbps / rw.connected : 0;
            printf("%-10s %7u %10.2f %10.2f %10.2f %9.1f %9.1f %9.1f %8u %9.2f %9.3f %8.2f %8.2f "
                   "%8.1f %9.2f\n",
                   size, rw.connected, rw.fps_mean, rw.fps_min, rw.server_fps, rw.lat_p50,
                   rw.lat_p99, rw.lat_max, rw.samples, rw.mbps, per_viewer, rw.gpu_ms, rw.world_ms,
                   rw.ticks_per_s, rw.encode_ms);
            fflush(stdout);
            if (f)
                fprintf(
                    f,
                    "%s,%s,%u,%u,%u,%u,%.3f,%.3f,%.3f,%.2f,%.2f,%.2f,%u,%.3f,%.3f,%.3f,%.3f,%.3f,"
                    "%.4f\n",
                    own_views ? "own" : "shared", video ? "video" : "jpeg", rw.w, rw.h, rw.viewers,
                    rw.connected, rw.fps_mean, rw.fps_min, rw.server_fps, rw.lat_p50, rw.lat_p99,
                    rw.lat_max, rw.samples, rw.mbps, rw.gpu_ms, rw.world_ms, rw.ticks_per_s,
                    rw.encode_ms, per_viewer);
        }
    }
    if (f) {
        fclose(f);
        printf("\nwrote %s\n", csv);
    }
    return 0;
}
