/* http_api.c: routing, limits and JSON of the HTTP API v1 on libmicrohttpd. */
#include "http_api.h"
#include "clock.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <microhttpd.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "api_json.h"
#include "log.h"
#include "renderer/gltf_loader.h"
#include "stats_report.h"

#define DEFAULT_MAX_UPLOAD (256u << 20)
#define CALL_TIMEOUT_MS 30000
#define FRAME_TIMEOUT_MS 60000 /* GET /v1/frame.jpg waits this long for a frame to be rendered */
#define SCENE_TIMEOUT_MS 300000
#define MAX_CONCURRENT_UPLOADS 2
#define STATIC_FILE_MAX (64u << 20)

enum { M_GET = 1, M_HEAD = 2, M_PUT = 4, M_PATCH = 8, M_POST = 16, M_DELETE = 32 };

typedef enum route {
    R_STATIC = 0,
    R_HEALTH,
    R_STATS,
    R_METRICS,
    R_OPENAPI,
    R_SCENE,
    R_CAMERA,
    R_LIGHTS,
    R_LIGHT,
    R_NODE,
    R_SETTINGS,
    R_FRAME,
    R_VIEWS,
    R_VIEW_CAMERA,
    R_UNKNOWN, /* under /v1/ but no such resource */
    R_COUNT
} route;

static const unsigned route_methods[R_COUNT] = {
    [R_STATIC] = M_GET | M_HEAD,
    [R_HEALTH] = M_GET | M_HEAD,
    [R_STATS] = M_GET | M_HEAD,
    [R_METRICS] = M_GET | M_HEAD,
    [R_OPENAPI] = M_GET | M_HEAD,
    [R_SCENE] = M_GET | M_HEAD | M_PUT,
    [R_CAMERA] = M_GET | M_HEAD | M_PUT | M_PATCH,
    [R_LIGHTS] = M_GET | M_HEAD | M_POST,
    [R_LIGHT] = M_GET | M_HEAD | M_PATCH | M_DELETE,
    [R_NODE] = M_GET | M_HEAD | M_PATCH,
    [R_SETTINGS] = M_GET | M_HEAD | M_PATCH,
    [R_FRAME] = M_GET | M_HEAD,
    [R_VIEWS] = M_GET | M_HEAD,
    [R_VIEW_CAMERA] = M_GET | M_HEAD | M_PUT | M_PATCH,
    [R_UNKNOWN] = 0,
};

typedef enum body_kind { BODY_NONE, BODY_JSON, BODY_SCENE } body_kind;

struct srv_http {
    srv_http_config cfg;
    char token[256];
    char web_dir[PATH_MAX];
    bool have_web_dir;
    char *openapi;
    size_t openapi_len;
    struct MHD_Daemon *daemon;
    unsigned port;
    double start_ms;
    atomic_uint uploads_in_progress;
    pthread_mutex_t counters_mu;
    srv_http_counters counters;
};

typedef struct request {
    unsigned method;
    route route;
    uint32_t id;
    bool id_ok;
    body_kind body;
    size_t limit;
    uint8_t *data;
    size_t len, cap;
    bool too_large;
    bool responded; /* a response was queued before the body was read */
    bool is_upload; /* counted in uploads_in_progress */
    int status;     /* of the response queued */
    double start_ms;
} request;


/* ---- responses ------------------------------------------------------------------------------ */

static void count_status(srv_http *h, request *rq, int status)
{
    if (rq) rq->status = status;
    pthread_mutex_lock(&h->counters_mu);
    h->counters.requests++;
    if (status < 300)
        h->counters.status_2xx++;
    else if (status < 500)
        h->counters.status_4xx++;
    else
        h->counters.status_5xx++;
    pthread_mutex_unlock(&h->counters_mu);
}

/* Queues body (malloc'd, taken; may be NULL when len is 0). */
static enum MHD_Result respond(srv_http *h, struct MHD_Connection *conn, request *rq, int status,
                               const char *type, char *body, size_t len)
{
    struct MHD_Response *resp =
        body ? MHD_create_response_from_buffer(len, body, MHD_RESPMEM_MUST_FREE)
             : MHD_create_response_from_buffer(0, (void *)"", MHD_RESPMEM_PERSISTENT);
    if (!resp) {
        free(body);
        return MHD_NO;
    }
    if (type) MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, type);
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
    MHD_add_response_header(resp, "X-Content-Type-Options", "nosniff");
    if (status == 401)
        MHD_add_response_header(resp, MHD_HTTP_HEADER_WWW_AUTHENTICATE,
                                "Bearer realm=\"probecast\"");
    if (status == 405 && rq && rq->route < R_COUNT) {
        char allow[64] = "";
        static const char *names[] = {"GET", "HEAD", "PUT", "PATCH", "POST", "DELETE"};
        for (int i = 0; i < 6; i++) {
            if (!(route_methods[rq->route] & (1u << i))) continue;
            if (allow[0]) strcat(allow, ", ");
            strcat(allow, names[i]);
        }
        MHD_add_response_header(resp, MHD_HTTP_HEADER_ALLOW, allow);
    }
    if (status == 503) MHD_add_response_header(resp, MHD_HTTP_HEADER_RETRY_AFTER, "1");
    enum MHD_Result r = MHD_queue_response(conn, (unsigned)status, resp);
    MHD_destroy_response(resp);
    count_status(h, rq, status);
    if (rq) rq->responded = true;
    return r;
}

