/* task_pool.h: a small fixed pool of worker threads running caller-owned tasks.
 *
 * A task is an rd_task embedded in the caller's own struct (first member, so the function can
 * cast back); the pool never allocates per task. Tasks belong to a group, and rd_task_wait
 * returns once every task submitted to that group (also from inside other tasks) has run. A
 * waiting thread runs queued tasks of the group it waits for, so tasks may submit and wait
 * for nested groups without deadlock, and a pool of one thread (no workers) still works: the
 * waiter runs everything. Workers take the newest task first.
 *
 * pool == NULL is allowed everywhere: rd_task_submit then runs the task at once on the
 * calling thread and rd_task_wait returns immediately.
 */
#ifndef RD_TASK_POOL_H
#define RD_TASK_POOL_H

#include <stdbool.h>
#include <stdint.h>

typedef struct rd_task rd_task;
typedef struct rd_task_group rd_task_group;
typedef void (*rd_task_fn)(rd_task *task);

struct rd_task {
    rd_task_fn fn;
    rd_task_group *group;
    rd_task *next;
};

/* Zero-initialise before use; it must outlive rd_task_wait. */
struct rd_task_group {
    uint32_t pending; /* guarded by the pool's mutex */
};

typedef struct rd_task_pool rd_task_pool;

/* Online CPU cores (at least 1). */
uint32_t rd_online_cores(void);

/* A pool of `threads` threads of execution: threads - 1 workers plus whichever thread waits.
 * 0 = rd_online_cores(). Returns NULL when out of memory or a thread cannot start. */
rd_task_pool *rd_task_pool_create(uint32_t threads);
/* Runs every task still queued, then joins the workers. NULL is ignored. */
void rd_task_pool_destroy(rd_task_pool *pool);
uint32_t rd_task_pool_threads(const rd_task_pool *pool); /* 1 for NULL */

/* Queues task (which must stay valid until it has run) in group g; fn receives task. */
void rd_task_submit(rd_task_pool *pool, rd_task_group *g, rd_task *task, rd_task_fn fn);
/* Returns when every task of g has finished, running queued tasks of g meanwhile. */
void rd_task_wait(rd_task_pool *pool, rd_task_group *g);
/* Whether every task of g has finished, without blocking or running any (a poll for work
 * handed off the calling thread; rd_task_wait afterwards returns at once). true for NULL. */
bool rd_task_group_done(rd_task_pool *pool, rd_task_group *g);

#endif
