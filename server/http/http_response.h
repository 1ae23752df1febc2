/* http_response.h: the responses every handler of the HTTP API queues on libmicrohttpd (the
 * dispatcher in http_api.c and the handlers in http_routes.c, http_static.c, http_stream.c).
 * Each counts the status in the server's counters and marks the request answered; errors answer
 * {"error": code, "message": sentence}. Also the id syntax of URLs and queries they share.
 * Not for use outside the HTTP API.
 */
#ifndef SRV_HTTP_RESPONSE_H
#define SRV_HTTP_RESPONSE_H

#include <cjson/cJSON.h>
#include <microhttpd.h>
#include <stdbool.h>
#include <stdint.h>

#include "server/api/api_error.h"
#include "server/api/commands.h"
#include "server/http/http_internal.h"

/* Counts status (rq may be NULL) for a response queued some other way. */
void srv_http_count_status(srv_http *h, request *rq, int status);
/* Queues body (malloc'd, taken; may be NULL when len is 0) with type (may be NULL). */
enum MHD_Result srv_http_respond(srv_http *h, struct MHD_Connection *conn, request *rq, int status,
                                 const char *type, char *body, size_t len);
/* j is printed and deleted. */
enum MHD_Result srv_http_respond_json(srv_http *h, struct MHD_Connection *conn, request *rq,
                                      int status, cJSON *j);
#if defined(__GNUC__)
__attribute__((format(printf, 6, 7)))
#endif
enum MHD_Result
srv_http_respond_error(srv_http *h, struct MHD_Connection *conn, request *rq, int status,
                       const char *code, const char *fmt, ...);
enum MHD_Result srv_http_respond_api_error(srv_http *h, struct MHD_Connection *conn, request *rq,
                                           const srv_api_error *e);
/* Answers with the render thread's reply to c (its body is taken). */
enum MHD_Result srv_http_respond_reply(srv_http *h, struct MHD_Connection *conn, request *rq,
                                       srv_cmd *c);

/* A decimal id without sign, leading zeros or overflow (/v1/lights/{id}, ?view=ID). */
bool srv_http_parse_id(const char *s, uint32_t *out);

#endif
