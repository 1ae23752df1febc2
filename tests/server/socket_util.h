/* socket_util.h: what the test HTTP and WebSocket clients share: a monotonic clock, a TCP
 * connect with a timeout, and a blocking send of a whole buffer. */
#ifndef PC_SOCKET_UTIL_H
#define PC_SOCKET_UTIL_H

#include <stddef.h>

/* Milliseconds on the monotonic clock. */
double pc_now_ms(void);
/* TCP connection to host:port (TCP_NODELAY, send timeout); -1 on failure. */
int pc_dial(const char *host, unsigned port, int timeout_ms);
/* Sends all len bytes (retrying on EINTR, no SIGPIPE); -1 on failure. */
int pc_send_all(int fd, const void *data, size_t len);

#endif
