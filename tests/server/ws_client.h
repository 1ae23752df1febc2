/* ws_client.h: a minimal blocking WebSocket client (RFC 6455) over plain sockets, for tests
 * and the load benchmark. One connection per struct; not thread-safe. */
#ifndef PC_WS_CLIENT_H
#define PC_WS_CLIENT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef struct pc_ws {
    int fd;
    uint8_t *buf; /* received, not yet parsed */
    size_t len, cap;
    uint8_t *msg; /* the message being reassembled */
    size_t msg_len, msg_cap;
    int msg_opcode;
    bool msg_done;   /* msg holds a message already returned */
    int http_status; /* of the handshake response */
    int close_code;  /* from a received close frame */
    char close_reason[128];
} pc_ws;

/* Connects to host:port and upgrades path (with query). extra_headers holds whole header
 * lines ("Origin: http://x\r\n"), may be NULL. Returns 0 on success (101); -1 otherwise, with
 * ws->http_status the response status (0 when there was none). */
int pc_ws_connect(pc_ws *ws, const char *host, unsigned port, const char *path,
                  const char *extra_headers, int timeout_ms);
/* Sends one frame (masked, as clients must). Returns 0 or -1. */
int pc_ws_send_frame(pc_ws *ws, int opcode, const void *data, size_t len, bool fin);
int pc_ws_send_text(pc_ws *ws, const char *text);
/* Receives one whole message: returns its opcode (1 text, 2 binary, 8 close) with the payload
 * in *data (valid until the next call), 0 on timeout, -1 on error or end of stream. Pings are
 * answered. timeout_ms 0 reads what has already arrived, without waiting. */
int pc_ws_recv(pc_ws *ws, int timeout_ms, uint8_t **data, size_t *len);
void pc_ws_close(pc_ws *ws);

#endif
