/* ws_client.c: a minimal WebSocket client for tests and benchmarks. */
#include "ws_client.h"
#include "socket_util.h"

#include <errno.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

static int fill(pc_ws *ws, double deadline)
{
    if (ws->len == ws->cap) {
        ws->cap = ws->cap ? ws->cap * 2 : 65536;
        ws->buf = realloc(ws->buf, ws->cap);
        if (!ws->buf) abort();
    }
    for (;;) {
        double left = deadline - pc_now_ms();
        int wait = left > 0 ? (int)(left + 0.999) : 0; /* past the deadline: a look, no wait */
        struct pollfd p = {.fd = ws->fd, .events = POLLIN};
        int r = poll(&p, 1, wait);
        if (r < 0 && errno == EINTR) continue;
        if (r == 0) return 0;
        if (r < 0) return -1;
        ssize_t n = recv(ws->fd, ws->buf + ws->len, ws->cap - ws->len, 0);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return -1;
        ws->len += (size_t)n;
        return 1;
    }
}

int pc_ws_connect(pc_ws *ws, const char *host, unsigned port, const char *path,
                  const char *extra_headers, int timeout_ms)
{
    memset(ws, 0, sizeof *ws);
    ws->fd = pc_dial(host, port, timeout_ms);
    if (ws->fd < 0) return -1;
    char req[4096];
    int n = snprintf(
        req, sizeof req,
        "GET %s HTTP/1.1\r\nHost: %s:%u\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
        "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n%s\r\n",
        path, host, port, extra_headers ? extra_headers : "");
    if (n <= 0 || (size_t)n >= sizeof req || pc_send_all(ws->fd, req, (size_t)n) != 0) return -1;
    double deadline = pc_now_ms() + timeout_ms;
    for (;;) {
        uint8_t *end = ws->len >= 4 ? memmem(ws->buf, ws->len, "\r\n\r\n", 4) : NULL;
        if (end) {
            int status = 0;
            if (sscanf((const char *)ws->buf, "HTTP/1.%*d %d", &status) == 1)
                ws->http_status = status;
            size_t used = (size_t)(end + 4 - ws->buf);
            memmove(ws->buf, ws->buf + used, ws->len - used);
            ws->len -= used;
            return status == 101 ? 0 : -1;
        }
        if (fill(ws, deadline) <= 0) return -1;
    }
}

int pc_ws_send_frame(pc_ws *ws, int opcode, const void *data, size_t len, bool fin)
{
    uint8_t hdr[14];
    size_t h = 0;
    hdr[h++] = (uint8_t)((fin ? 0x80 : 0) | (opcode & 0x0f));
    if (len < 126) {
        hdr[h++] = (uint8_t)(0x80 | len);
    } else if (len < 65536) {
        hdr[h++] = 0x80 | 126;
        hdr[h++] = (uint8_t)(len >> 8);
        hdr[h++] = (uint8_t)len;
    } else {
        hdr[h++] = 0x80 | 127;
        for (int i = 7; i >= 0; i--)
            hdr[h++] = (uint8_t)((uint64_t)len >> (8 * i));
    }
    uint8_t mask[4] = {(uint8_t)rand(), (uint8_t)rand(), (uint8_t)rand(), (uint8_t)rand()};
    memcpy(hdr + h, mask, 4);
    h += 4;
    uint8_t *frame = malloc(h + len);
    if (!frame) abort();
    memcpy(frame, hdr, h);
    for (size_t i = 0; i < len; i++)
        frame[h + i] = ((const uint8_t *)data)[i] ^ mask[i & 3];
    int r = pc_send_all(ws->fd, frame, h + len);
    free(frame);
    return r;
}

int pc_ws_send_text(pc_ws *ws, const char *text)
{
    return pc_ws_send_frame(ws, 1, text, strlen(text), true);
}

/* Parses one frame from ws->buf; 1 when one was consumed, 0 when more bytes are needed. */
static int parse_frame(pc_ws *ws, int *opcode, bool *fin, uint8_t **payload, size_t *plen,
                       size_t *used)
{
    if (ws->len < 2) return 0;
    const uint8_t *b = ws->buf;
    *fin = b[0] & 0x80;
    *opcode = b[0] & 0x0f;
    bool masked = b[1] & 0x80;
    uint64_t len = b[1] & 0x7f;
    size_t h = 2;
    if (len == 126) {
        if (ws->len < 4) return 0;
        len = ((uint64_t)b[2] << 8) | b[3];
        h = 4;
    } else if (len == 127) {
        if (ws->len < 10) return 0;
        len = 0;
        for (int i = 0; i < 8; i++)
            len = (len << 8) | b[2 + i];
        h = 10;
    }
    if (masked) h += 4;
    if (ws->len < h + len) return 0;
    *payload = ws->buf + h;
    *plen = (size_t)len;
    *used = h + (size_t)len;
    return 1;
}

int pc_ws_recv(pc_ws *ws, int timeout_ms, uint8_t **data, size_t *len)
{
    double deadline = pc_now_ms() + timeout_ms;
    if (ws->msg_done) { /* the previous message was returned: start a new one */
        ws->msg_len = 0;
        ws->msg_done = false;
    }
    for (;;) {
        int opcode;
        bool fin;
        uint8_t *payload;
        size_t plen, used;
        while (parse_frame(ws, &opcode, &fin, &payload, &plen, &used)) {
            if (opcode == 9) { /* ping */
                pc_ws_send_frame(ws, 10, payload, plen, true);
            } else if (opcode == 8) {
                ws->close_code = plen >= 2 ? (payload[0] << 8) | payload[1] : 1005;
                size_t rl = plen > 2 ? plen - 2 : 0;
                if (rl >= sizeof ws->close_reason) rl = sizeof ws->close_reason - 1;
                memcpy(ws->close_reason, payload + 2, rl);
                ws->close_reason[rl] = 0;
                memmove(ws->buf, ws->buf + used, ws->len - used);
                ws->len -= used;
                *data = NULL;
                *len = 0;
                return 8;
            } else if (opcode != 10) {
                if (opcode != 0) ws->msg_opcode = opcode;
                if (ws->msg_len + plen > ws->msg_cap) {
                    ws->msg_cap = (ws->msg_len + plen) * 2;
                    ws->msg = realloc(ws->msg, ws->msg_cap);
                    if (!ws->msg) abort();
                }
                memcpy(ws->msg + ws->msg_len, payload, plen);
                ws->msg_len += plen;
            }
            memmove(ws->buf, ws->buf + used, ws->len - used);
            ws->len -= used;
            if (fin && (opcode == 0 || opcode == 1 || opcode == 2)) {
                ws->msg_done = true;
                *data = ws->msg;
                *len = ws->msg_len;
                return ws->msg_opcode;
            }
        }
        int r = fill(ws, deadline);
        if (r == 0) return 0;
        if (r < 0) return -1;
    }
}

void pc_ws_close(pc_ws *ws)
{
    if (ws->fd >= 0) {
        uint8_t code[2] = {0x03, 0xe8}; /* 1000 */
        pc_ws_send_frame(ws, 8, code, 2, true);
        close(ws->fd);
    }
    ws->fd = -1;
    free(ws->buf);
    free(ws->msg);
    ws->buf = ws->msg = NULL;
    ws->len = ws->cap = ws->msg_len = ws->msg_cap = 0;
}
