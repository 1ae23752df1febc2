/* serve_util.c: daemon control, API calls, stream frames and test scenes. */
#include "serve_util.h"

#include <errno.h>
#include <math.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <time.h>
#include <turbojpeg.h>
#include <unistd.h>

#include "server/cli/image_io.h"
#include "test_util.h"

void pc_sleep_ms(int ms)
{
    struct timespec ts = {ms / 1000, (long)(ms % 1000) * 1000000L};
    while (nanosleep(&ts, &ts) != 0 && errno == EINTR) {
    }
}

bool pc_daemon_start(pc_daemon *d, const char *const *args)
{
    const char *token = d->token, *log_path = d->log_path;
    memset(d, 0, sizeof *d);
    d->token = token;
    d->log_path = log_path;
    int out[2];
    if (pipe(out) != 0) return false;
    const char *argv[64];
    int n = 0;
    argv[n++] = PROBECAST_EXE;
    argv[n++] = "serve";
    argv[n++] = "--http";
    argv[n++] = "127.0.0.1:0";
    /* no --ws: the stream is reached at /v1/stream of the API's address (ws_port = http_port)
     * unless a test asks for a port of its own */
    for (int i = 0; args && args[i] && n < 62; i++)
        argv[n++] = args[i];
    argv[n] = NULL;
    fprintf(stderr, "starting:");
    for (int i = 0; i < n; i++)
        fprintf(stderr, " %s", argv[i]);
    fprintf(stderr, "\n");
    pid_t pid = fork();
    if (pid < 0) return false;
    if (pid == 0) {
        /* the daemon must not outlive a test that crashes (it would hold ctest's pipes) */
        prctl(PR_SET_PDEATHSIG, SIGTERM);
        dup2(out[1], 1);
        close(out[0]);
        close(out[1]);
        if (log_path) {
            int fd = open(log_path, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
            if (fd >= 0) dup2(fd, 2);
        }
        execv(argv[0], (char *const *)argv);
        _exit(127);
    }
    close(out[1]);
    d->pid = pid;
    /* read stdout until the "probecast serving" line (start-up on lavapipe + ASan is slow) */
    char line[512];
    size_t len = 0;
    double deadline = pc_now_ms() + 120000;
    bool ok = false;
    while (!ok && pc_now_ms() < deadline && len < sizeof line - 1) {
        ssize_t k = read(out[0], line + len, 1);
        if (k <= 0) break;
        if (line[len] == '\n') {
            line[len] = 0;
            ok = sscanf(line, "probecast serving http=127.0.0.1:%u ws=127.0.0.1:%u", &d->http_port,
                        &d->ws_port) == 2;
            len = 0;
            continue;
        }
        len++;
    }
    /* keep draining stdout in the background so the daemon never blocks on it */
    if (ok && fork() == 0) {
        prctl(PR_SET_PDEATHSIG, SIGKILL);
        char buf[256];
        while (read(out[0], buf, sizeof buf) > 0) {
        }
        _exit(0);
    }
    close(out[0]);
    if (!ok) {
        fprintf(stderr, "the daemon did not report its ports\n");
        kill(pid, SIGKILL);
        waitpid(pid, NULL, 0);
        d->pid = 0;
    }
    return ok;
}

unsigned long long pc_daemon_memory_kib(const pc_daemon *d, const char *field)
{
    char path[64], line[256], format[64];
    snprintf(path, sizeof path, "/proc/%d/status", (int)d->pid);
    snprintf(format, sizeof format, "%s: %%llu kB", field);
    FILE *f = fopen(path, "r");
    unsigned long long kib = 0;
    if (!f) return 0;
    while (fgets(line, sizeof line, f))
        if (sscanf(line, format, &kib) == 1) break;
    fclose(f);
    return kib;
}

bool pc_daemon_reset_peak(const pc_daemon *d)
{
    char path[64];
    snprintf(path, sizeof path, "/proc/%d/clear_refs", (int)d->pid);
    FILE *f = fopen(path, "w");
    if (!f) return false;
    bool ok = fputs("5", f) >= 0;
    return fclose(f) == 0 && ok;
}

bool pc_daemon_alive(pc_daemon *d)
{
    if (d->pid <= 0) return false;
    int status;
    return waitpid(d->pid, &status, WNOHANG) == 0;
}

int pc_daemon_stop(pc_daemon *d)
{
    if (d->pid <= 0) return -1;
    kill(d->pid, SIGTERM);
    double deadline = pc_now_ms() + 60000;
    int status = 0;
    for (;;) {
        pid_t r = waitpid(d->pid, &status, WNOHANG);
        if (r == d->pid) break;
        if (pc_now_ms() > deadline) {
            fprintf(stderr, "the daemon did not stop within 60 s\n");
            kill(d->pid, SIGKILL);
            waitpid(d->pid, NULL, 0);
            d->pid = 0;
            return -1;
        }
        pc_sleep_ms(50);
    }
    d->pid = 0;
    if (WIFSIGNALED(status)) {
        fprintf(stderr, "the daemon died of signal %d\n", WTERMSIG(status));
        return -1;
    }
    return WEXITSTATUS(status);
}

int pc_api(pc_daemon *d, const char *method, const char *path, const char *json, bool auth,
           pc_http_response *out)
{
    char headers[512] = "";
    size_t n = 0;
    if (auth && d->token)
        n += (size_t)snprintf(headers + n, sizeof headers - n, "Authorization: Bearer %s\r\n",
                              d->token);
    if (json) snprintf(headers + n, sizeof headers - n, "Content-Type: application/json\r\n");
    return pc_http("127.0.0.1", d->http_port, method, path, headers, json, json ? strlen(json) : 0,
                   out, 120000);
}

cJSON *pc_api_get_json(pc_daemon *d, const char *path)
{
    pc_http_response r;
    if (pc_api(d, "GET", path, NULL, true, &r) != 200) {
        fprintf(stderr, "GET %s: %d %s\n", path, r.status, r.body ? r.body : "");
        pc_http_response_free(&r);
        return NULL;
    }
    cJSON *j = cJSON_Parse(r.body);
    pc_http_response_free(&r);
    return j;
}

double pc_json_number(const cJSON *o, const char *name)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, name);
    return cJSON_IsNumber(v) ? v->valuedouble : NAN;
}

