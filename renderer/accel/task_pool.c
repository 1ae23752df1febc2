/* task_pool.c: one mutex, one condition variable and an intrusive LIFO list of tasks.
 *
 * Tasks here are coarse (thousands of primitives each), so a single lock is not the
 * bottleneck; one condition variable, broadcast when a task is queued or a group empties,
 * wakes both idle workers and waiters. */
#include "renderer/accel/task_pool.h"

#include <assert.h>
#include <pthread.h>
#include <stdbool.h>
#include <stdlib.h>
#include <unistd.h>

struct rd_task_pool {
    pthread_mutex_t mu;
    pthread_cond_t cv;
    rd_task *head; /* newest first */
    bool stop;
    uint32_t threads;
    uint32_t started; /* workers running */
    pthread_t *workers;
};

uint32_t rd_online_cores(void)
{
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n < 1 ? 1u : n > 1024 ? 1024u : (uint32_t)n;
}

/* Runs task outside the lock, then retires it from its group. Called with mu held. */
static void run_locked(rd_task_pool *p, rd_task *t)
{
    rd_task_group *g = t->group;
    pthread_mutex_unlock(&p->mu);
    t->fn(t);
    pthread_mutex_lock(&p->mu);
    assert(g->pending > 0);
    if (--g->pending == 0) pthread_cond_broadcast(&p->cv);
}

static void *worker_main(void *arg)
{
    rd_task_pool *p = arg;
    pthread_mutex_lock(&p->mu);
    for (;;) {
        if (p->head) {
            rd_task *t = p->head;
            p->head = t->next;
            run_locked(p, t);
        } else if (p->stop) {
            break;
        } else {
            pthread_cond_wait(&p->cv, &p->mu);
        }
    }
    pthread_mutex_unlock(&p->mu);
    return NULL;
}

rd_task_pool *rd_task_pool_create(uint32_t threads)
{
    rd_task_pool *p = calloc(1, sizeof *p);
    if (!p) return NULL;
    p->threads = threads ? threads : rd_online_cores();
    p->workers = calloc(p->threads, sizeof *p->workers);
    if (!p->workers || pthread_mutex_init(&p->mu, NULL) != 0) {
        free(p->workers);
        free(p);
        return NULL;
    }
    if (pthread_cond_init(&p->cv, NULL) != 0) {
        pthread_mutex_destroy(&p->mu);
        free(p->workers);
        free(p);
        return NULL;
    }
    for (uint32_t i = 0; i + 1 < p->threads; i++) {
        if (pthread_create(&p->workers[i], NULL, worker_main, p) != 0) {
            rd_task_pool_destroy(p);
            return NULL;
        }
        p->started++;
    }
    return p;
}

void rd_task_pool_destroy(rd_task_pool *p)
{
    if (!p) return;
    pthread_mutex_lock(&p->mu);
    /* Without workers nobody else would drain the queue. */
    while (p->started == 0 && p->head) {
        rd_task *t = p->head;
        p->head = t->next;
        run_locked(p, t);
    }
    p->stop = true;
    pthread_cond_broadcast(&p->cv);
    pthread_mutex_unlock(&p->mu);
    for (uint32_t i = 0; i < p->started; i++)
        pthread_join(p->workers[i], NULL);
    assert(!p->head);
    pthread_cond_destroy(&p->cv);
    pthread_mutex_destroy(&p->mu);
    free(p->workers);
    free(p);
}

uint32_t rd_task_pool_threads(const rd_task_pool *p)
{
    return p ? p->threads : 1u;
}

void rd_task_submit(rd_task_pool *p, rd_task_group *g, rd_task *t, rd_task_fn fn)
{
    t->fn = fn;
    t->group = g;
    if (!p) {
        fn(t);
        return;
    }
    pthread_mutex_lock(&p->mu);
    g->pending++;
    t->next = p->head;
    p->head = t;
    pthread_cond_broadcast(&p->cv);
    pthread_mutex_unlock(&p->mu);
}

void rd_task_wait(rd_task_pool *p, rd_task_group *g)
{
    if (!p) return;
    pthread_mutex_lock(&p->mu);
    while (g->pending > 0) {
        /* Help with this group's own queued tasks only: picking up another group's long task
         * here would hold up whoever waits for this group. */
        rd_task **link = &p->head;
        while (*link && (*link)->group != g)
            link = &(*link)->next;
        if (*link) {
            rd_task *t = *link;
            *link = t->next;
            run_locked(p, t);
        } else {
            pthread_cond_wait(&p->cv, &p->mu);
        }
    }
    pthread_mutex_unlock(&p->mu);
}

bool rd_task_group_done(rd_task_pool *p, rd_task_group *g)
{
    if (!p) return true;
    pthread_mutex_lock(&p->mu);
    bool done = g->pending == 0;
    pthread_mutex_unlock(&p->mu);
    return done;
}
