/* ws_handshake.c: whether the frame stream accepts a WebSocket upgrade (path, Host, Origin,
 * token, viewer and view limits, viewers per address) and what the client offered. */
#include "server/stream/ws_internal.h"

#include <stdio.h>
#include <string.h>
#include <strings.h>

#include "server/api/access.h"

/* The client's address: for a connection handed over by the HTTP API (srv_ws_adopt), the one
 * it was accepted from there (this socket's peer is the API's end of a socket pair). */
void srv_ws_peer_ip(struct lws *wsi, char *ip, size_t n)
{
    const char *adopted = lws_get_opaque_user_data(wsi);
    if (adopted)
        snprintf(ip, n, "%s", adopted);
    else
        lws_get_peer_simple(wsi, ip, n);
}

/* Token from "Authorization: Bearer T", "?token=T" or a "bearer.T" subprotocol entry. */
static bool token_ok(srv_ws_stream *ws, struct lws *wsi)
{
    if (!ws->token[0]) return true;
    char buf[1024];
    int n = lws_hdr_copy(wsi, buf, sizeof buf, WSI_TOKEN_HTTP_AUTHORIZATION);
    if (n > 7 && strncasecmp(buf, "Bearer ", 7) == 0 &&
        srv_token_equal(buf + 7, (size_t)n - 7, ws->token))
        return true;
    const char *v = lws_get_urlarg_by_name(wsi, "token=", buf, sizeof buf);
    if (v && srv_token_equal(v, strlen(v), ws->token)) return true;
    n = lws_hdr_copy(wsi, buf, sizeof buf, WSI_TOKEN_PROTOCOL);
    for (char *save = NULL, *t = n > 0 ? strtok_r(buf, ", ", &save) : NULL; t;
         t = strtok_r(NULL, ", ", &save))
        if (strncmp(t, "bearer.", 7) == 0 && srv_token_equal(t + 7, strlen(t + 7), ws->token))
            return true;
    return false;
}

/* Whether the client asked for protocol version 2 (its own view). */
bool srv_ws_offers_v2(struct lws *wsi)
{
    char buf[1024];
    int n = lws_hdr_copy(wsi, buf, sizeof buf, WSI_TOKEN_PROTOCOL);
    for (char *save = NULL, *t = n > 0 ? strtok_r(buf, ", ", &save) : NULL; t;
         t = strtok_r(NULL, ", ", &save))
        if (strcmp(t, "probecast.v2") == 0) return true;
    return false;
}

/* 0 to accept the upgrade, else a reason logged and the connection refused. */
const char *srv_ws_handshake_refusal(srv_ws_stream *ws, struct lws *wsi)
{
    char buf[1024], host[256] = "";
    if (atomic_load(&ws->stopping)) return "shutting down";
    if (lws_hdr_copy(wsi, buf, sizeof buf, WSI_TOKEN_GET_URI) <= 0 ||
        strcmp(buf, "/v1/stream") != 0)
        return "unknown path";
    lws_hdr_copy(wsi, host, sizeof host, WSI_TOKEN_HOST);
    if (!srv_host_allowed(host, ws->cfg.public_names)) return "host not allowed";
    if (lws_hdr_total_length(wsi, WSI_TOKEN_ORIGIN) > 0) {
        if (lws_hdr_total_length(wsi, WSI_TOKEN_ORIGIN) >= (int)sizeof buf)
            return "origin too long";
        lws_hdr_copy(wsi, buf, sizeof buf, WSI_TOKEN_ORIGIN);
        lws_hdr_copy(wsi, host, sizeof host, WSI_TOKEN_HOST);
        /* the API's own page, or (behind a TLS proxy that forwards Host, under a --public-name)
         * a page of the public origin this very request was sent to */
        if (!srv_ws_origin_allowed(buf, ws->http_host, ws->cfg.http_port, host) &&
            !(srv_host_is_public(host, ws->cfg.public_names) &&
              srv_origin_same_host(buf, host, ws->cfg.public_names)))
            return "origin not allowed";
    }
    if (!token_ok(ws, wsi)) return "missing or wrong token";
    if (ws->viewer_count >= ws->cfg.max_viewers) return "too many viewers";
    if (srv_ws_offers_v2(wsi)) {
        srv_view_limits lim;
        srv_render_view_limits(ws->cfg.loop, &lim);
        if (ws->v2_count + 1 >= lim.max_views)
            return "too many views (the server's --max-views); connect with probecast.v1 to "
                   "share the default view";
    }
    char ip[64] = "";
    srv_ws_peer_ip(wsi, ip, sizeof ip);
    unsigned same = 0;
    for (viewer *v = ws->viewers; v; v = v->next)
        same += strcmp(v->ip, ip) == 0;
    if (same >= ws->cfg.max_per_ip) return "too many viewers from this address";
    return NULL;
}