static enum MHD_Result respond_json(srv_http *h, struct MHD_Connection *conn, request *rq,
                                    int status, cJSON *j)
{
    char *s = srv_json_print_delete(j);
    return respond(h, conn, rq, status, "application/json", s, strlen(s));
}

#if defined(__GNUC__)
__attribute__((format(printf, 6, 7)))
#endif
static enum MHD_Result
respond_error(srv_http *h, struct MHD_Connection *conn, request *rq, int status, const char *code,
              const char *fmt, ...)
{
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    char *s = srv_json_error_body(code, msg);
    return respond(h, conn, rq, status, "application/json", s, strlen(s));
}

static enum MHD_Result respond_api_error(srv_http *h, struct MHD_Connection *conn, request *rq,
                                         const srv_api_error *e)
{
    return respond_error(h, conn, rq, e->status, e->code, "%s", e->message);
}

/* Answers with the render thread's reply to c. */
static enum MHD_Result respond_reply(srv_http *h, struct MHD_Connection *conn, request *rq,
                                     srv_cmd *c)
{
    char *body = c->reply.body;
    c->reply.body = NULL;
    return respond(h, conn, rq, c->reply.status ? c->reply.status : 500,
                   body ? "application/json" : NULL, body, body ? strlen(body) : 0);
}

/* ---- routing ---------------------------------------------------------------------------- */

static unsigned method_bit(const char *m)
{
    static const struct {
        const char *name;
        unsigned bit;
    } t[] = {{"GET", M_GET},     {"HEAD", M_HEAD}, {"PUT", M_PUT},
             {"PATCH", M_PATCH}, {"POST", M_POST}, {"DELETE", M_DELETE}};
    for (size_t i = 0; i < sizeof t / sizeof t[0]; i++)
        if (strcmp(m, t[i].name) == 0) return t[i].bit;
    return 0;
}

/* A decimal id without sign, leading zeros or overflow. */
static bool parse_id(const char *s, uint32_t *out)
{
    if (!*s || strlen(s) > 10 || (s[0] == '0' && s[1])) return false;
    uint64_t v = 0;
    for (const char *p = s; *p; p++) {
        if (*p < '0' || *p > '9') return false;
        v = v * 10 + (uint64_t)(*p - '0');
    }
    if (v > UINT32_MAX) return false;
    *out = (uint32_t)v;
    return true;
}

static route match(const char *url, uint32_t *id, bool *id_ok)
{
    *id_ok = true;
    if (strcmp(url, "/metrics") == 0) return R_METRICS;
    if (strncmp(url, "/v1/", 4) != 0 && strcmp(url, "/v1") != 0) return R_STATIC;
    static const struct {
        const char *path;
        route r;
    } fixed[] = {{"/v1/health", R_HEALTH},        {"/v1/stats", R_STATS},
                 {"/v1/openapi.yaml", R_OPENAPI}, {"/v1/scene", R_SCENE},
                 {"/v1/camera", R_CAMERA},        {"/v1/lights", R_LIGHTS},
                 {"/v1/settings", R_SETTINGS},    {"/v1/frame.jpg", R_FRAME},
                 {"/v1/views", R_VIEWS}};
    for (size_t i = 0; i < sizeof fixed / sizeof fixed[0]; i++)
        if (strcmp(url, fixed[i].path) == 0) return fixed[i].r;
    if (strncmp(url, "/v1/lights/", 11) == 0) {
        *id_ok = parse_id(url + 11, id);
        return R_LIGHT;
    }
    if (strncmp(url, "/v1/nodes/", 10) == 0) {
        *id_ok = parse_id(url + 10, id);
        return R_NODE;
    }
    if (strncmp(url, "/v1/views/", 10) == 0) {
        const char *rest = url + 10, *slash = strchr(rest, '/');
        if (!slash || strcmp(slash, "/camera") != 0) return R_UNKNOWN;
        char num[16];
        size_t n = (size_t)(slash - rest);
        *id_ok = n < sizeof num;
        if (*id_ok) {
            memcpy(num, rest, n);
            num[n] = 0;
            *id_ok = parse_id(num, id);
        }
        return R_VIEW_CAMERA;
    }
    return R_UNKNOWN;
}

