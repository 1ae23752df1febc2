/* http_client.h: a minimal blocking HTTP/1.1 client (one request per connection) for tests
 * and the load benchmark. */
#ifndef PC_HTTP_CLIENT_H
#define PC_HTTP_CLIENT_H

#include <stddef.h>

typedef struct pc_http_response {
    int status;    /* 0 when no response arrived */
    char *headers; /* the raw header block */
    char *body;    /* NUL-terminated */
    size_t body_len;
} pc_http_response;

/* Sends method path with extra header lines (may be NULL) and body (may be NULL). With
 * body NULL and body_len > 0, only "Content-Length: body_len" is announced and no byte is
 * sent (to test limits). When headers name a Transfer-Encoding, body is sent as given (already
 * encoded) without Content-Length. Returns the status (0 on failure). */
int pc_http(const char *host, unsigned port, const char *method, const char *path,
            const char *headers, const void *body, size_t body_len, pc_http_response *out,
            int timeout_ms);
/* Value of a response header (case-insensitive name) copied into buf, or NULL. */
const char *pc_http_header(const pc_http_response *r, const char *name, char *buf, size_t len);
void pc_http_response_free(pc_http_response *r);

#endif
