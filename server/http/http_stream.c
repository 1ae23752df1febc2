/* http_stream.c: GET /v1/stream on the API's own address, so that a browser needs one URL (one
 * origin, one port, one TLS certificate, one proxy route).
 *
 * How: libmicrohttpd keeps the HTTP side (its limits, timeouts and TLS) and libwebsockets keeps
 * the WebSocket protocol (framing, pings, flow control: ws_stream.c). lws cannot adopt a
 * connection that is already past its handshake, and MHD sends the 101 answer itself, so the API
 * hands the request over through a socket pair:
 *   1. the upgrade request's head is written again into one end of a socket pair whose other end
 *      the stream adopts (srv_ws_adopt), so lws runs its usual checks (path, Host, Origin, token,
 *      subprotocol, viewer limits) and answers;
 *   2. that answer goes to the client through MHD: its 101 with lws's Sec-WebSocket-Accept and
 *      chosen subprotocol, or its refusal (401, 403, ...) as a JSON error;
 *   3. after the 101, a relay thread copies bytes both ways between the client's socket (or, over
 *      TLS, MHD's plaintext end of it) and the pair, until either side closes.
 * The cost is one copy of the stream's bytes; --ws still opens a port of lws's own without it.
 * Measured on an H200 (tests/bench/results/h200/stream_relay.txt): 1080p, 10 viewers of their
 * own views, p50 input-to-frame 20.6-22.8 ms relayed against 19.6-19.7 ms on --ws, the same
 * frame rates; before the relayed socket got TCP_NODELAY, Nagle made it 36 ms.
 * The relays end before MHD stops (srv_http_stream_stop), since MHD waits for upgraded
 * connections. */
#include "server/http/http_internal.h"
#include "server/http/http_response.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include "server/api/api_json.h"
#include "server/base/clock.h"
#include "server/base/log.h"

#define HEAD_MAX 8192          /* the request head written to the stream, and its answer */
#define ANSWER_TIMEOUT_MS 5000 /* for the stream's answer to the handshake */
#define RELAY_BUFFER (64 * 1024)

typedef struct relay {
    srv_http *h;
    int inner;                             /* our end of the pair */
    struct MHD_UpgradeResponseHandle *urh; /* the client's side, closed through MHD */
    int client;
    uint8_t up[RELAY_BUFFER], down[RELAY_BUFFER]; /* client → stream, stream → client */
    size_t up_len, up_pos, down_len, down_pos;
} relay;

/* ---- the request head, written again ------------------------------------------------------ */

typedef struct head {
    char s[HEAD_MAX];
    size_t n;
    bool overflow;
} head;

#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
static void
head_printf(head *b, const char *fmt, ...)
{
    if (b->overflow) return;
    va_list ap;
    va_start(ap, fmt);
    int k = vsnprintf(b->s + b->n, sizeof b->s - b->n, fmt, ap);
    va_end(ap);
    if (k < 0 || (size_t)k >= sizeof b->s - b->n)
        b->overflow = true;
    else
        b->n += (size_t)k;
}

static void head_percent(head *b, const char *v)
{
    for (const unsigned char *p = (const unsigned char *)v; p && *p; p++) {
        if ((*p >= 'A' && *p <= 'Z') || (*p >= 'a' && *p <= 'z') || (*p >= '0' && *p <= '9') ||
            strchr("-._~", *p))
            head_printf(b, "%c", *p);
        else
            head_printf(b, "%%%02X", *p);
    }
}

static enum MHD_Result add_argument(void *cls, enum MHD_ValueKind kind, const char *key,
                                    const char *value)
{
    (void)kind;
    head *b = cls;
    head_printf(b, "%s", b->s[b->n - 1] == '?' ? "" : "&");
    head_percent(b, key);
    if (value) {
        head_printf(b, "=");
        head_percent(b, value);
    }
    return MHD_YES;
}

static enum MHD_Result add_header(void *cls, enum MHD_ValueKind kind, const char *key,
                                  const char *value)
{
    (void)kind;
    head *b = cls;
    /* MHD has parsed these; a CR or LF inside would make a second request */
    if (strpbrk(key, "\r\n") || (value && strpbrk(value, "\r\n"))) {
        b->overflow = true;
        return MHD_NO;
    }
    head_printf(b, "%s: %s\r\n", key, value ? value : "");
    return MHD_YES;
}

/* ---- the stream's answer ------------------------------------------------------------------ */

typedef struct answer {
    int status;
    char accept[128], protocol[128], extensions[256];
    char why[256]; /* a refusal's text, tags removed */
} answer;