static bool auth_ok(srv_http *h, struct MHD_Connection *conn)
{
    if (!h->token[0]) return true;
    const char *a =
        MHD_lookup_connection_value(conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_AUTHORIZATION);
    return a && strncasecmp(a, "Bearer ", 7) == 0 &&
           srv_token_equal(a + 7, strlen(a + 7), h->token);
}

/* The media type without parameters, lower-cased into out. */
static const char *media_type(struct MHD_Connection *conn, char *out, size_t outlen)
{
    const char *t =
        MHD_lookup_connection_value(conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_CONTENT_TYPE);
    if (!t) return NULL;
    size_t n = strcspn(t, ";");
    while (n > 0 && (t[n - 1] == ' ' || t[n - 1] == '\t'))
        n--;
    if (n >= outlen) n = outlen - 1;
    for (size_t i = 0; i < n; i++)
        out[i] = (char)((t[i] >= 'A' && t[i] <= 'Z') ? t[i] + 32 : t[i]);
    out[n] = 0;
    return out;
}

static bool scene_media_type(const char *t)
{
    return strcmp(t, "model/gltf-binary") == 0 || strcmp(t, "model/gltf+json") == 0 ||
           strcmp(t, "application/octet-stream") == 0 || strcmp(t, "application/json") == 0;
}

/* Checks made before any body byte is read. Returns true when a response was queued. */
static bool refuse_early(srv_http *h, struct MHD_Connection *conn, request *rq,
                         enum MHD_Result *ret)
{
#define REFUSE(...) (*ret = respond_error(h, conn, rq, __VA_ARGS__), true)
    if (!rq->method)
        return REFUSE(405, SRV_ERR_METHOD, "This server does not implement that method.");
    if (rq->route == R_UNKNOWN)
        return REFUSE(404, SRV_ERR_NOT_FOUND, "There is no such API resource.");
    if (!(route_methods[rq->route] & rq->method))
        return REFUSE(405, SRV_ERR_METHOD, "This resource does not allow that method.");
    bool mutating = rq->method & (M_PUT | M_PATCH | M_POST | M_DELETE);
    if ((mutating || rq->route == R_FRAME) && !auth_ok(h, conn))
        return REFUSE(401, SRV_ERR_UNAUTHORIZED,
                      "A valid 'Authorization: Bearer <token>' header is required.");
    char type[128];
    const char *mt = media_type(conn, type, sizeof type);
    if (rq->route == R_SCENE && rq->method == M_PUT) {
        if (!mt || !scene_media_type(mt))
            return REFUSE(
                415, SRV_ERR_MEDIA_TYPE,
                "A scene is uploaded as model/gltf-binary (.glb), model/gltf+json (.gltf), "
                "application/json or application/octet-stream (got %s).",
                mt ? mt : "no Content-Type");
        rq->body = BODY_SCENE;
        rq->limit = h->cfg.max_upload;
    } else if (mutating && rq->method != M_DELETE) {
        if (mt && strcmp(mt, "application/json") != 0)
            return REFUSE(415, SRV_ERR_MEDIA_TYPE, "The body must be application/json (got %s).",
                          mt);
        rq->body = BODY_JSON;
        rq->limit = SRV_JSON_BODY_MAX;
    } else {
        rq->body = BODY_NONE;
        rq->limit = SRV_JSON_BODY_MAX; /* read and ignored */
    }
    const char *cl =
        MHD_lookup_connection_value(conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_CONTENT_LENGTH);
    if (cl) {
        char *end = NULL;
        errno = 0;
        unsigned long long n = strtoull(cl, &end, 10);
        if (!*cl || *end || errno || cl[0] == '-')
            return REFUSE(400, SRV_ERR_INVALID_FIELD, "Content-Length is not a number.");
        if (n > rq->limit)
            return REFUSE(413, SRV_ERR_TOO_LARGE,
                          "The body of %llu bytes exceeds the limit of %zu bytes.", n, rq->limit);
    }
    if (rq->body == BODY_SCENE) {
        if (atomic_fetch_add(&h->uploads_in_progress, 1) >= MAX_CONCURRENT_UPLOADS) {
            atomic_fetch_sub(&h->uploads_in_progress, 1);
            return REFUSE(503, SRV_ERR_UNAVAILABLE,
                          "Another scene upload is in progress; try again.");
        }
        rq->is_upload = true;
    }
    return false;
#undef REFUSE
}

/* ---- handlers ------------------------------------------------------------------------------- */

static enum MHD_Result call(srv_http *h, struct MHD_Connection *conn, request *rq, srv_cmd *c,
                            unsigned timeout_ms)
{
    srv_render_call(h->cfg.loop, c, timeout_ms);
    enum MHD_Result r = respond_reply(h, conn, rq, c);
    srv_cmd_unref(c);
    return r;
}

