/* http_api.h: the HTTP API v1 (protocol/openapi.yaml) and the viewer's static files, on
 * libmicrohttpd with one thread per connection.
 *
 * GET routes answer from the published snapshot (snapshot.h) without waiting for the render
 * thread. For a change, a connection's thread parses and validates the request (JSON bodies;
 * glTF uploads, whose BVHs it builds too), posts a command to the render thread and waits for its
 * reply, so nothing here touches the scene or the GPU. Limits are applied before a body is read:
 * the token (401), the media type (415) and Content-Length against the upload cap (413); bodies
 * without a length are counted as they arrive. Every error answers {"error": code, "message":
 * sentence}.
 */
#ifndef SRV_HTTP_API_H
#define SRV_HTTP_API_H

#include <stdbool.h>
#include <stddef.h>

#include "server/encode/encoder_pool.h"
#include "server/scene/persist.h"
#include "server/render/render_loop.h"
#include "server/stream/ws_stream.h"

typedef struct srv_http_config {
    const char *address;      /* numeric IP to listen on */
    unsigned port;            /* 0 = any free port */
    const char *token;        /* NULL or "" = no token */
    const char *public_names; /* Host names besides loopback and IP literals (comma-separated) */
    size_t max_upload;        /* bytes of a scene upload (0 = 256 MiB) */
    unsigned max_connections; /* 0 = 64 */
    unsigned max_per_ip;      /* 0 = 16 */
    unsigned timeout_s;       /* idle connection timeout (0 = 30) */
    /* viewers of /v1/stream on this address, on top of the connection limits above (the
     * stream applies its own viewer limits as well) */
    unsigned stream_viewers, stream_per_ip;
    const char *web_dir;      /* viewer files, may be NULL */
    const char *openapi_path; /* protocol/openapi.yaml, may be NULL */
    /* both or neither: HTTPS only, with this certificate (chain) and key as PEM text, which must
     * stay valid until srv_http_stop (tls_cert.h checked them) */
    const char *tls_cert_pem, *tls_key_pem;
    srv_render_loop *loop;
    srv_encoder_pool *encoders;
    srv_ws_stream *ws;
    srv_snapshot *snapshot; /* GET routes answer from it */
    srv_persist *persist;   /* may be NULL */
} srv_http_config;

typedef struct srv_http srv_http;

/* Whether this libmicrohttpd can serve HTTPS (it was built with GnuTLS). */
bool srv_http_tls_available(void);
/* Starts listening and serving. NULL with a message on failure. */
srv_http *srv_http_start(const srv_http_config *cfg, char *err, size_t errlen);
unsigned srv_http_port(const srv_http *h);
/* Stops accepting new connections (requests in progress go on). */
void srv_http_quiesce(srv_http *h);
/* Stops, waits for the connection threads and frees h (NULL is fine). */
void srv_http_stop(srv_http *h);

/* The HTML served at / when the web folder has no index.html: a minimal viewer. */
const char *srv_placeholder_page(void);

#endif
