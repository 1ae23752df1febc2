/* http_client.c: a minimal HTTP/1.1 client for tests and benchmarks. */
#include "http_client.h"
#include "socket_util.h"

#include <errno.h>
#include <netdb.h>
#include <poll.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

int pc_http(const char *host, unsigned port, const char *method, const char *path,
            const char *headers, const void *body, size_t body_len, pc_http_response *out,
            int timeout_ms)
{
    memset(out, 0, sizeof *out);
    int fd = pc_dial(host, port, timeout_ms);
    if (fd < 0) return 0;
    char req[8192];
    int n = snprintf(req, sizeof req, "%s %s HTTP/1.1\r\nHost: %s:%u\r\nConnection: close\r\n%s",
                     method, path, host, port, headers ? headers : "");
    bool chunked = headers && strstr(headers, "Transfer-Encoding:");
    if ((body || body_len) && !chunked)
        n += snprintf(req + n, sizeof req - (size_t)n, "Content-Length: %zu\r\n", body_len);
    n += snprintf(req + n, sizeof req - (size_t)n, "\r\n");
    /* a send error after the headers is fine: the server may answer early and close */
    if (pc_send_all(fd, req, (size_t)n) == 0 && body && body_len) pc_send_all(fd, body, body_len);
    size_t cap = 65536, len = 0;
    char *buf = malloc(cap + 1);
    if (!buf) abort();
    double deadline = pc_now_ms() + timeout_ms;
    for (;;) {
        int wait = (int)(deadline - pc_now_ms());
        if (wait <= 0) break;
        struct pollfd p = {.fd = fd, .events = POLLIN};
        int r = poll(&p, 1, wait);
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) break;
        if (len == cap) {
            cap *= 2;
            buf = realloc(buf, cap + 1);
            if (!buf) abort();
        }
        ssize_t k = recv(fd, buf + len, cap - len, 0);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) break;
        len += (size_t)k;
    }
    close(fd);
    buf[len] = 0;
    char *end = strstr(buf, "\r\n\r\n");
    int status = 0;
    if (!end || sscanf(buf, "HTTP/1.%*d %d", &status) != 1) {
        free(buf);
        return 0;
    }
    size_t hl = (size_t)(end - buf);
    out->headers = malloc(hl + 1);
    if (!out->headers) abort();
    memcpy(out->headers, buf, hl);
    out->headers[hl] = 0;
    out->body_len = len - hl - 4;
    out->body = malloc(out->body_len + 1);
    if (!out->body) abort();
    memcpy(out->body, end + 4, out->body_len);
    out->body[out->body_len] = 0;
    out->status = status;
    free(buf);
    return status;
}

const char *pc_http_header(const pc_http_response *r, const char *name, char *buf, size_t len)
{
    if (!r->headers) return NULL;
    size_t nl = strlen(name);
    for (const char *line = strstr(r->headers, "\r\n"); line; line = strstr(line + 2, "\r\n")) {
        const char *l = line + 2;
        if (strncasecmp(l, name, nl) == 0 && l[nl] == ':') {
            l += nl + 1;
            while (*l == ' ')
                l++;
            size_t vl = strcspn(l, "\r\n");
            if (vl >= len) vl = len - 1;
            memcpy(buf, l, vl);
            buf[vl] = 0;
            return buf;
        }
    }
    return NULL;
}

void pc_http_response_free(pc_http_response *r)
{
    free(r->headers);
    free(r->body);
    memset(r, 0, sizeof *r);
}
