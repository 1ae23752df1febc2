/* http_internal.h: what the HTTP API's files share: the server and request state, and the
 * handlers the dispatcher calls (http_api.c: routing, limits and the libmicrohttpd handler;
 * http_routes.c: the API resources; http_static.c: the viewer's files; http_stream.c: the relay
 * of /v1/stream). Responses are queued through http_response.h. Not for use outside the HTTP API.
 */
#ifndef SRV_HTTP_INTERNAL_H
#define SRV_HTTP_INTERNAL_H

#include "server/http/http_admission.h"
#include <limits.h>
#include <microhttpd.h>
#include <pthread.h>
#include <stdatomic.h>

#include "server/http/http_api.h"
#include "server/http/stats_report.h"

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
    R_VIEW_PICK, /* POST /v1/views/{id}/pick: what lies under a point of the picture */
    R_ANIMATION,
    R_STREAM,      /* GET /v1/stream: the WebSocket, handed to the stream (http_stream.c) */
    R_ENVIRONMENT, /* PUT, DELETE /v1/environment: the HDR image (http_routes.c) */
    R_UNKNOWN,     /* under /v1/ but no such resource */
    R_COUNT
} route;

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
    srv_admission admission; /* connections per client address (http_admission.h) */
    pthread_mutex_t counters_mu;
    srv_http_counters counters;
    /* relays of /v1/stream connections (http_stream.c) */
    pthread_mutex_t relay_mu;
    pthread_cond_t relay_done;
    int relay_wake; /* eventfd: readable when the relays must stop; -1 before init */
    unsigned relays;
    bool relays_stopping;
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
    unsigned allow; /* the M_* methods its route allows (the Allow header of a 405) */
    int status;     /* of the response queued */
    int stream_fd;  /* R_STREAM: our end of the pair until the relay takes it; else -1 */
    double start_ms;
} request;

/* ---- what the dispatcher (http_api.c) calls; the handlers answer through http_response.h ---- */
/* ---- the API's resources (http_routes.c) ---- */
void srv_http_stats_snapshot(srv_http *h, srv_stats_snapshot *s);
enum MHD_Result srv_http_handle_health(srv_http *h, struct MHD_Connection *conn, request *rq);
enum MHD_Result srv_http_handle_frame(srv_http *h, struct MHD_Connection *conn, request *rq);
enum MHD_Result srv_http_handle_upload(srv_http *h, struct MHD_Connection *conn, request *rq);
enum MHD_Result srv_http_handle_environment(srv_http *h, struct MHD_Connection *conn, request *rq);
enum MHD_Result srv_http_handle_json_route(srv_http *h, struct MHD_Connection *conn, request *rq);
/* ---- GET /v1/stream (http_stream.c) ---- */
enum MHD_Result srv_http_handle_stream(srv_http *h, struct MHD_Connection *conn, request *rq);
bool srv_http_stream_init(srv_http *h);    /* false: no eventfd */
void srv_http_stream_stop(srv_http *h);    /* ends the relays and waits for them */
void srv_http_stream_destroy(srv_http *h); /* after MHD stopped */
/* ---- the viewer's files (http_static.c) ---- */
enum MHD_Result srv_http_handle_static(srv_http *h, struct MHD_Connection *conn, request *rq,
                                       const char *url);

#endif