static void snapshot(srv_http *h, srv_stats_snapshot *s)
{
    memset(s, 0, sizeof *s);
    srv_render_get_stats(h->cfg.loop, &s->render);
    srv_encoder_get_stats(h->cfg.encoders, &s->encoder);
    if (h->cfg.ws) srv_ws_get_stats(h->cfg.ws, &s->stream);
    pthread_mutex_lock(&h->counters_mu);
    s->http = h->counters;
    pthread_mutex_unlock(&h->counters_mu);
    s->uptime_s = (srv_mono_ms() - h->start_ms) / 1000.0;
}

static enum MHD_Result handle_health(srv_http *h, struct MHD_Connection *conn, request *rq)
{
    srv_render_stats rs;
    srv_render_get_stats(h->cfg.loop, &rs);
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "status", rs.device_lost ? "degraded" : "ok");
    cJSON_AddStringToObject(j, "version", PROBECAST_VERSION);
    cJSON_AddStringToObject(j, "device", rs.device);
    cJSON_AddNumberToObject(j, "uptime_s", floor(srv_mono_ms() - h->start_ms) / 1000.0);
    cJSON_AddStringToObject(j, "auth", h->token[0] ? "bearer" : "none");
    cJSON *st = cJSON_AddObjectToObject(j, "stream");
    cJSON_AddNumberToObject(st, "port", h->cfg.ws ? srv_ws_port(h->cfg.ws) : 0);
    cJSON_AddStringToObject(st, "path", "/v1/stream");
    cJSON_AddStringToObject(st, "subprotocol", "probecast.v2");
    if (rs.device_lost) cJSON_AddStringToObject(j, "error", rs.last_error);
    return respond_json(h, conn, rq, rs.device_lost ? 503 : 200, j);
}

/* GET /v1/frame.jpg[?view=ID]: the view's current frame; when it has none, or owes one, the
 * render thread is asked for it and the request waits for its encoding. */
static double frame_after(const cJSON *j)
{
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(j, "after");
    return cJSON_IsNumber(a) && a->valuedouble >= 0 ? a->valuedouble : 0;
}

static enum MHD_Result handle_frame(srv_http *h, struct MHD_Connection *conn, request *rq)
{
    uint32_t view = 0;
    const char *q = MHD_lookup_connection_value(conn, MHD_GET_ARGUMENT_KIND, "view");
    if (q && !parse_id(q, &view))
        return respond_error(h, conn, rq, 400, SRV_ERR_INVALID_FIELD,
                             "Query 'view' must be a view id (GET /v1/views lists them).");
    srv_cmd *c = srv_cmd_new(SRV_CMD_FRAME_REQUEST);
    c->view = view;
    srv_render_call(h->cfg.loop, c, CALL_TIMEOUT_MS);
    if (c->reply.status != 200) {
        enum MHD_Result r = respond_reply(h, conn, rq, c);
        srv_cmd_unref(c);
        return r;
    }
    cJSON *j = cJSON_Parse(c->reply.body ? c->reply.body : "");
    double after = frame_after(j);
    cJSON_Delete(j);
    srv_cmd_unref(c);
    srv_frame *f = srv_encoder_wait_frame(h->cfg.encoders, view, (uint64_t)after, FRAME_TIMEOUT_MS);
    if (!f)
        return respond_error(h, conn, rq, 503, SRV_ERR_UNAVAILABLE,
                             "No frame of view %u was rendered in time.", view);
    const srv_jpeg *jp = srv_frame_best(f);
    struct MHD_Response *resp =
        MHD_create_response_from_buffer(jp->size, jp->data, MHD_RESPMEM_MUST_COPY);
    char id[32], qs[8], vs[16];
    snprintf(id, sizeof id, "%llu", (unsigned long long)f->info.frame_id);
    snprintf(qs, sizeof qs, "%u", jp->quality);
    snprintf(vs, sizeof vs, "%u", f->info.view_id);
    srv_frame_unref(f);
    if (!resp) return MHD_NO;
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, "image/jpeg");
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
    MHD_add_response_header(resp, "X-Frame-Id", id);
    MHD_add_response_header(resp, "X-Frame-Quality", qs);
    MHD_add_response_header(resp, "X-View-Id", vs);
    enum MHD_Result r = MHD_queue_response(conn, 200, resp);
    MHD_destroy_response(resp);
    count_status(h, rq, 200);
    rq->responded = true;
    return r;
}

