/* probecast serve under abusive clients (issue 30, item 5): each has a limit, reported in
 * /v1/stats, and the daemon goes on serving everyone else.
 * - slow-loris HTTP: connections from one address that send their headers a few bytes at a time
 *   hold at most that address's share (http.connections_per_ip; more are refused and counted in
 *   http.connections_refused); another address is still answered; a connection that goes quiet
 *   is closed after the idle timeout (--idle-timeout, http.idle_timeout_s), and the address's
 *   share comes back;
 * - a /v1/stream handshake that never completes is closed after the idle timeout too;
 * - a viewer that never reads: the daemon holds one frame for it and skips to the newest when
 *   its socket takes more (stream.frames_skipped), what waits for it is bounded by the socket
 *   buffers, the daemon's memory stays flat, and another viewer's frames keep coming;
 * - a flood of camera messages: below the rate limit they are taken (those the render queue has
 *   no room for are dropped and counted in stream.inputs_dropped), above it (1000 a second) the
 *   connection is closed with 1008 and counted in stream.connections_closed_for_abuse.
 * Clients of other addresses bind 127.0.0.2 and 127.0.0.3 (loopback). Oversized messages and
 * the stream's per-address limit are in test_gpu_serve_errors. */
#include <arpa/inet.h>
#include <errno.h>
#include <math.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "serve_util.h"
#include "test_util.h"

static pc_daemon d = {.token = "s3cret"};

#define IDLE_S 2
#define PER_IP (16 + 2) /* the HTTP share (16) and --max-viewers-per-ip 2 */

/* A TCP connection to the daemon from source address src (rcvbuf > 0: the receive buffer's
 * size, set before connecting so the window stays small); -1 on failure. */
static int dial_from(const char *src, unsigned port, int rcvbuf)
{
    int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) return -1;
    if (rcvbuf > 0) setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
    struct timeval tv = {5, 0};
    setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
    struct sockaddr_in a = {.sin_family = AF_INET};
    inet_pton(AF_INET, src, &a.sin_addr);
    struct sockaddr_in to = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
    inet_pton(AF_INET, "127.0.0.1", &to.sin_addr);
    if (bind(fd, (struct sockaddr *)&a, sizeof a) != 0 ||
        connect(fd, (struct sockaddr *)&to, sizeof to) != 0) {
        close(fd);
        return -1;
    }
    return fd;
}

/* Whether the daemon closed fd within timeout_ms (end of stream or reset; bytes it sends are
 * read and dropped). */
static bool closed_within(int fd, int timeout_ms)
{
    double deadline = pc_now_ms() + timeout_ms;
    for (;;) {
        double left = deadline - pc_now_ms();
        if (left <= 0) return false;
        struct timeval tv = {(time_t)(left / 1000), (suseconds_t)((long)left % 1000) * 1000};
        setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
        char buf[4096];
        ssize_t n = recv(fd, buf, sizeof buf, 0);
        if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR))
            return true;
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return false;
    }
}

/* Still open: nothing to read and no end of stream. */
static bool still_open(int fd)
{
    char c;
    ssize_t n = recv(fd, &c, 1, MSG_DONTWAIT | MSG_PEEK);
    return n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK);
}

static cJSON *stats(void)
{
    return pc_api_get_json(&d, "/v1/stats");
}

static double stat(const cJSON *s, const char *group, const char *name)
{
    return pc_json_number(cJSON_GetObjectItemCaseSensitive(s, group), name);
}