bool pc_stream_open(pc_daemon *d, pc_ws *ws)
{
    char path[256];
    if (d->token)
        snprintf(path, sizeof path, "/v1/stream?token=%s", d->token);
    else
        snprintf(path, sizeof path, "/v1/stream");
    return pc_ws_connect(ws, "127.0.0.1", d->ws_port, path, NULL, 10000) == 0;
}

bool pc_stream_open_v2(pc_daemon *d, pc_ws *ws, uint32_t *view)
{
    char path[256];
    if (d->token)
        snprintf(path, sizeof path, "/v1/stream?token=%s", d->token);
    else
        snprintf(path, sizeof path, "/v1/stream");
    if (pc_ws_connect(ws, "127.0.0.1", d->ws_port, path, "Sec-WebSocket-Protocol: probecast.v2\r\n",
                      10000) != 0)
        return false;
    cJSON *w = pc_stream_next_text(ws, 10000, "welcome");
    double id = pc_json_number(w, "view");
    cJSON_Delete(w);
    if (!(id >= 1)) return false;
    *view = (uint32_t)id;
    return true;
}

cJSON *pc_stream_next_text(pc_ws *ws, int timeout_ms, const char *type)
{
    double deadline = pc_now_ms() + timeout_ms;
    for (;;) {
        double left_ms = deadline - pc_now_ms();
        if (left_ms < 0) return NULL;
        uint8_t *data;
        size_t len;
        int op = pc_ws_recv(ws, (int)(left_ms + 0.999), &data, &len);
        if (op <= 0 || op == 8) return NULL;
        if (op != 1) continue;
        cJSON *j = cJSON_ParseWithLength((const char *)data, len);
        const cJSON *t = cJSON_GetObjectItemCaseSensitive(j, "type");
        if (cJSON_IsString(t) && (!type || strcmp(t->valuestring, type) == 0)) return j;
        cJSON_Delete(j);
    }
}