static enum MHD_Result handle_upload(srv_http *h, struct MHD_Connection *conn, request *rq)
{
    rd_scene *scene = calloc(1, sizeof *scene);
    if (!scene) abort();
    char err[512] = "";
    double t0 = srv_mono_ms();
    rd_gltf_result gr = rd_gltf_load_memory(rq->data, rq->len, NULL, NULL, scene, err, sizeof err);
    if (gr != RD_GLTF_OK) {
        free(scene);
        pthread_mutex_lock(&h->counters_mu);
        h->counters.uploads_rejected++;
        pthread_mutex_unlock(&h->counters_mu);
        srv_info("http", "scene upload of %zu bytes rejected: %s", rq->len, err);
        return respond_error(h, conn, rq, 422, SRV_ERR_INVALID_GLTF, "%s",
                             err[0] ? err : rd_gltf_strerror(gr));
    }
    for (uint32_t i = 0; i < scene->warning_count; i++)
        srv_warn("http", "uploaded scene: %s", scene->warnings[i]);
    srv_info("http", "scene upload of %zu bytes parsed in %.0f ms (%llu triangles)", rq->len,
             srv_mono_ms() - t0, (unsigned long long)scene->tri_total);
    /* the BVHs too are built here, on this connection's thread: the render thread only uploads
     * them, so viewers keep seeing the old scene meanwhile */
    rd_gpu_scene_prep *prep = calloc(1, sizeof *prep);
    if (!prep) abort();
    double t1 = srv_mono_ms();
    rd_vk_result pr = rd_gpu_scene_prepare(prep, scene, err, sizeof err);
    if (pr != RD_VK_OK) {
        free(prep);
        rd_scene_destroy(scene);
        free(scene);
        pthread_mutex_lock(&h->counters_mu);
        h->counters.uploads_rejected++;
        pthread_mutex_unlock(&h->counters_mu);
        return respond_error(h, conn, rq, 422, SRV_ERR_INVALID_GLTF, "%s", err);
    }
    srv_info("http", "BVHs of the upload built in %.0f ms", srv_mono_ms() - t1);
    srv_cmd *c = srv_cmd_new(SRV_CMD_REPLACE_SCENE);
    c->scene = scene;
    c->prepared = prep;
    snprintf(c->source, sizeof c->source, "upload");
    srv_render_call(h->cfg.loop, c, SCENE_TIMEOUT_MS);
    pthread_mutex_lock(&h->counters_mu);
    if (c->reply.status == 200)
        h->counters.uploads_accepted++;
    else
        h->counters.uploads_rejected++;
    pthread_mutex_unlock(&h->counters_mu);
    if (c->reply.status == 200 && h->cfg.persist) {
        srv_persist_post_scene(h->cfg.persist, c->reply.scene_generation, rq->data, rq->len);
        rq->data = NULL;
        rq->len = rq->cap = 0;
    }
    enum MHD_Result r = respond_reply(h, conn, rq, c);
    srv_cmd_unref(c);
    return r;
}

/* Answers a GET from the published snapshot (never waits for the render thread). */
static enum MHD_Result handle_get(srv_http *h, struct MHD_Connection *conn, request *rq)
{
    srv_snapshot *snap = h->cfg.snapshot;
    char *text = NULL;
    srv_view_info vi;
    switch (rq->route) {
    case R_SCENE:
        text = srv_snapshot_print(snap, SRV_DOC_SCENE, NULL);
        break;
    case R_LIGHTS:
        text = srv_snapshot_print(snap, SRV_DOC_LIGHTS, NULL);
        break;
    case R_SETTINGS:
        text = srv_snapshot_print(snap, SRV_DOC_SETTINGS, NULL);
        break;
    case R_VIEWS:
        text = srv_snapshot_print(snap, SRV_DOC_VIEWS, NULL);
        break;
    case R_LIGHT:
        text = srv_snapshot_print_light(snap, rq->id);
        if (!text)
            return respond_error(h, conn, rq, 404, SRV_ERR_NOT_FOUND,
                                 "There is no light with id %u.", rq->id);
        break;
    case R_NODE:
        text = srv_snapshot_print_node(snap, rq->id);
        if (!text)
            return respond_error(h, conn, rq, 404, SRV_ERR_NOT_FOUND,
                                 "There is no node with id %u.", rq->id);
        break;
    case R_CAMERA:
    case R_VIEW_CAMERA: {
        uint32_t id = rq->route == R_CAMERA ? SRV_DEFAULT_VIEW : rq->id;
        if (!srv_snapshot_view(snap, id, &vi))
            return respond_error(h, conn, rq, 404, SRV_ERR_NOT_FOUND,
                                 "There is no view with id %u.", id);
        text = srv_json_print_delete(srv_json_camera(&vi.camera));
        break;
    }
    default:
        break;
    }
    if (!text)
        return respond_error(h, conn, rq, 503, SRV_ERR_UNAVAILABLE,
                             "The server is still starting.");
    return respond(h, conn, rq, 200, "application/json", text, strlen(text));
}

