/* http_response.c: the responses of the HTTP API, queued on libmicrohttpd and counted. See
 * http_response.h. */
#include "server/http/http_response.h"

#include <microhttpd.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "server/api/api_json.h"

/* ---- responses ------------------------------------------------------------------------------ */

void srv_http_count_status(srv_http *h, request *rq, int status)
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
enum MHD_Result srv_http_respond(srv_http *h, struct MHD_Connection *conn, request *rq, int status,
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
    if (status == 405 && rq) {
        char allow[64] = "";
        static const char *names[] = {"GET", "HEAD", "PUT", "PATCH", "POST", "DELETE"};
        for (int i = 0; i < 6; i++) {
            if (!(rq->allow & (1u << i))) continue;
            if (allow[0]) strcat(allow, ", ");
            strcat(allow, names[i]);
        }
        MHD_add_response_header(resp, MHD_HTTP_HEADER_ALLOW, allow);
    }
    if (status == 503) MHD_add_response_header(resp, MHD_HTTP_HEADER_RETRY_AFTER, "1");
    enum MHD_Result r = MHD_queue_response(conn, (unsigned)status, resp);
    MHD_destroy_response(resp);
    srv_http_count_status(h, rq, status);
    if (rq) rq->responded = true;
    return r;
}

enum MHD_Result srv_http_respond_json(srv_http *h, struct MHD_Connection *conn, request *rq,
                                      int status, cJSON *j)
{
    char *s = srv_json_print_delete(j);
    return srv_http_respond(h, conn, rq, status, "application/json", s, strlen(s));
}

#if defined(__GNUC__)
__attribute__((format(printf, 6, 7)))
#endif
enum MHD_Result
srv_http_respond_error(srv_http *h, struct MHD_Connection *conn, request *rq, int status,
                       const char *code, const char *fmt, ...)
{
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    char *s = srv_json_error_body(code, msg);
    return srv_http_respond(h, conn, rq, status, "application/json", s, strlen(s));
}

enum MHD_Result srv_http_respond_api_error(srv_http *h, struct MHD_Connection *conn, request *rq,
                                           const srv_api_error *e)
{
    return srv_http_respond_error(h, conn, rq, e->status, e->code, "%s", e->message);
}

/* Answers with the render thread's reply to c. */
enum MHD_Result srv_http_respond_reply(srv_http *h, struct MHD_Connection *conn, request *rq,
                                       srv_cmd *c)
{
    char *body = c->mail.reply.body;
    c->mail.reply.body = NULL;
    return srv_http_respond(h, conn, rq, c->mail.reply.status ? c->mail.reply.status : 500,
                            body ? "application/json" : NULL, body, body ? strlen(body) : 0);
}

/* ---- request ids ------------------------------------------------------------------------ */

/* A decimal id without sign, leading zeros or overflow. */
bool srv_http_parse_id(const char *s, uint32_t *out)
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