bool pc_stream_next(pc_ws *ws, int timeout_ms, bool ack, pc_frame *f)
{
    memset(f, 0, sizeof *f);
    double deadline = pc_now_ms() + timeout_ms;
    for (;;) {
        double left_ms = deadline - pc_now_ms();
        if (left_ms < 0) return false;
        int left = (int)(left_ms + 0.999);
        uint8_t *data;
        size_t len;
        int op = pc_ws_recv(ws, left, &data, &len);
        if (op <= 0 || op == 8) return false;
        if (op != 2) continue;
        const uint8_t *jpeg;
        if (proto_frame_header_unpack(data, len, &f->h, &jpeg) != PROTO_OK) return false;
        tjhandle tj = tjInitDecompress();
        int w, h, sub, cs;
        bool ok = tj && tjDecompressHeader3(tj, jpeg, f->h.jpeg_size, &w, &h, &sub, &cs) == 0 &&
                  (unsigned)w == f->h.width && (unsigned)h == f->h.height;
        if (ok) {
            f->rgb = malloc((size_t)w * h * 3);
            if (!f->rgb) abort();
            ok = tjDecompress2(tj, jpeg, f->h.jpeg_size, f->rgb, w, 0, h, TJPF_RGB, 0) == 0;
        }
        if (tj) tjDestroy(tj);
        if (!ok) {
            free(f->rgb);
            f->rgb = NULL;
            return false;
        }
        double sum = 0;
        for (size_t i = 0; i < (size_t)w * h * 3; i++)
            sum += f->rgb[i];
        f->mean = sum / ((double)w * h * 3);
        if (ack) {
            char msg[64];
            snprintf(msg, sizeof msg, "{\"type\":\"ack\",\"frame\":%llu}",
                     (unsigned long long)f->h.frame_id);
            pc_ws_send_text(ws, msg);
        }
        return true;
    }
}

void pc_frame_free(pc_frame *f)
{
    free(f->rgb);
    f->rgb = NULL;
}

double pc_frame_diff(const pc_frame *a, const pc_frame *b)
{
    if (!a->rgb || !b->rgb || a->h.width != b->h.width || a->h.height != b->h.height) return 255;
    size_t n = (size_t)a->h.width * a->h.height * 3;
    double sum = 0;
    for (size_t i = 0; i < n; i++)
        sum += abs((int)a->rgb[i] - (int)b->rgb[i]);
    return sum / n;
}

/* ---- test scenes ---------------------------------------------------------------------------- */

size_t pc_scene_bin(uint8_t *bin)
{
    const float floor_pos[12] = {-2, 0, -2, -2, 0, 2, 2, 0, 2, 2, 0, -2};
    const uint16_t floor_idx[6] = {0, 1, 2, 0, 2, 3};
    float box_pos[24];
    for (int i = 0; i < 8; i++) {
        box_pos[i * 3 + 0] = (i & 1) ? 0.5f : -0.5f;
        box_pos[i * 3 + 1] = (i & 2) ? 0.5f : -0.5f;
        box_pos[i * 3 + 2] = (i & 4) ? 0.5f : -0.5f;
    }
    const uint16_t box_idx[36] = {0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5, 0, 1, 5, 0, 5, 4,
                                  2, 6, 7, 2, 7, 3, 0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6};
    memcpy(bin, floor_pos, 48);
    memcpy(bin + 48, floor_idx, 12);
    memcpy(bin + 60, box_pos, 96);
    memcpy(bin + 156, box_idx, 72);
    return 228;
}

static char *scene_json(float box_x, const char *buffer_uri)
{
    char *j = malloc(8192);
    if (!j) abort();
    snprintf(
        j, 8192,
        "{\"asset\":{\"version\":\"2.0\"},\"extensionsUsed\":[\"KHR_lights_punctual\"],"
        "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"type\":\"point\",\"intensity\":20,"
        "\"color\":[1,1,1]}]}},\"scene\":0,\"scenes\":[{\"nodes\":[0,1,2,3]}],"
        "\"nodes\":[{\"name\":\"floor\",\"mesh\":0},{\"name\":\"box\",\"mesh\":1,\"translation\":[%"
        "g,0.5,0]},"
        "{\"name\":\"lamp\",\"translation\":[0,2.5,1],\"extensions\":{\"KHR_lights_punctual\":{"
        "\"light\":0}}},"
        "{\"name\":\"cam\",\"camera\":0,\"translation\":[0,1.5,5]}],"
        "\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.8,\"znear\":0.05}}],"
        "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.8,0.8,0.8,1]}},"
        "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.9,0.2,0.1,1]}}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"material\":"
        "0}]},"
        "{\"primitives\":[{\"attributes\":{\"POSITION\":2},\"indices\":3,\"material\":1}]}],"
        "\"buffers\":[{\"byteLength\":228%s%s%s}],"
        "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":48},"
        "{\"buffer\":0,\"byteOffset\":48,\"byteLength\":12},{\"buffer\":0,\"byteOffset\":60,"
        "\"byteLength\":96},"
        "{\"buffer\":0,\"byteOffset\":156,\"byteLength\":72}],"
        "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\","
        "\"min\":[-2,0,-2],\"max\":[2,0,2]},{\"bufferView\":1,\"componentType\":5123,\"count\":6,"
        "\"type\":\"SCALAR\"},"
        "{\"bufferView\":2,\"componentType\":5126,\"count\":8,\"type\":\"VEC3\",\"min\":[-0.5,-0.5,"
        "-0.5],"
        "\"max\":[0.5,0.5,0.5]},{\"bufferView\":3,\"componentType\":5123,\"count\":36,\"type\":"
        "\"SCALAR\"}]}",
        (double)box_x, buffer_uri ? ",\"uri\":\"" : "", buffer_uri ? buffer_uri : "",
        buffer_uri ? "\"" : "");
    return j;
}