static enum MHD_Result handle_json_route(srv_http *h, struct MHD_Connection *conn, request *rq)
{
    if (rq->method & (M_GET | M_HEAD)) return handle_get(h, conn, rq);
    srv_api_error e;
    cJSON *body = NULL;
    if (rq->body == BODY_JSON) {
        body = srv_json_parse_object((const char *)rq->data, rq->len, &e);
        if (!body) return respond_api_error(h, conn, rq, &e);
    }
    srv_cmd *c = NULL;
    bool ok = true;
    switch (rq->route) {
    case R_CAMERA:
    case R_VIEW_CAMERA:
        c = srv_cmd_new(SRV_CMD_SET_CAMERA);
        c->view = rq->route == R_CAMERA ? SRV_DEFAULT_VIEW : rq->id;
        c->replace = rq->method == M_PUT;
        ok = srv_json_camera_patch(body, &c->camera, &e);
        break;
    case R_LIGHTS:
        c = srv_cmd_new(SRV_CMD_ADD_LIGHT);
        ok = srv_json_light_patch(body, &c->light, &e);
        break;
    case R_LIGHT:
        c = srv_cmd_new(rq->method == M_DELETE ? SRV_CMD_DELETE_LIGHT : SRV_CMD_PATCH_LIGHT);
        c->id = rq->id;
        if (rq->method == M_PATCH) ok = srv_json_light_patch(body, &c->light, &e);
        break;
    case R_NODE:
        c = srv_cmd_new(SRV_CMD_PATCH_NODE);
        c->id = rq->id;
        ok = srv_json_node_patch(body, &c->node, &e);
        break;
    case R_SETTINGS:
        c = srv_cmd_new(SRV_CMD_PATCH_SETTINGS);
        ok = srv_json_settings_patch(body, &c->settings, &e);
        break;
    default:
        break;
    }
    cJSON_Delete(body);
    if (!c) return respond_error(h, conn, rq, 500, SRV_ERR_INTERNAL, "Unrouted request.");
    if (!ok) {
        srv_cmd_unref(c);
        return respond_api_error(h, conn, rq, &e);
    }
    return call(h, conn, rq, c, CALL_TIMEOUT_MS);
}

/* ---- static files ------------------------------------------------------------------------ */

static const char *content_type_for(const char *path)
{
    static const struct {
        const char *ext, *type;
    } t[] = {{".html", "text/html; charset=utf-8"},
             {".js", "text/javascript; charset=utf-8"},
             {".mjs", "text/javascript; charset=utf-8"},
             {".css", "text/css; charset=utf-8"},
             {".json", "application/json"},
             {".png", "image/png"},
             {".jpg", "image/jpeg"},
             {".jpeg", "image/jpeg"},
             {".svg", "image/svg+xml"},
             {".ico", "image/x-icon"},
             {".wasm", "application/wasm"},
             {".txt", "text/plain; charset=utf-8"},
             {".map", "application/json"},
             {".yaml", "application/yaml"},
             {".webp", "image/webp"}};
    const char *dot = strrchr(path, '.');
    for (size_t i = 0; dot && i < sizeof t / sizeof t[0]; i++)
        if (strcasecmp(dot, t[i].ext) == 0) return t[i].type;
    return "application/octet-stream";
}

/* Resolves url below the web folder: no "..", no hidden files, and the real path (symlinks
 * followed) must stay inside the folder. */
static bool resolve_static(srv_http *h, const char *url, char *out, size_t outlen)
{
    if (!h->have_web_dir || url[0] != '/' || strlen(url) > 512) return false;
    if (strstr(url, "/.") || strchr(url, '\\') || strstr(url, "//")) return false;
    char joined[PATH_MAX];
    int n = snprintf(joined, sizeof joined, "%s%s", h->web_dir,
                     strcmp(url, "/") == 0 ? "/index.html" : url);
    if (n < 0 || (size_t)n >= sizeof joined) return false;
    char real[PATH_MAX];
    if (!realpath(joined, real)) return false;
    size_t root = strlen(h->web_dir);
    if (strncmp(real, h->web_dir, root) != 0 || real[root] != '/') return false;
    snprintf(out, outlen, "%s", real);
    return true;
}

static enum MHD_Result handle_static(srv_http *h, struct MHD_Connection *conn, request *rq,
                                     const char *url)
{
    char path[PATH_MAX];
    if (!resolve_static(h, url, path, sizeof path)) {
        if (strcmp(url, "/") == 0 || strcmp(url, "/index.html") == 0) {
            const char *page = srv_placeholder_page();
            char *copy = strdup(page);
            if (!copy) abort();
            return respond(h, conn, rq, 200, "text/html; charset=utf-8", copy, strlen(copy));
        }
        return respond_error(h, conn, rq, 404, SRV_ERR_NOT_FOUND, "No such file.");
    }
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    struct stat sb;
    if (fd < 0 || fstat(fd, &sb) != 0 || !S_ISREG(sb.st_mode) ||
        (size_t)sb.st_size > STATIC_FILE_MAX) {
        if (fd >= 0) close(fd);
        return respond_error(h, conn, rq, 404, SRV_ERR_NOT_FOUND, "No such file.");
    }
    struct MHD_Response *resp = MHD_create_response_from_fd((uint64_t)sb.st_size, fd);
    if (!resp) {
        close(fd);
        return MHD_NO;
    }
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, content_type_for(path));
    MHD_add_response_header(resp, "X-Content-Type-Options", "nosniff");
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, "no-cache");
    enum MHD_Result r = MHD_queue_response(conn, 200, resp);
    MHD_destroy_response(resp);
    count_status(h, rq, 200);
    rq->responded = true;
    return r;
}