static bool wait_readable(int fd, double deadline_ms)
{
    for (;;) {
        double left = deadline_ms - srv_mono_ms();
        if (left <= 0) return false;
        struct pollfd p = {.fd = fd, .events = POLLIN};
        int r = poll(&p, 1, (int)left + 1);
        if (r > 0) return true;
        if (r < 0 && errno != EINTR) return false;
    }
}

static void header_value(const char *headers, const char *name, char *out, size_t cap)
{
    out[0] = 0;
    size_t n = strlen(name);
    for (const char *l = headers; l && *l; l = strstr(l, "\r\n") ? strstr(l, "\r\n") + 2 : NULL) {
        if (strncasecmp(l, name, n) != 0 || l[n] != ':') continue;
        const char *v = l + n + 1;
        while (*v == ' ' || *v == '\t')
            v++;
        size_t len = strcspn(v, "\r\n");
        while (len > 0 && (v[len - 1] == ' ' || v[len - 1] == '\t'))
            len--;
        if (len >= cap) len = cap - 1;
        memcpy(out, v, len);
        out[len] = 0;
        return;
    }
}

/* Reads the answer's head (and a refusal's body) from the pair. Bytes after a 101's head (the
 * stream's first messages) stay in the socket for the relay. */
static bool read_answer(int fd, answer *a)
{
    char buf[HEAD_MAX + 1];
    double deadline = srv_mono_ms() + ANSWER_TIMEOUT_MS;
    size_t head_len = 0;
    for (;;) {
        if (!wait_readable(fd, deadline)) return false;
        ssize_t k = recv(fd, buf, HEAD_MAX, MSG_PEEK);
        if (k <= 0) return false;
        buf[k] = 0;
        char *end = strstr(buf, "\r\n\r\n");
        if (end) {
            head_len = (size_t)(end - buf) + 4;
            break;
        }
        if ((size_t)k == HEAD_MAX) return false;
        /* wait for more than is there: poll says readable while anything is, so sleep a bit */
        struct timespec ts = {0, 1000000};
        nanosleep(&ts, NULL);
    }
    if (recv(fd, buf, head_len, 0) != (ssize_t)head_len) return false;
    buf[head_len] = 0;
    if (sscanf(buf, "HTTP/1.%*d %d", &a->status) != 1) return false;
    header_value(buf, "Sec-WebSocket-Accept", a->accept, sizeof a->accept);
    header_value(buf, "Sec-WebSocket-Protocol", a->protocol, sizeof a->protocol);
    header_value(buf, "Sec-WebSocket-Extensions", a->extensions, sizeof a->extensions);
    if (a->status == 101) return a->accept[0] != 0;
    /* a refusal: its short HTML body, as text */
    char len_s[32];
    header_value(buf, "Content-Length", len_s, sizeof len_s);
    size_t want = (size_t)strtoul(len_s, NULL, 10), got = 0;
    if (want > sizeof buf - 1) want = sizeof buf - 1;
    while (got < want && wait_readable(fd, deadline)) {
        ssize_t k = recv(fd, buf + got, want - got, 0);
        if (k <= 0) break;
        got += (size_t)k;
    }
    buf[got] = 0;
    size_t o = 0;
    bool tag = false;
    for (size_t i = 0; i < got && o + 1 < sizeof a->why; i++) {
        if (buf[i] == '<')
            tag = true;
        else if (buf[i] == '>')
            tag = false;
        else if (!tag && buf[i] != '\r' && buf[i] != '\n')
            a->why[o++] = buf[i];
    }
    a->why[o] = 0;
    /* lws's page repeats the status as a heading before the reason */
    char code[8];
    snprintf(code, sizeof code, "%d", a->status);
    if (strncmp(a->why, code, strlen(code)) == 0)
        memmove(a->why, a->why + strlen(code), strlen(a->why + strlen(code)) + 1);
    return true;
}

/* ---- the relay ---------------------------------------------------------------------------- */

/* Moves what one side has buffered to the other. False on a closed or failed socket. */
static bool flush(int to, const uint8_t *buf, size_t *pos, size_t *len)
{
    while (*pos < *len) {
        ssize_t k = send(to, buf + *pos, *len - *pos, MSG_NOSIGNAL | MSG_DONTWAIT);
        if (k < 0) return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR;
        *pos += (size_t)k;
    }
    *pos = *len = 0;
    return true;
}

static bool fill(int from, uint8_t *buf, size_t *len)
{
    ssize_t k = recv(from, buf, RELAY_BUFFER, MSG_DONTWAIT);
    if (k > 0) {
        *len = (size_t)k;
        return true;
    }
    return k < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR);
}

