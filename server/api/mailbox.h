/* mailbox.h: the render thread's queue of mail.
 *
 * Network threads (HTTP, WebSocket) post mail; the render thread takes it in batches between
 * frames, acts on each piece and completes it with a reply. Every piece gets an input ticket in
 * posting order, so a frame can say which inputs it reflects. A caller either waits for the
 * reply (srv_mailbox_call) or posts and forgets (srv_mailbox_post). Once closed, the mailbox
 * refuses new mail with a 503 and the render thread answers what is still queued.
 *
 * The queue knows nothing of what is sent. An srv_mail lives inside its owner's struct (the
 * daemon's commands: commands.h) with the owner's destroy callback, which frees that struct and
 * what it holds when the last reference goes.
 */
#ifndef SRV_MAILBOX_H
#define SRV_MAILBOX_H

#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

/* The render thread's answer: an HTTP status and a JSON body (malloc'd, may be NULL). */
typedef struct srv_reply {
    int status;
    char *body;
} srv_reply;

typedef struct srv_mail srv_mail;
/* Frees the struct holding m and what it owns (m's own lock and reply are already gone). */
typedef void srv_mail_destroy_fn(srv_mail *m);

struct srv_mail {
    srv_mail_destroy_fn *destroy;
    uint64_t ticket; /* input order (see srv_mailbox_post) */
    srv_reply reply;
    atomic_int refs;
    bool done;
    bool abandoned; /* the caller stopped waiting */
    pthread_mutex_t mu;
    pthread_cond_t cv;
    srv_mail *next;
};

/* Makes m a piece of mail with one reference (the caller's) that calls destroy(m) when the
 * last reference goes. */
void srv_mail_init(srv_mail *m, srv_mail_destroy_fn *destroy);
void srv_mail_unref(srv_mail *m);
/* Render thread: hands the reply (body malloc'd or NULL, taken) to the waiting thread. */
void srv_mail_complete(srv_mail *m, int status, char *body);

typedef struct srv_mailbox {
    pthread_mutex_t mu;
    pthread_cond_t cv;
    srv_mail *head, *tail;
    unsigned queued;
    bool closed;
    uint64_t next_ticket;
} srv_mailbox;

void srv_mailbox_init(srv_mailbox *m);
/* Answers what is still queued with 503 and frees the lock (idempotent after close). */
void srv_mailbox_dispose(srv_mailbox *m);
/* Refuses later mail and wakes the render thread. */
void srv_mailbox_close(srv_mailbox *m);
/* Posts c and waits up to timeout_ms for its reply (c->reply). On timeout the reply is a 503 and
 * false is returned (the mail may still be acted on later). c stays the caller's. */
bool srv_mailbox_call(srv_mailbox *m, srv_mail *c, unsigned timeout_ms);
/* Posts c without waiting (takes the caller's reference). Returns its input ticket, or 0 when
 * the queue is full or closed (then c is dropped). */
uint64_t srv_mailbox_post(srv_mailbox *m, srv_mail *c);
/* Render thread: takes all queued mail (a list linked by next, oldest first); *closed tells
 * whether the mailbox was closed. */
srv_mail *srv_mailbox_take(srv_mailbox *m, bool *closed);
/* Render thread: sleeps until mail arrives, the mailbox closes, or the monotonic time wake_ms
 * (INFINITY: no deadline). */
void srv_mailbox_wait(srv_mailbox *m, double wake_ms);
/* Wakes a render thread sleeping in srv_mailbox_wait. */
void srv_mailbox_wake(srv_mailbox *m);

#endif