/* ---- the access handler -------------------------------------------------------------------- */

static enum MHD_Result dispatch(srv_http *h, struct MHD_Connection *conn, request *rq,
                                const char *url)
{
    if (rq->too_large)
        return respond_error(h, conn, rq, 413, SRV_ERR_TOO_LARGE,
                             "The body exceeds the limit of %zu bytes.", rq->limit);
    switch (rq->route) {
    case R_STATIC:
        return handle_static(h, conn, rq, url);
    case R_HEALTH:
        return handle_health(h, conn, rq);
    case R_STATS: {
        srv_stats_snapshot s;
        snapshot(h, &s);
        return respond_json(h, conn, rq, 200, srv_stats_json(&s));
    }
    case R_METRICS: {
        srv_stats_snapshot s;
        snapshot(h, &s);
        char *t = srv_stats_prometheus(&s);
        return respond(h, conn, rq, 200, "text/plain; version=0.0.4; charset=utf-8", t, strlen(t));
    }
    case R_OPENAPI: {
        if (!h->openapi)
            return respond_error(h, conn, rq, 404, SRV_ERR_NOT_FOUND,
                                 "The API description was not found at start-up.");
        char *copy = malloc(h->openapi_len);
        if (!copy) abort();
        memcpy(copy, h->openapi, h->openapi_len);
        return respond(h, conn, rq, 200, "application/yaml", copy, h->openapi_len);
    }
    case R_FRAME:
        return handle_frame(h, conn, rq);
    case R_SCENE:
        if (rq->method == M_PUT) return handle_upload(h, conn, rq);
        return handle_json_route(h, conn, rq);
    case R_LIGHT:
    case R_NODE:
        if (!rq->id_ok)
            return respond_error(h, conn, rq, 404, SRV_ERR_NOT_FOUND, "'%s' is not a %s id.",
                                 strrchr(url, '/') + 1, rq->route == R_LIGHT ? "light" : "node");
        return handle_json_route(h, conn, rq);
    case R_VIEW_CAMERA:
        if (!rq->id_ok)
            return respond_error(h, conn, rq, 404, SRV_ERR_NOT_FOUND, "Not a view id in '%s'.",
                                 url);
        return handle_json_route(h, conn, rq);
    default:
        return handle_json_route(h, conn, rq);
    }
}

static enum MHD_Result on_request(void *cls, struct MHD_Connection *conn, const char *url,
                                  const char *method, const char *version, const char *upload_data,
                                  size_t *upload_data_size, void **con_cls)
{
    (void)version;
    srv_http *h = cls;
    request *rq = *con_cls;
    if (!rq) {
        rq = calloc(1, sizeof *rq);
        if (!rq) abort();
        *con_cls = rq;
        rq->start_ms = srv_mono_ms();
        rq->method = method_bit(method);
        rq->route = match(url, &rq->id, &rq->id_ok);
        enum MHD_Result ret;
        if (refuse_early(h, conn, rq, &ret)) {
            srv_info("http", "%s %s %d (refused before the body)", method, url, rq->status);
            return ret;
        }
        return MHD_YES;
    }
    if (*upload_data_size > 0) {
        size_t n = *upload_data_size;
        *upload_data_size = 0;
        if (rq->responded || rq->too_large) return MHD_YES; /* discarded */
        if (n > rq->limit - rq->len) {
            rq->too_large = true;
            free(rq->data);
            rq->data = NULL;
            rq->len = rq->cap = 0;
            return MHD_YES;
        }
        if (rq->len + n > rq->cap) {
            size_t cap = rq->cap ? rq->cap : 64 * 1024;
            while (cap < rq->len + n)
                cap *= 2;
            if (cap > rq->limit) cap = rq->limit;
            uint8_t *d = realloc(rq->data, cap + 1);
            if (!d) abort();
            rq->data = d;
            rq->cap = cap;
        }
        memcpy(rq->data + rq->len, upload_data, n);
        rq->len += n;
        return MHD_YES;
    }
    if (rq->responded) return MHD_YES;
    enum MHD_Result r = dispatch(h, conn, rq, url);
    double ms = srv_mono_ms() - rq->start_ms;
    if ((rq->method & (M_GET | M_HEAD)) && rq->status < 400)
        srv_debug("http", "%s %s %d (%.1f ms)", method, url, rq->status, ms);
    else
        srv_info("http", "%s %s %d (%.1f ms)", method, url, rq->status, ms);
    return r;
}

static void on_completed(void *cls, struct MHD_Connection *conn, void **con_cls,
                         enum MHD_RequestTerminationCode toe)
{
    (void)conn;
    (void)toe;
    srv_http *h = cls;
    request *rq = *con_cls;
    if (!rq) return;
    if (rq->is_upload) atomic_fetch_sub(&h->uploads_in_progress, 1);
    free(rq->data);
    free(rq);
    *con_cls = NULL;
}

