/* http_admission.h: which TCP connections the HTTP server takes (issue 30, abuse): at most
 * per_ip open connections from one client address (plain requests and the relayed /v1/stream
 * together), counted here so that /v1/stats can say how many were refused and how many are
 * open. libmicrohttpd's accept policy asks before a connection is taken; its connection
 * notifications count them open and closed. Together with the idle timeout (--idle-timeout) this
 * is what holds a slow-loris client: its connections stay within its own address's share, and a
 * connection that sends nothing for the timeout is closed. */
#ifndef SRV_HTTP_ADMISSION_H
#define SRV_HTTP_ADMISSION_H

#include <microhttpd.h>
#include <pthread.h>
#include <stdbool.h>
#include <stdint.h>
#include <sys/socket.h>

typedef struct srv_admission_slot {
    uint8_t addr[16]; /* IPv4 in the first 4 bytes, or IPv6 */
    uint8_t family;   /* AF_INET, AF_INET6; 0: free */
    unsigned open;
} srv_admission_slot;

typedef struct srv_admission {
    pthread_mutex_t mu;
    srv_admission_slot *slots; /* one per connection that can be open at once */
    unsigned slot_count, per_ip;
    unsigned open;     /* connections open now */
    uint64_t refused;  /* connections refused for their address's limit */
} srv_admission;

/* capacity: the most connections open at once (libmicrohttpd's own limit). */
void srv_admission_init(srv_admission *a, unsigned capacity, unsigned per_ip);
void srv_admission_destroy(srv_admission *a);
/* MHD_OPTION_ACCEPT_POLICY_CALLBACK (cls: the srv_admission). */
enum MHD_Result srv_admission_accept(void *cls, const struct sockaddr *addr, socklen_t addrlen);
/* MHD_OPTION_NOTIFY_CONNECTION (cls: the srv_admission). */
void srv_admission_notify(void *cls, struct MHD_Connection *connection, void **socket_context,
                          enum MHD_ConnectionNotificationCode code);
/* Open and refused, read together. */
void srv_admission_counts(srv_admission *a, unsigned *open, uint64_t *refused);

#endif
