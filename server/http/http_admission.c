/* http_admission.c: connections per client address (http_admission.h). The table has a slot
 * per connection that can be open, so it never fills: an address takes a slot while it has an
 * open connection. Both callbacks run on libmicrohttpd's threads; a mutex guards the table. */
#include "server/http/http_admission.h"

#include <netinet/in.h>
#include <stdlib.h>
#include <string.h>

void srv_admission_init(srv_admission *a, unsigned capacity, unsigned per_ip)
{
    memset(a, 0, sizeof *a);
    pthread_mutex_init(&a->mu, NULL);
    a->slot_count = capacity ? capacity : 1;
    a->per_ip = per_ip ? per_ip : 1;
    a->slots = calloc(a->slot_count, sizeof *a->slots);
    if (!a->slots) abort();
}

void srv_admission_destroy(srv_admission *a)
{
    if (!a->slots) return;
    free(a->slots);
    a->slots = NULL;
    pthread_mutex_destroy(&a->mu);
}

/* The address's key: family and bytes; false for other families (not limited). */
static bool key_of(const struct sockaddr *sa, uint8_t *family, uint8_t addr[16])
{
    memset(addr, 0, 16);
    if (!sa) return false;
    if (sa->sa_family == AF_INET) {
        memcpy(addr, &((const struct sockaddr_in *)sa)->sin_addr, 4);
        *family = AF_INET;
        return true;
    }
    if (sa->sa_family == AF_INET6) {
        memcpy(addr, &((const struct sockaddr_in6 *)sa)->sin6_addr, 16);
        *family = AF_INET6;
        return true;
    }
    return false;
}

/* The slot of the address, or (create) a free one for it; NULL when none. Locked. */
static srv_admission_slot *find(srv_admission *a, uint8_t family, const uint8_t addr[16],
                                bool create)
{
    srv_admission_slot *free_slot = NULL;
    for (unsigned i = 0; i < a->slot_count; i++) {
        srv_admission_slot *s = &a->slots[i];
        if (s->family == family && memcmp(s->addr, addr, 16) == 0) return s;
        if (!s->family && !free_slot) free_slot = s;
    }
    if (!create || !free_slot) return NULL;
    free_slot->family = family;
    memcpy(free_slot->addr, addr, 16);
    free_slot->open = 0;
    return free_slot;
}

enum MHD_Result srv_admission_accept(void *cls, const struct sockaddr *addr, socklen_t addrlen)
{
    (void)addrlen;
    srv_admission *a = cls;
    uint8_t family, key[16];
    if (!key_of(addr, &family, key)) return MHD_YES;
    pthread_mutex_lock(&a->mu);
    srv_admission_slot *s = find(a, family, key, false);
    bool full = s && s->open >= a->per_ip;
    if (full) a->refused++;
    pthread_mutex_unlock(&a->mu);
    return full ? MHD_NO : MHD_YES;
}

void srv_admission_notify(void *cls, struct MHD_Connection *connection, void **socket_context,
                          enum MHD_ConnectionNotificationCode code)
{
    srv_admission *a = cls;
    pthread_mutex_lock(&a->mu);
    if (code == MHD_CONNECTION_NOTIFY_STARTED) {
        a->open++;
        const union MHD_ConnectionInfo *ci =
            MHD_get_connection_info(connection, MHD_CONNECTION_INFO_CLIENT_ADDRESS);
        uint8_t family, key[16];
        srv_admission_slot *s = NULL;
        if (ci && key_of(ci->client_addr, &family, key)) s = find(a, family, key, true);
        if (s) s->open++;
        *socket_context = s;
    } else if (code == MHD_CONNECTION_NOTIFY_CLOSED) {
        if (a->open) a->open--;
        srv_admission_slot *s = *socket_context;
        if (s && s->open && --s->open == 0) s->family = 0;
        *socket_context = NULL;
    }
    pthread_mutex_unlock(&a->mu);
}

void srv_admission_counts(srv_admission *a, unsigned *open, uint64_t *refused)
{
    pthread_mutex_lock(&a->mu);
    *open = a->open;
    *refused = a->refused;
    pthread_mutex_unlock(&a->mu);
}