static void mhd_log(void *cls, const char *fmt, va_list ap)
{
    (void)cls;
    char buf[512];
    vsnprintf(buf, sizeof buf, fmt, ap);
    size_t n = strlen(buf);
    while (n > 0 && (buf[n - 1] == '\n' || buf[n - 1] == '\r'))
        buf[--n] = 0;
    srv_warn("mhd", "%s", buf);
}

/* ---- lifecycle ---------------------------------------------------------------------------- */

static void load_openapi(srv_http *h, const char *path)
{
    if (!path) return;
    FILE *f = fopen(path, "rb");
    if (!f) {
        srv_warn("http", "cannot read %s; /v1/openapi.yaml will answer 404", path);
        return;
    }
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    if (n > 0 && n < (16 << 20)) {
        h->openapi = malloc((size_t)n);
        if (!h->openapi) abort();
        h->openapi_len = fread(h->openapi, 1, (size_t)n, f);
    }
    fclose(f);
}

srv_http *srv_http_start(const srv_http_config *cfg, char *err, size_t errlen)
{
    srv_http *h = calloc(1, sizeof *h);
    if (!h) abort();
    h->cfg = *cfg;
    if (!h->cfg.max_upload) h->cfg.max_upload = DEFAULT_MAX_UPLOAD;
    if (!h->cfg.max_connections) h->cfg.max_connections = 64;
    if (!h->cfg.max_per_ip) h->cfg.max_per_ip = 16;
    if (!h->cfg.timeout_s) h->cfg.timeout_s = 30;
    snprintf(h->token, sizeof h->token, "%s", cfg->token ? cfg->token : "");
    h->start_ms = srv_mono_ms();
    pthread_mutex_init(&h->counters_mu, NULL);
    if (cfg->web_dir && realpath(cfg->web_dir, h->web_dir)) h->have_web_dir = true;
    load_openapi(h, cfg->openapi_path);

    struct sockaddr_storage ss;
    memset(&ss, 0, sizeof ss);
    unsigned flags = MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_THREAD_PER_CONNECTION |
                     MHD_USE_POLL | MHD_USE_ERROR_LOG | MHD_USE_ITC;
    struct sockaddr_in *a4 = (struct sockaddr_in *)&ss;
    struct sockaddr_in6 *a6 = (struct sockaddr_in6 *)&ss;
    if (inet_pton(AF_INET, cfg->address, &a4->sin_addr) == 1) {
        a4->sin_family = AF_INET;
        a4->sin_port = htons((uint16_t)cfg->port);
    } else if (inet_pton(AF_INET6, cfg->address, &a6->sin6_addr) == 1) {
        a6->sin6_family = AF_INET6;
        a6->sin6_port = htons((uint16_t)cfg->port);
        flags |= MHD_USE_IPv6;
    } else {
        snprintf(err, errlen, "'%s' is not a numeric IP address", cfg->address);
        srv_http_stop(h);
        return NULL;
    }
    h->daemon =
        MHD_start_daemon(flags, (uint16_t)cfg->port, NULL, NULL, on_request, h,
                         MHD_OPTION_EXTERNAL_LOGGER, mhd_log, NULL, /* first, as MHD asks */
                         MHD_OPTION_SOCK_ADDR, (struct sockaddr *)&ss, MHD_OPTION_CONNECTION_LIMIT,
                         (unsigned int)h->cfg.max_connections, MHD_OPTION_PER_IP_CONNECTION_LIMIT,
                         (unsigned int)h->cfg.max_per_ip, MHD_OPTION_CONNECTION_TIMEOUT,
                         (unsigned int)h->cfg.timeout_s, MHD_OPTION_NOTIFY_COMPLETED, on_completed,
                         h, MHD_OPTION_END);
    if (!h->daemon) {
        snprintf(err, errlen, "cannot listen for HTTP on %s:%u (in use, or not a local address?)",
                 cfg->address, cfg->port);
        srv_http_stop(h);
        return NULL;
    }
    const union MHD_DaemonInfo *di = MHD_get_daemon_info(h->daemon, MHD_DAEMON_INFO_BIND_PORT);
    h->port = di ? di->port : cfg->port;
    return h;
}

unsigned srv_http_port(const srv_http *h)
{
    return h->port;
}

void srv_http_quiesce(srv_http *h)
{
    if (!h || !h->daemon) return;
    MHD_socket s = MHD_quiesce_daemon(h->daemon);
    if (s != MHD_INVALID_SOCKET) close(s);
}

void srv_http_stop(srv_http *h)
{
    if (!h) return;
    if (h->daemon) MHD_stop_daemon(h->daemon);
    h->daemon = NULL;
    free(h->openapi);
    pthread_mutex_destroy(&h->counters_mu);
    free(h);
}
