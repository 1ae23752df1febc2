/* mailbox.c: the render thread's queue of mail (generic: it knows no payload). */
#include "server/api/mailbox.h"
#include "server/base/clock.h"

#include <math.h>
#include <stdlib.h>
#include <time.h>

#include "server/api/api_error.h"

#define QUEUE_MAX 4096 /* pieces waiting; viewers posting faster are refused */

void srv_mailbox_init(srv_mailbox *m)
{
    *m = (srv_mailbox){0};
    pthread_mutex_init(&m->mu, NULL);
    pthread_cond_init(&m->cv, NULL);
}

void srv_mailbox_close(srv_mailbox *m)
{
    pthread_mutex_lock(&m->mu);
    m->closed = true;
    pthread_cond_broadcast(&m->cv);
    pthread_mutex_unlock(&m->mu);
}

/* The 503 of a closed mailbox. */
static void refuse(srv_mail *c)
{
    srv_mail_complete(c, 503,
                      srv_json_error_body(SRV_ERR_UNAVAILABLE, "The server is shutting down."));
}

void srv_mailbox_dispose(srv_mailbox *m)
{
    srv_mailbox_close(m);
    bool closed;
    srv_mail *rest = srv_mailbox_take(m, &closed);
    while (rest) {
        srv_mail *c = rest;
        rest = c->next;
        refuse(c);
        srv_mail_unref(c);
    }
    pthread_cond_destroy(&m->cv);
    pthread_mutex_destroy(&m->mu);
}

/* Appends c with the next ticket; false when closed or full. Lock held. */
static bool enqueue_locked(srv_mailbox *m, srv_mail *c, bool bounded)
{
    if (m->closed || (bounded && m->queued >= QUEUE_MAX)) return false;
    c->ticket = ++m->next_ticket;
    c->next = NULL;
    if (m->tail)
        m->tail->next = c;
    else
        m->head = c;
    m->tail = c;
    m->queued++;
    pthread_cond_signal(&m->cv);
    return true;
}

bool srv_mailbox_call(srv_mailbox *m, srv_mail *c, unsigned timeout_ms)
{
    atomic_fetch_add(&c->refs, 1); /* the queue's reference */
    pthread_mutex_lock(&m->mu);
    bool queued = enqueue_locked(m, c, false);
    pthread_mutex_unlock(&m->mu);
    if (!queued) {
        srv_mail_unref(c);
        refuse(c);
        return false;
    }
    struct timespec deadline;
    clock_gettime(CLOCK_REALTIME, &deadline);
    deadline.tv_sec += timeout_ms / 1000;
    deadline.tv_nsec += (long)(timeout_ms % 1000) * 1000000L;
    if (deadline.tv_nsec >= 1000000000L) deadline.tv_sec++, deadline.tv_nsec -= 1000000000L;
    pthread_mutex_lock(&c->mu);
    while (!c->done)
        if (pthread_cond_timedwait(&c->cv, &c->mu, &deadline) != 0) break;
    bool ok = c->done;
    if (!ok) {
        c->abandoned = true;
        c->reply.status = 503;
        c->reply.body = srv_json_error_body(
            SRV_ERR_UNAVAILABLE, "The render thread did not answer in time; the change may still "
                                 "be applied.");
    }
    pthread_mutex_unlock(&c->mu);
    return ok;
}

uint64_t srv_mailbox_post(srv_mailbox *m, srv_mail *c)
{
    pthread_mutex_lock(&m->mu);
    bool queued = enqueue_locked(m, c, true);
    uint64_t ticket = queued ? c->ticket : 0;
    pthread_mutex_unlock(&m->mu);
    if (!queued) srv_mail_unref(c);
    return ticket;
}

srv_mail *srv_mailbox_take(srv_mailbox *m, bool *closed)
{
    pthread_mutex_lock(&m->mu);
    srv_mail *batch = m->head;
    m->head = m->tail = NULL;
    m->queued = 0;
    *closed = m->closed;
    pthread_mutex_unlock(&m->mu);
    return batch;
}

void srv_mailbox_wait(srv_mailbox *m, double wake_ms)
{
    pthread_mutex_lock(&m->mu);
    if (!m->head && !m->closed) {
        if (isinf(wake_ms)) {
            pthread_cond_wait(&m->cv, &m->mu);
        } else {
            double delay = wake_ms - srv_mono_ms();
            if (delay > 0) {
                struct timespec ts;
                clock_gettime(CLOCK_REALTIME, &ts);
                long long ns = (long long)ts.tv_nsec + (long long)(delay * 1e6);
                ts.tv_sec += ns / 1000000000LL;
                ts.tv_nsec = ns % 1000000000LL;
                pthread_cond_timedwait(&m->cv, &m->mu, &ts);
            }
        }
    }
    pthread_mutex_unlock(&m->mu);
}

void srv_mailbox_wake(srv_mailbox *m)
{
    pthread_mutex_lock(&m->mu);
    pthread_cond_signal(&m->cv);
    pthread_mutex_unlock(&m->mu);
}

/* ---- mail ------------------------------------------------------------------------------------ */

void srv_mail_init(srv_mail *m, srv_mail_destroy_fn *destroy)
{
    *m = (srv_mail){.destroy = destroy};
    atomic_init(&m->refs, 1);
    pthread_mutex_init(&m->mu, NULL);
    pthread_cond_init(&m->cv, NULL);
}

void srv_mail_unref(srv_mail *m)
{
    if (!m || atomic_fetch_sub(&m->refs, 1) != 1) return;
    free(m->reply.body);
    m->reply.body = NULL;
    pthread_cond_destroy(&m->cv);
    pthread_mutex_destroy(&m->mu);
    if (m->destroy) m->destroy(m);
}

void srv_mail_complete(srv_mail *m, int status, char *body)
{
    pthread_mutex_lock(&m->mu);
    if (m->abandoned) {
        free(body);
    } else {
        free(m->reply.body);
        m->reply.status = status;
        m->reply.body = body;
    }
    m->done = true;
    pthread_cond_broadcast(&m->cv);
    pthread_mutex_unlock(&m->mu);
}