static void *relay_main(void *arg)
{
    relay *r = arg;
    srv_http *h = r->h;
    for (;;) {
        struct pollfd p[3] = {
            {.fd = r->client, .events = r->up_len ? 0 : POLLIN},
            {.fd = r->inner, .events = r->down_len ? 0 : POLLIN},
            {.fd = h->relay_wake, .events = POLLIN},
        };
        if (r->up_len) p[1].events |= POLLOUT;
        if (r->down_len) p[0].events |= POLLOUT;
        if (poll(p, 3, -1) < 0) {
            if (errno == EINTR) continue;
            break;
        }
        if (p[2].revents) break; /* the API stops */
        if ((p[0].revents & POLLIN) && !fill(r->client, r->up, &r->up_len)) break;
        if ((p[1].revents & POLLIN) && !fill(r->inner, r->down, &r->down_len)) break;
        if (!flush(r->inner, r->up, &r->up_pos, &r->up_len)) break;
        if (!flush(r->client, r->down, &r->down_pos, &r->down_len)) break;
        if ((p[0].revents | p[1].revents) & (POLLERR | POLLNVAL)) break;
        if ((p[0].revents & POLLHUP) && !(p[0].revents & POLLIN)) break;
        if ((p[1].revents & POLLHUP) && !(p[1].revents & POLLIN)) break;
    }
    close(r->inner);
    MHD_upgrade_action(r->urh, MHD_UPGRADE_ACTION_CLOSE);
    free(r);
    pthread_mutex_lock(&h->relay_mu);
    h->relays--;
    pthread_cond_broadcast(&h->relay_done);
    pthread_mutex_unlock(&h->relay_mu);
    return NULL;
}

/* MHD sent the 101: the client's socket is ours (through urh) until the relay closes it. */
static void on_upgraded(void *cls, struct MHD_Connection *conn, void *con_cls, const char *extra_in,
                        size_t extra_in_size, MHD_socket sock,
                        struct MHD_UpgradeResponseHandle *urh)
{
    (void)conn;
    srv_http *h = cls;
    request *rq = con_cls;
    relay *r = calloc(1, sizeof *r);
    if (!r) abort();
    r->h = h;
    r->inner = rq->stream_fd;
    rq->stream_fd = -1;
    r->client = sock;
    r->urh = urh;
    /* frames and acks go out at once: MHD may leave the socket corked after its 101, and Nagle
     * would hold the small messages back (over TLS sock is MHD's socket pair: these fail, and
     * MHD's own TLS socket is its business) */
    int off = 0, on = 1;
    setsockopt(sock, IPPROTO_TCP, TCP_CORK, &off, sizeof off);
    setsockopt(sock, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
    if (extra_in_size > sizeof r->up) extra_in_size = sizeof r->up; /* < one request's bytes */
    memcpy(r->up, extra_in, extra_in_size);
    r->up_len = extra_in_size;
    pthread_mutex_lock(&h->relay_mu);
    bool ok = !h->relays_stopping;
    pthread_t t;
    pthread_attr_t attr;
    pthread_attr_init(&attr);
    pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED);
    if (ok) ok = pthread_create(&t, &attr, relay_main, r) == 0;
    if (ok) h->relays++;
    pthread_attr_destroy(&attr);
    pthread_mutex_unlock(&h->relay_mu);
    if (!ok) {
        close(r->inner);
        MHD_upgrade_action(urh, MHD_UPGRADE_ACTION_CLOSE);
        free(r);
    }
}

/* ---- the route ---------------------------------------------------------------------------- */

static void client_ip(struct MHD_Connection *conn, char *out, size_t cap)
{
    out[0] = 0;
    const union MHD_ConnectionInfo *ci =
        MHD_get_connection_info(conn, MHD_CONNECTION_INFO_CLIENT_ADDRESS);
    if (!ci || !ci->client_addr) return;
    const struct sockaddr *sa = ci->client_addr;
    if (sa->sa_family == AF_INET)
        inet_ntop(AF_INET, &((const struct sockaddr_in *)sa)->sin_addr, out, (socklen_t)cap);
    else if (sa->sa_family == AF_INET6)
        inet_ntop(AF_INET6, &((const struct sockaddr_in6 *)sa)->sin6_addr, out, (socklen_t)cap);
}