static void test_slow_loris(void)
{
    int held[PER_IP];
    int opened = 0;
    const char *start = "GET /v1/health HTTP/1.1\r\nHost: 127.0.0.1\r\n";
    for (int i = 0; i < PER_IP; i++) {
        held[i] = dial_from("127.0.0.2", d.http_port, 0);
        if (held[i] >= 0 && pc_send_all(held[i], start, strlen(start)) == 0) opened++;
    }
    CHECKF(opened == PER_IP, "%d of %d slow connections opened", opened, PER_IP);
    pc_sleep_ms(200);
    /* one more from the same address is refused: closed without an answer */
    int extra = dial_from("127.0.0.2", d.http_port, 0);
    CHECK(extra >= 0 && closed_within(extra, 3000));
    if (extra >= 0) close(extra);
    /* another address is still answered (how fast is printed; tests do not time) */
    double t0 = pc_now_ms();
    pc_http_response r;
    int status = pc_http("127.0.0.1", d.http_port, "GET", "/v1/health", NULL, NULL, 0, &r, 5000);
    double ms = pc_now_ms() - t0;
    pc_http_response_free(&r);
    CHECKF(status == 200, "health beside a slow-loris: %d after %.0f ms", status, ms);
    cJSON *s = stats();
    CHECKF(stat(s, "http", "connections_refused") >= 1 &&
               stat(s, "http", "connections_per_ip") == PER_IP &&
               stat(s, "http", "idle_timeout_s") == IDLE_S &&
               stat(s, "http", "connections_open") >= PER_IP,
           "http stats: refused %g, per ip %g, idle timeout %g, open %g",
           stat(s, "http", "connections_refused"), stat(s, "http", "connections_per_ip"),
           stat(s, "http", "idle_timeout_s"), stat(s, "http", "connections_open"));
    cJSON_Delete(s);
    /* a header line every half second keeps them (the timeout is for silence) ... */
    for (int k = 0; k < 2 * (IDLE_S + 1); k++) {
        pc_sleep_ms(500);
        for (int i = 0; i < PER_IP; i++)
            if (held[i] >= 0) pc_send_all(held[i], "X-Slow: 1\r\n", 11);
    }
    int open_after = 0;
    for (int i = 0; i < PER_IP; i++) open_after += held[i] >= 0 && still_open(held[i]);
    CHECKF(open_after == PER_IP, "%d of %d trickling connections still open", open_after, PER_IP);
    /* ... and silence closes them */
    int closed = 0;
    double t1 = pc_now_ms();
    for (int i = 0; i < PER_IP; i++)
        closed += held[i] >= 0 && closed_within(held[i], (IDLE_S + 3) * 1000);
    printf("slow-loris: %d connections from one address held, the next refused, health answered "
           "in %.0f ms beside them; %d closed %.1f s after going quiet (idle timeout %d s)\n",
           PER_IP, ms, closed, (pc_now_ms() - t1) / 1000, IDLE_S);
    CHECKF(closed == PER_IP, "%d of %d quiet connections closed", closed, PER_IP);
    for (int i = 0; i < PER_IP; i++)
        if (held[i] >= 0) close(held[i]);
    /* the address's share comes back */
    pc_sleep_ms(200);
    int again = dial_from("127.0.0.2", d.http_port, 0);
    const char *full = "GET /v1/health HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n";
    char buf[64] = "";
    if (again >= 0 && pc_send_all(again, full, strlen(full)) == 0) {
        struct timeval tv = {5, 0};
        setsockopt(again, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
        ssize_t n = recv(again, buf, sizeof buf - 1, 0);
        buf[n > 0 ? n : 0] = 0;
    }
    CHECKF(strstr(buf, "HTTP/1.1 200") == buf, "after the slow ones: '%.12s'", buf);
    if (again >= 0) close(again);
}

static void test_slow_handshake(void)
{
    int fd = dial_from("127.0.0.3", d.ws_port, 0);
    const char *part = "GET /v1/stream?token=s3cret HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: web";
    CHECK(fd >= 0 && pc_send_all(fd, part, strlen(part)) == 0);
    double t0 = pc_now_ms();
    CHECK(fd >= 0 && closed_within(fd, (IDLE_S + 3) * 1000));
    printf("an unfinished stream handshake closed after %.1f s\n", (pc_now_ms() - t0) / 1000);
    if (fd >= 0) close(fd);
}

static void test_viewer_never_reads(void)
{
    /* the stuck viewer: a tiny receive window, handshake sent, nothing ever read */
    int stuck = dial_from("127.0.0.3", d.ws_port, 2048);
    const char *hs = "GET /v1/stream?token=s3cret HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: "
                     "websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: "
                     "dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n";
    CHECK(stuck >= 0 && pc_send_all(stuck, hs, strlen(hs)) == 0);
    pc_ws ws;
    CHECK(pc_stream_open(&d, &ws));
    cJSON *s = stats();
    double skipped0 = stat(s, "stream", "frames_skipped");
    cJSON_Delete(s);
    /* the stuck viewer's buffers fill within the first seconds; then memory must stay flat. The
     * first reading is taken once the reading viewer has had 4 frames and 2 s have passed (on a
     * loaded machine the daemon's first frames, with their one-time allocations, came after 2 s:
     * 9 frames in 6 s, RSS +41 MiB), the second 4 s after it (20 s at most in all) */
    int frames = 0;
    unsigned long long rss1 = 0;
    double t0 = pc_now_ms(), t1 = 0;
    while (pc_now_ms() - t0 < 20000 && !(rss1 && pc_now_ms() - t1 >= 4000)) {
        /* the camera moves, so there are always newer frames than the stuck viewer took */
        char cam[160];
        snprintf(cam, sizeof cam,
                 "{\"type\":\"camera\",\"seq\":%d,\"position\":[%.3f,1,3],\"target\":[0,0.5,0]}",
                 frames + 1, 0.2 * sin((pc_now_ms() - t0) / 500.0));
        pc_ws_send_text(&ws, cam);
        pc_frame f;
        if (pc_stream_next(&ws, 2000, true, &f)) {
            frames++;
            pc_frame_free(&f);
        }
        if (!rss1 && frames >= 4 && pc_now_ms() - t0 > 2000) {
            rss1 = pc_daemon_memory_kib(&d, "VmRSS");
            t1 = pc_now_ms();
        }
    }
    unsigned long long rss2 = pc_daemon_memory_kib(&d, "VmRSS");
    pc_ws_close(&ws);
    long long grew = (long long)rss2 - (long long)rss1;
    CHECKF(frames >= 4, "the reading viewer got %d frames beside a stuck one", frames);
    CHECKF(rss1 > 0 && grew < 16 * 1024, "the daemon's RSS grew by %lld KiB in 4 s", grew);
    /* the stuck viewer reads again: it gets the newest frame, the ones in between skipped */
    double skipped1 = skipped0;
    size_t drained = 0;
    if (stuck >= 0) {
        double deadline = pc_now_ms() + 1500; /* read what waited, and what comes after */
        while (pc_now_ms() < deadline) {
            char buf[65536];
            ssize_t k;
            while ((k = recv(stuck, buf, sizeof buf, MSG_DONTWAIT)) > 0) drained += (size_t)k;
            pc_sleep_ms(100);
            s = stats();
            skipped1 = stat(s, "stream", "frames_skipped");
            cJSON_Delete(s);
        }
        close(stuck);
    }
    printf("a viewer that never reads: the other viewer got %d frames, the daemon's RSS "
           "%+lld KiB over the last 4 s, %g frames skipped for the stuck one (%zu KiB waiting "
           "for it)\n",
           frames, grew, skipped1 - skipped0, drained >> 10);
    /* what waits for it is bounded by the sockets' buffers, the relay's and one frame (the
     * sender holds only the frame it is writing and skips to the newest when the socket takes
     * more): on lavapipe about 1 MiB of kernel buffers absorb the 6 s here, so the skipping
     * itself shows only in longer runs (frames_skipped, printed) */
    CHECKF(drained < ((size_t)8 << 20), "%zu KiB waited for the stuck viewer", drained >> 10);
}

static int send_cameras(pc_ws *ws, int n)
{
    int sent = 0;
    for (int i = 0; i < n; i++) {
        char msg[160];
        snprintf(msg, sizeof msg,
                 "{\"type\":\"camera\",\"seq\":%d,\"position\":[%g,1,3],\"target\":[0,0.5,0]}",
                 i + 1, 0.001 * i);
        if (pc_ws_send_text(ws, msg) != 0) break;
        sent++;
    }
    return sent;
}

static void test_camera_flood(void)
{
    cJSON *s = stats();
    double received0 = stat(s, "stream", "messages_received");
    double abuse0 = stat(s, "stream", "connections_closed_for_abuse");
    cJSON_Delete(s);
    /* 600 in a burst: under the limit of 1000 a second, all taken, the viewer stays */
    pc_ws ws;
    uint32_t view;
    CHECK(pc_stream_open_v2(&d, &ws, &view));
    int sent = send_cameras(&ws, 600);
    pc_frame f;
    bool frame = pc_stream_next(&ws, 10000, true, &f);
    if (frame) pc_frame_free(&f);
    CHECKF(sent == 600 && frame && ws.close_code == 0, "600 cameras: sent %d, frame %d, close %d",
           sent, frame, ws.close_code);
    double t0 = pc_now_ms();
    pc_http_response r;
    int status = pc_http("127.0.0.1", d.http_port, "GET", "/v1/health", NULL, NULL, 0, &r, 5000);
    pc_http_response_free(&r);
    CHECKF(status == 200, "health after a flood: %d after %.0f ms", status, pc_now_ms() - t0);
    s = stats();
    double received = stat(s, "stream", "messages_received") - received0;
    double dropped = stat(s, "stream", "inputs_dropped");
    cJSON_Delete(s);
    CHECKF(received >= 600 && dropped >= 0, "messages received %g, inputs dropped %g", received,
           dropped);
    pc_ws_close(&ws);
    /* 3000 in a burst: past the limit, closed with 1008 */
    CHECK(pc_stream_open_v2(&d, &ws, &view));
    send_cameras(&ws, 3000);
    int op = 0;
    double deadline = pc_now_ms() + 15000;
    while (pc_now_ms() < deadline) {
        uint8_t *m;
        size_t l;
        op = pc_ws_recv(&ws, 5000, &m, &l);
        if (op == 8 || op < 0) break;
    }
    /* the close frame, or (when the daemon closed while this client still sent) a reset that
     * came first; the stats below say why it closed */
    CHECKF((op == 8 && ws.close_code == 1008) || op < 0, "3000 cameras: opcode %d close %d", op,
           ws.close_code);
    pc_ws_close(&ws);
    s = stats();
    double abuse = stat(s, "stream", "connections_closed_for_abuse") - abuse0;
    cJSON_Delete(s);
    printf("camera flood: 600 taken (%g dropped by the full render queue so far), 3000 closed "
           "(%s)\n",
           dropped, op == 8 ? ws.close_reason : "reset before the close frame was read");
    CHECKF(abuse >= 1, "connections_closed_for_abuse grew by %g", abuse);
}

int main(void)
{
    char idle[8];
    snprintf(idle, sizeof idle, "%d", IDLE_S);
    /* large frames (JPEG quality 100) fill the stuck viewer's kernel buffers sooner */
    const char *args[] = {"--no-animate",         "--width",  "256",          "--height",
                          "192",                  "--probes", "2,2,2",        "--rays",
                          "16",                   "--token",  "s3cret",       "--scene",
                          "builtin:cornell",      "--idle-timeout", idle,     "--max-viewers-per-ip",
                          "2",                    "--quality-interactive", "100", "--quality-still",
                          "100",                  NULL};
    if (!pc_daemon_start(&d, args)) {
        CHECK(!"daemon started");
        return test_finish();
    }
    test_slow_loris();
    test_slow_handshake();
    test_viewer_never_reads();
    test_camera_flood();
    CHECK(pc_daemon_alive(&d));
    CHECK(pc_daemon_stop(&d) == 0);
    return test_finish();
}
