/* mailbox.h: the render thread's command queue.
 *
 * Network threads (HTTP, WebSocket) post commands (commands.h); the render thread takes them in
 * batches between frames, applies them and completes each one with a reply. Every command gets
 * an input ticket in posting order, so a frame can say which inputs it reflects. A caller either
 * waits for the reply (srv_mailbox_call) or posts and forgets (srv_mailbox_post). Once closed,
 * the mailbox refuses new commands with a 503 and the render thread answers what is still queued.
 */
#ifndef SRV_MAILBOX_H
#define SRV_MAILBOX_H

#include <pthread.h>
#include <stdbool.h>
#include <stdint.h>

#include "server/api/commands.h"

typedef struct srv_mailbox {
    pthread_mutex_t mu;
    pthread_cond_t cv;
    srv_cmd *head, *tail;
    unsigned queued;
    bool closed;
    uint64_t next_ticket;
} srv_mailbox;

void srv_mailbox_init(srv_mailbox *m);
/* Answers what is still queued with 503 and frees the lock (idempotent after close). */
void srv_mailbox_dispose(srv_mailbox *m);
/* Refuses later commands and wakes the render thread. */
void srv_mailbox_close(srv_mailbox *m);
/* Posts c and waits up to timeout_ms for its reply (c->reply). On timeout the reply is a 503 and
 * false is returned (the command may still be applied later). c stays the caller's. */
bool srv_mailbox_call(srv_mailbox *m, srv_cmd *c, unsigned timeout_ms);
/* Posts c without waiting (takes the caller's reference). Returns its input ticket, or 0 when
 * the queue is full or closed (then c is dropped). */
uint64_t srv_mailbox_post(srv_mailbox *m, srv_cmd *c);
/* Render thread: takes every queued command (a list linked by next, oldest first); *closed
 * tells whether the mailbox was closed. */
srv_cmd *srv_mailbox_take(srv_mailbox *m, bool *closed);
/* Render thread: sleeps until a command arrives, the mailbox closes, or the monotonic time
 * wake_ms (INFINITY: no deadline). */
void srv_mailbox_wait(srv_mailbox *m, double wake_ms);
/* Wakes a render thread sleeping in srv_mailbox_wait. */
void srv_mailbox_wake(srv_mailbox *m);

/* A new command with one reference (the caller's). */
srv_cmd *srv_cmd_new(srv_cmd_kind kind);
void srv_cmd_unref(srv_cmd *c);
/* Render thread: hands the reply (body malloc'd or NULL, taken) to the waiting thread. */
void srv_cmd_complete(srv_cmd *c, int status, char *body);
void srv_cmd_complete_json(srv_cmd *c, int status, cJSON *j); /* j is deleted */
void srv_cmd_complete_error(srv_cmd *c, const srv_api_error *e);
void srv_cmd_fail(srv_cmd *c, int status, const char *code, const char *message);

#endif
