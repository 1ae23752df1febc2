/* http_api.c: routing, limits and the lifecycle of the HTTP API v1 on libmicrohttpd; the
 * resources themselves are in http_routes.c, the viewer's files in http_static.c, the relay of
 * /v1/stream in http_stream.c, and the responses they all queue in http_response.c. */
#include "server/http/http_internal.h"
#include "server/http/http_response.h"

#include "server/api/access.h"

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

#include "server/api/api_json.h"
#include "server/base/clock.h"
#include "server/base/log.h"
#include "server/http/stats_report.h"

#define DEFAULT_MAX_UPLOAD (256u << 20)
#define MAX_CONCURRENT_UPLOADS 2

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
    [R_VIEW_PICK] = M_POST,
    [R_ANIMATION] = M_GET | M_HEAD | M_PATCH,
    [R_STREAM] = M_GET,
    [R_ENVIRONMENT] = M_PUT | M_DELETE,
    [R_UNKNOWN] = 0,
};

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
                 {"/v1/views", R_VIEWS},          {"/v1/animation", R_ANIMATION},
                 {"/v1/stream", R_STREAM},        {"/v1/environment", R_ENVIRONMENT}};
    for (size_t i = 0; i < sizeof fixed / sizeof fixed[0]; i++)
        if (strcmp(url, fixed[i].path) == 0) return fixed[i].r;
    if (strncmp(url, "/v1/lights/", 11) == 0) {
        *id_ok = srv_http_parse_id(url + 11, id);
        return R_LIGHT;
    }
    if (strncmp(url, "/v1/nodes/", 10) == 0) {
        *id_ok = srv_http_parse_id(url + 10, id);
        return R_NODE;
    }
    if (strncmp(url, "/v1/views/", 10) == 0) {
        const char *rest = url + 10, *slash = strchr(rest, '/');
        if (!slash) return R_UNKNOWN;
        route r = strcmp(slash, "/camera") == 0 ? R_VIEW_CAMERA
                  : strcmp(slash, "/pick") == 0 ? R_VIEW_PICK
                                                : R_UNKNOWN;
        if (r == R_UNKNOWN) return R_UNKNOWN;
        char num[16];
        size_t n = (size_t)(slash - rest);
        *id_ok = n < sizeof num;
        if (*id_ok) {
            memcpy(num, rest, n);
            num[n] = 0;
            *id_ok = srv_http_parse_id(num, id);
        }
        return r;
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
#define REFUSE(...) (*ret = srv_http_respond_error(h, conn, rq, __VA_ARGS__), true)
    if (!rq->method)
        return REFUSE(405, SRV_ERR_METHOD, "This server does not implement that method.");
    if (rq->route == R_UNKNOWN)
        return REFUSE(404, SRV_ERR_NOT_FOUND, "There is no such API resource.");
    if (!(rq->allow & rq->method))
        return REFUSE(405, SRV_ERR_METHOD, "This resource does not allow that method.");
    bool mutating = rq->method & (M_PUT | M_PATCH | M_POST | M_DELETE);
    /* DNS rebinding and foreign pages: the Host must name this server, and a browser page may
     * change something only from this server's own origin */
    const char *host = MHD_lookup_connection_value(conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_HOST);
    if (!srv_host_allowed(host, h->cfg.public_names))
        return REFUSE(403, SRV_ERR_FORBIDDEN,
                      "Host '%.80s' is not a name of this server (loopback, an IP address, or "
                      "--public-name).",
                      host ? host : "");
    const char *origin = MHD_lookup_connection_value(conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_ORIGIN);
    if (mutating && !srv_origin_same_host(origin, host, h->cfg.public_names))
        return REFUSE(403, SRV_ERR_FORBIDDEN,
                      "A page from '%.80s' may not change this server; use its own address.",
                      origin);
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
    } else if (rq->route == R_ENVIRONMENT && rq->method == M_PUT) {
        if (mt && strcmp(mt, "image/vnd.radiance") != 0 && strcmp(mt, "image/x-exr") != 0 &&
            strcmp(mt, "application/octet-stream") != 0)
            return REFUSE(415, SRV_ERR_MEDIA_TYPE,
                          "An environment is uploaded as image/vnd.radiance (.hdr), image/x-exr "
                          "(.exr) or application/octet-stream (got %s).",
                          mt);
        rq->body = BODY_SCENE; /* raw bytes, counted against the upload cap */
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

/* ---- the access handler -------------------------------------------------------------------- */

static enum MHD_Result dispatch(srv_http *h, struct MHD_Connection *conn, request *rq,
                                const char *url)
{
    if (rq->too_large)
        return srv_http_respond_error(h, conn, rq, 413, SRV_ERR_TOO_LARGE,
                                      "The body exceeds the limit of %zu bytes.", rq->limit);
    switch (rq->route) {
    case R_STATIC:
        return srv_http_handle_static(h, conn, rq, url);
    case R_HEALTH:
        return srv_http_handle_health(h, conn, rq);
    case R_STATS: {
        srv_stats_snapshot s;
        srv_http_stats_snapshot(h, &s);
        return srv_http_respond_json(h, conn, rq, 200, srv_stats_json(&s));
    }
    case R_METRICS: {
        srv_stats_snapshot s;
        srv_http_stats_snapshot(h, &s);
        char *t = srv_stats_prometheus(&s);
        return srv_http_respond(h, conn, rq, 200, "text/plain; version=0.0.4; charset=utf-8", t,
                                strlen(t));
    }
    case R_OPENAPI: {
        if (!h->openapi)
            return srv_http_respond_error(h, conn, rq, 404, SRV_ERR_NOT_FOUND,
                                          "The API description was not found at start-up.");
        char *copy = malloc(h->openapi_len);
        if (!copy) abort();
        memcpy(copy, h->openapi, h->openapi_len);
        return srv_http_respond(h, conn, rq, 200, "application/yaml", copy, h->openapi_len);
    }
    case R_FRAME:
        return srv_http_handle_frame(h, conn, rq);
    case R_STREAM:
        return srv_http_handle_stream(h, conn, rq);
    case R_ENVIRONMENT:
        return srv_http_handle_environment(h, conn, rq);
    case R_SCENE:
        if (rq->method == M_PUT) return srv_http_handle_upload(h, conn, rq);
        return srv_http_handle_json_route(h, conn, rq);
    case R_LIGHT:
    case R_NODE:
        if (!rq->id_ok)
            return srv_http_respond_error(h, conn, rq, 404, SRV_ERR_NOT_FOUND,
                                          "'%s' is not a %s id.", strrchr(url, '/') + 1,
                                          rq->route == R_LIGHT ? "light" : "node");
        return srv_http_handle_json_route(h, conn, rq);
    case R_VIEW_CAMERA:
    case R_VIEW_PICK:
        if (!rq->id_ok)
            return srv_http_respond_error(h, conn, rq, 404, SRV_ERR_NOT_FOUND,
                                          "Not a view id in '%s'.", url);
        return srv_http_handle_json_route(h, conn, rq);
    default:
        return srv_http_handle_json_route(h, conn, rq);
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
        rq->stream_fd = -1;
        rq->start_ms = srv_mono_ms();
        rq->method = method_bit(method);
        rq->route = match(url, &rq->id, &rq->id_ok);
        rq->allow = route_methods[rq->route];
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
    if (rq->stream_fd >= 0) close(rq->stream_fd); /* the upgrade never happened */
    free(rq->data);
    free(rq);
    *con_cls = NULL;
}

/* While srv_http_start runs MHD_start_daemon on this thread: where MHD's first message goes, so
 * that a failure can say what MHD said. */
static _Thread_local char *start_message;
static _Thread_local size_t start_message_len;

static void mhd_log(void *cls, const char *fmt, va_list ap)
{
    (void)cls;
    char buf[512];
    vsnprintf(buf, sizeof buf, fmt, ap);
    size_t n = strlen(buf);
    while (n > 0 && (buf[n - 1] == '\n' || buf[n - 1] == '\r'))
        buf[--n] = 0;
    if (start_message && !start_message[0]) snprintf(start_message, start_message_len, "%s", buf);
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

bool srv_http_tls_available(void)
{
    return MHD_is_feature_supported(MHD_FEATURE_TLS) == MHD_YES;
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
    /* per address: plain requests and the relayed stream together */
    srv_admission_init(&h->admission, h->cfg.max_connections + h->cfg.stream_viewers,
                       h->cfg.max_per_ip + h->cfg.stream_per_ip);
    h->relay_wake = -1;
    if (!srv_http_stream_init(h)) {
        snprintf(err, errlen, "cannot create an eventfd");
        srv_http_stop(h);
        return NULL;
    }
    if (cfg->web_dir && realpath(cfg->web_dir, h->web_dir)) h->have_web_dir = true;
    load_openapi(h, cfg->openapi_path);

    struct sockaddr_storage ss;
    memset(&ss, 0, sizeof ss);
    unsigned flags = MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_THREAD_PER_CONNECTION |
                     MHD_USE_POLL | MHD_USE_ERROR_LOG | MHD_USE_ITC | MHD_ALLOW_UPGRADE;
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
    /* HTTPS: TLS 1.2 and 1.3 only; the PEM text is GnuTLS's to parse (the chain included) */
    bool tls = cfg->tls_cert_pem && cfg->tls_key_pem;
    struct MHD_OptionItem tls_options[] = {
        {MHD_OPTION_HTTPS_MEM_CERT, 0, (void *)cfg->tls_cert_pem},
        {MHD_OPTION_HTTPS_MEM_KEY, 0, (void *)cfg->tls_key_pem},
        {MHD_OPTION_HTTPS_PRIORITIES, 0, (void *)"NORMAL:-VERS-ALL:+VERS-TLS1.3:+VERS-TLS1.2"},
        {MHD_OPTION_END, 0, NULL},
    };
    const struct MHD_OptionItem *tls_end =
        &tls_options[sizeof tls_options / sizeof *tls_options - 1];
    if (tls) {
        if (!srv_http_tls_available()) {
            snprintf(err, errlen,
                     "this libmicrohttpd was built without TLS, so it cannot serve HTTPS "
                     "(Debian's libmicrohttpd12 has it, through GnuTLS)");
            srv_http_stop(h);
            return NULL;
        }
        flags |= MHD_USE_TLS;
    }
    char mhd_said[256] = "";
    start_message = mhd_said;
    start_message_len = sizeof mhd_said;
    h->daemon = MHD_start_daemon(
        flags, (uint16_t)cfg->port, srv_admission_accept, &h->admission, on_request, h,
        MHD_OPTION_EXTERNAL_LOGGER, mhd_log,
        NULL, /* first, as MHD asks */
        MHD_OPTION_SOCK_ADDR, (struct sockaddr *)&ss, MHD_OPTION_CONNECTION_LIMIT,
        (unsigned int)(h->cfg.max_connections + h->cfg.stream_viewers),
        MHD_OPTION_NOTIFY_CONNECTION, srv_admission_notify, &h->admission,
        MHD_OPTION_CONNECTION_TIMEOUT, (unsigned int)h->cfg.timeout_s,
        MHD_OPTION_NOTIFY_COMPLETED, on_completed, h,
        MHD_OPTION_ARRAY, tls ? tls_options : tls_end, MHD_OPTION_END);
    start_message = NULL;
    if (!h->daemon) {
        size_t n = strlen(mhd_said);
        while (n > 0 && (mhd_said[n - 1] == '.' || mhd_said[n - 1] == ' '))
            mhd_said[--n] = 0;
        if (tls && mhd_said[0])
            snprintf(err, errlen, "cannot serve HTTPS on %s:%u: %s", cfg->address, cfg->port,
                     mhd_said);
        else
            snprintf(err, errlen,
                     "cannot listen for HTTP on %s:%u (in use, or not a local address?)",
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
    srv_http_stream_stop(h); /* MHD waits for upgraded connections */
    if (h->daemon) MHD_stop_daemon(h->daemon);
    h->daemon = NULL;
    srv_http_stream_destroy(h);
    srv_admission_destroy(&h->admission);
    free(h->openapi);
    pthread_mutex_destroy(&h->counters_mu);
    free(h);
}
