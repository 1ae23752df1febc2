/* access.c: who may connect — token comparison, Host and Origin parsing and checks. */
#include "server/api/access.h"

#include <arpa/inet.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

bool srv_token_equal(const char *given, size_t given_len, const char *token)
{
    size_t n = strlen(token);
    unsigned char diff = given_len != n;
    for (size_t i = 0; i < given_len; i++)
        diff |= (unsigned char)(given[i] ^ token[i % (n ? n : 1)]);
    return diff == 0 && n > 0;
}

bool srv_host_is_loopback(const char *h)
{
    return strcasecmp(h, "localhost") == 0 || strncmp(h, "127.", 4) == 0 || strcmp(h, "::1") == 0 ||
           strcmp(h, "[::1]") == 0;
}

/* Splits "host[:port]" or "[v6]:port"; port stays dflt when absent. */
bool srv_split_host_port(const char *s, size_t len, char *host, size_t hostlen, unsigned *port,
                         unsigned dflt)
{
    *port = dflt;
    const char *end = s + len, *colon = NULL;
    if (len > 0 && s[0] == '[') {
        const char *rb = memchr(s, ']', len);
        if (!rb) return false;
        if (rb + 1 < end) {
            if (rb[1] != ':') return false;
            colon = rb + 1;
        }
        size_t hl = (size_t)(rb - s - 1);
        if (hl + 1 > hostlen) return false;
        memcpy(host, s + 1, hl);
        host[hl] = 0;
    } else {
        colon = memchr(s, ':', len);
        size_t hl = colon ? (size_t)(colon - s) : len;
        if (hl == 0 || hl + 1 > hostlen) return false;
        memcpy(host, s, hl);
        host[hl] = 0;
    }
    if (colon) {
        char *e = NULL;
        char buf[8];
        size_t pl = (size_t)(end - colon - 1);
        if (pl == 0 || pl >= sizeof buf) return false;
        memcpy(buf, colon + 1, pl);
        buf[pl] = 0;
        unsigned long p = strtoul(buf, &e, 10);
        if (*e || p == 0 || p > 65535) return false;
        *port = (unsigned)p;
    }
    return true;
}

/* An Origin "http[s]://host[:port][/...]" into host and port (the scheme's default when absent);
 * *dflt gets that default. False for "null", file: and other schemes, or a malformed value. */
static bool parse_origin(const char *origin, char *host, size_t hostlen, unsigned *port,
                         unsigned *dflt)
{
    const char *rest;
    if (strncasecmp(origin, "http://", 7) == 0)
        *dflt = 80, rest = origin + 7;
    else if (strncasecmp(origin, "https://", 8) == 0)
        *dflt = 443, rest = origin + 8;
    else
        return false;
    return srv_split_host_port(rest, strcspn(rest, "/"), host, hostlen, port, *dflt);
}

bool srv_ws_origin_allowed(const char *origin, const char *http_host, unsigned http_port,
                           const char *request_host)
{
    char host[256];
    unsigned port, dflt;
    if (!parse_origin(origin, host, sizeof host, &port, &dflt) || port != http_port) return false;
    bool wildcard = strcmp(http_host, "0.0.0.0") == 0 || strcmp(http_host, "::") == 0;
    if (wildcard) {
        /* listening everywhere: the page must come from the host name this request used */
        char rhost[256];
        unsigned rport;
        if (!request_host || !srv_split_host_port(request_host, strlen(request_host), rhost,
                                                  sizeof rhost, &rport, 80))
            return false;
        return strcasecmp(host, rhost) == 0 ||
               (srv_host_is_loopback(host) && srv_host_is_loopback(rhost));
    }
    return strcasecmp(host, http_host) == 0 ||
           (srv_host_is_loopback(host) && srv_host_is_loopback(http_host));
}

static bool is_ip_literal(const char *host)
{
    unsigned char buf[16];
    return inet_pton(AF_INET, host, buf) == 1 || inet_pton(AF_INET6, host, buf) == 1;
}

static bool listed(const char *host, const char *names)
{
    size_t n = strlen(host);
    for (const char *p = names; p && *p;) {
        size_t len = strcspn(p, ",");
        if (len == n && strncasecmp(p, host, n) == 0) return true;
        p += len;
        if (*p == ',') p++;
    }
    return false;
}

bool srv_host_allowed(const char *host_header, const char *public_names)
{
    char host[256];
    unsigned port;
    if (!host_header ||
        !srv_split_host_port(host_header, strlen(host_header), host, sizeof host, &port, 80))
        return false;
    return srv_host_is_loopback(host) || is_ip_literal(host) || listed(host, public_names);
}

bool srv_host_is_public(const char *host_header, const char *public_names)
{
    char host[256];
    unsigned port;
    return host_header &&
           srv_split_host_port(host_header, strlen(host_header), host, sizeof host, &port, 80) &&
           listed(host, public_names);
}

bool srv_origin_same_host(const char *origin, const char *host_header, const char *public_names)
{
    if (!origin) return true;
    if (!srv_host_allowed(host_header, public_names)) return false;
    char ohost[256], hhost[256];
    unsigned oport, hport, dflt;
    if (!parse_origin(origin, ohost, sizeof ohost, &oport, &dflt) ||
        !srv_split_host_port(host_header, strlen(host_header), hhost, sizeof hhost, &hport, dflt))
        return false;
    bool same_host = strcasecmp(ohost, hhost) == 0 ||
                     (srv_host_is_loopback(ohost) && srv_host_is_loopback(hhost));
    return same_host && oport == hport;
}