static void put32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

uint8_t *pc_make_glb(float box_x, size_t *size)
{
    char *json = scene_json(box_x, NULL);
    size_t jl = strlen(json), jpad = (jl + 3) & ~(size_t)3;
    uint8_t bin[256];
    size_t bl = pc_scene_bin(bin), bpad = (bl + 3) & ~(size_t)3;
    size_t total = 12 + 8 + jpad + 8 + bpad;
    uint8_t *g = calloc(1, total);
    if (!g) abort();
    memcpy(g, "glTF", 4);
    put32(g + 4, 2);
    put32(g + 8, (uint32_t)total);
    put32(g + 12, (uint32_t)jpad);
    memcpy(g + 16, "JSON", 4);
    memcpy(g + 20, json, jl);
    memset(g + 20 + jl, ' ', jpad - jl);
    put32(g + 20 + jpad, (uint32_t)bpad);
    memcpy(g + 24 + jpad, "BIN\0", 4);
    memcpy(g + 28 + jpad, bin, bl);
    free(json);
    *size = total;
    return g;
}

char *pc_make_gltf(float box_x)
{
    static const char b64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    uint8_t bin[256];
    size_t bl = pc_scene_bin(bin);
    char uri[512] = "data:application/octet-stream;base64,";
    size_t o = strlen(uri);
    for (size_t i = 0; i < bl; i += 3) {
        uint32_t v = (uint32_t)bin[i] << 16 | (i + 1 < bl ? (uint32_t)bin[i + 1] << 8 : 0) |
                     (i + 2 < bl ? bin[i + 2] : 0);
        uri[o++] = b64[(v >> 18) & 63];
        uri[o++] = b64[(v >> 12) & 63];
        uri[o++] = i + 1 < bl ? b64[(v >> 6) & 63] : '=';
        uri[o++] = i + 2 < bl ? b64[v & 63] : '=';
    }
    uri[o] = 0;
    return scene_json(box_x, uri);
}

float *pc_render_luminance(const char *model, const char *options, uint32_t w, uint32_t h,
                           char *out, size_t outlen)
{
    const char *hdr = test_tmp_path("render-luminance.pfm");
    char cmd[2048];
    snprintf(cmd, sizeof cmd, "'%s' render '%s' --width %u --height %u --hdr '%s' %s 2>&1",
             PROBECAST_EXE, model, w, h, hdr, options);
    remove(hdr);
    FILE *p = popen(cmd, "r");
    out[0] = '\0';
    if (!p) return NULL;
    size_t n = fread(out, 1, outlen - 1, p);
    out[n] = '\0';
    int status = pclose(p);
    CHECKF(WIFEXITED(status) && WEXITSTATUS(status) == 0, "%s\n%s", cmd, out);
    float *rgb = NULL;
    uint32_t iw = 0, ih = 0;
    char err[256];
    if (rd_image_read_pfm(hdr, &rgb, &iw, &ih, err, sizeof err) != RD_IMAGE_OK || iw != w ||
        ih != h) {
        CHECKF(0, "%s: %s", cmd, err);
        free(rgb);
        return NULL;
    }
    for (size_t i = 0; i < (size_t)w * h; i++)
        rgb[i] = 0.2126f * rgb[3 * i] + 0.7152f * rgb[3 * i + 1] + 0.0722f * rgb[3 * i + 2];
    return rgb; /* the first w * h floats */
}

void pc_camera_msg(char *out, size_t size, int seq, double px, double py, double pz, double tx,
                   double ty, double tz)
{
    snprintf(out, size,
             "{\"type\":\"camera\",\"seq\":%d,\"position\":[%.4f,%.4f,%.4f],"
             "\"target\":[%.4f,%.4f,%.4f]}",
             seq, px, py, pz, tx, ty, tz);
}