enum MHD_Result srv_http_handle_stream(srv_http *h, struct MHD_Connection *conn, request *rq)
{
    const char *upgrade = MHD_lookup_connection_value(conn, MHD_HEADER_KIND, "Upgrade");
    if (!upgrade || strcasecmp(upgrade, "websocket") != 0)
        return srv_http_respond_error(
            h, conn, rq, 400, SRV_ERR_INVALID_FIELD,
            "/v1/stream is a WebSocket (protocol/stream.md): send 'Upgrade: websocket'.");
    if (!h->cfg.ws || MHD_is_feature_supported(MHD_FEATURE_UPGRADE) != MHD_YES)
        return srv_http_respond_error(h, conn, rq, 503, SRV_ERR_UNAVAILABLE,
                                      "This server has no stream.");
    head *b = malloc(sizeof *b);
    if (!b) abort();
    b->n = 0;
    b->overflow = false;
    head_printf(b, "GET /v1/stream?");
    MHD_get_connection_values(conn, MHD_GET_ARGUMENT_KIND, add_argument, b);
    if (b->s[b->n - 1] == '?') b->n--;
    head_printf(b, " HTTP/1.1\r\n");
    MHD_get_connection_values(conn, MHD_HEADER_KIND, add_header, b);
    head_printf(b, "\r\n");
    if (b->overflow) {
        free(b);
        return srv_http_respond_error(h, conn, rq, 431, SRV_ERR_INVALID_FIELD,
                                      "The upgrade request's head is too large.");
    }
    int pair[2];
    if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, pair) != 0) {
        free(b);
        return srv_http_respond_error(h, conn, rq, 503, SRV_ERR_UNAVAILABLE,
                                      "Cannot open the stream now.");
    }
    /* small pair buffers: the stream's flow control (it writes while the socket takes bytes)
     * should feel the client's TCP window, not a deep queue in between */
    int buf = RELAY_BUFFER;
    for (int i = 0; i < 2; i++) {
        setsockopt(pair[i], SOL_SOCKET, SO_SNDBUF, &buf, sizeof buf);
        setsockopt(pair[i], SOL_SOCKET, SO_RCVBUF, &buf, sizeof buf);
    }
    char ip[64];
    client_ip(conn, ip, sizeof ip);
    answer a = {0};
    bool ok = srv_ws_adopt(h->cfg.ws, pair[1], ip);
    if (!ok) close(pair[1]);
    ok = ok && send(pair[0], b->s, b->n, MSG_NOSIGNAL) == (ssize_t)b->n;
    free(b);
    ok = ok && read_answer(pair[0], &a);
    if (!ok || a.status != 101) {
        close(pair[0]);
        if (!ok)
            return srv_http_respond_error(h, conn, rq, 503, SRV_ERR_UNAVAILABLE,
                                          "The stream did not answer; try again.");
        const char *code = a.status == 401   ? SRV_ERR_UNAUTHORIZED
                           : a.status == 403 ? SRV_ERR_FORBIDDEN
                           : a.status == 404 ? SRV_ERR_NOT_FOUND
                           : a.status >= 500 ? SRV_ERR_UNAVAILABLE
                                             : SRV_ERR_INVALID_FIELD;
        int status = a.status >= 400 && a.status < 600 ? a.status : 400;
        return srv_http_respond_error(h, conn, rq, status, code, "The stream refused: %s.",
                                      a.why[0] ? a.why : "no reason given");
    }
    struct MHD_Response *resp = MHD_create_response_for_upgrade(on_upgraded, h);
    if (!resp) {
        close(pair[0]);
        return MHD_NO;
    }
    MHD_add_response_header(resp, MHD_HTTP_HEADER_UPGRADE, "websocket");
    MHD_add_response_header(resp, "Sec-WebSocket-Accept", a.accept);
    if (a.protocol[0]) MHD_add_response_header(resp, "Sec-WebSocket-Protocol", a.protocol);
    if (a.extensions[0]) MHD_add_response_header(resp, "Sec-WebSocket-Extensions", a.extensions);
    rq->stream_fd = pair[0];
    enum MHD_Result r = MHD_queue_response(conn, MHD_HTTP_SWITCHING_PROTOCOLS, resp);
    MHD_destroy_response(resp);
    srv_http_count_status(h, rq, 101);
    rq->responded = true;
    return r;
}

bool srv_http_stream_init(srv_http *h)
{
    pthread_mutex_init(&h->relay_mu, NULL);
    pthread_cond_init(&h->relay_done, NULL);
    h->relay_wake = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
    return h->relay_wake >= 0;
}

void srv_http_stream_stop(srv_http *h)
{
    if (h->relay_wake < 0) return;
    pthread_mutex_lock(&h->relay_mu);
    h->relays_stopping = true;
    uint64_t one = 1;
    if (write(h->relay_wake, &one, sizeof one) < 0) srv_warn("http", "cannot wake the relays");
    while (h->relays > 0)
        pthread_cond_wait(&h->relay_done, &h->relay_mu);
    pthread_mutex_unlock(&h->relay_mu);
}

void srv_http_stream_destroy(srv_http *h)
{
    if (h->relay_wake < 0) return;
    close(h->relay_wake);
    h->relay_wake = -1;
    pthread_cond_destroy(&h->relay_done);
    pthread_mutex_destroy(&h->relay_mu);
}
