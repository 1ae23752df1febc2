/* mailbox.c: the render thread's command queue. */
#include "server/api/mailbox.h"
#include "server/base/clock.h"

#include <math.h>
#include <stdlib.h>
#include <time.h>

#include "server/api/api_json.h"

#define QUEUE_MAX 4096 /* commands waiting; viewers posting faster are refused */

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

void srv_mailbox_dispose(srv_mailbox *m)
{
    srv_mailbox_close(m);
    bool closed;
    srv_cmd *rest = srv_mailbox_take(m, &closed);
    while (rest) {
        srv_cmd *c = rest;
        rest = c->next;
        srv_cmd_fail(c, 503, SRV_ERR_UNAVAILABLE, "The server is shutting down.");
        srv_cmd_unref(c);
    }
    pthread_cond_destroy(&m->cv);
    pthread_mutex_destroy(&m->mu);
}

/* Appends c with the next ticket; false when closed or full. Lock held. */
static bool enqueue_locked(srv_mailbox *m, srv_cmd *c, bool bounded)
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

bool srv_mailbox_call(srv_mailbox *m, srv_cmd *c, unsigned timeout_ms)
{
    atomic_fetch_add(&c->refs, 1); /* the queue's reference */
    pthread_mutex_lock(&m->mu);
    bool queued = enqueue_locked(m, c, false);
    pthread_mutex_unlock(&m->mu);
    if (!queued) {
        srv_cmd_unref(c);
        srv_cmd_fail(c, 503, SRV_ERR_UNAVAILABLE, "The server is shutting down.");
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

uint64_t srv_mailbox_post(srv_mailbox *m, srv_cmd *c)
{
    pthread_mutex_lock(&m->mu);
    bool queued = enqueue_locked(m, c, true);
    uint64_t ticket = queued ? c->ticket : 0;
    pthread_mutex_unlock(&m->mu);
    if (!queued) srv_cmd_unref(c);
    return ticket;
}

srv_cmd *srv_mailbox_take(srv_mailbox *m, bool *closed)
{
    pthread_mutex_lock(&m->mu);
    srv_cmd *batch = m->head;
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

/* ---- commands ------------------------------------------------------------------------------- */

srv_cmd *srv_cmd_new(srv_cmd_kind kind)
{
    srv_cmd *c = calloc(1, sizeof *c);
    if (!c) abort();
    c->kind = kind;
    atomic_init(&c->refs, 1);
    pthread_mutex_init(&c->mu, NULL);
    pthread_cond_init(&c->cv, NULL);
    return c;
}

void srv_cmd_unref(srv_cmd *c)
{
    if (!c || atomic_fetch_sub(&c->refs, 1) != 1) return;
    if (c->scene) {
        rd_scene_destroy(c->scene);
        free(c->scene);
    }
    if (c->prepared) {
        rd_gpu_scene_prep_destroy(c->prepared);
        free(c->prepared);
    }
    if (c->env_image) {
        rd_env_image_free(c->env_image);
        free(c->env_image);
    }
    free(c->reply.body);
    pthread_cond_destroy(&c->cv);
    pthread_mutex_destroy(&c->mu);
    free(c);
}

void srv_cmd_complete(srv_cmd *c, int status, char *body)
{
    pthread_mutex_lock(&c->mu);
    if (c->abandoned) {
        free(body);
    } else {
        free(c->reply.body);
        c->reply.status = status;
        c->reply.body = body;
    }
    c->done = true;
    pthread_cond_broadcast(&c->cv);
    pthread_mutex_unlock(&c->mu);
}

void srv_cmd_complete_json(srv_cmd *c, int status, cJSON *j)
{
    srv_cmd_complete(c, status, srv_json_print_delete(j));
}

void srv_cmd_complete_error(srv_cmd *c, const srv_api_error *e)
{
    srv_cmd_complete(c, e->status, srv_json_error_body(e->code, e->message));
}

void srv_cmd_fail(srv_cmd *c, int status, const char *code, const char *message)
{
    srv_cmd_complete(c, status, srv_json_error_body(code, message));
}
