/* test_task_pool.c: every task runs exactly once, on pools of 1, 2, 3 and 8 threads and on
 * none (NULL, inline); tasks submit and wait for nested groups; shutdown drains the queue;
 * rd_task_group_done polls a group without blocking (a task held on a gate stays pending). */
#include "renderer/accel/task_pool.h"
#include "test_util.h"

#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdlib.h>

#define LEAVES 4000

typedef struct leaf_task {
    rd_task task; /* first member */
    atomic_uint *runs;
} leaf_task;

static void leaf_run(rd_task *t)
{
    leaf_task *l = (leaf_task *)t;
    atomic_fetch_add(l->runs, 1);
}

static void test_flat(rd_task_pool *pool, const char *what)
{
    static leaf_task tasks[LEAVES];
    static atomic_uint runs[LEAVES];
    rd_task_group g = {0};
    for (int i = 0; i < LEAVES; i++) {
        atomic_init(&runs[i], 0);
        tasks[i].runs = &runs[i];
        rd_task_submit(pool, &g, &tasks[i].task, leaf_run);
    }
    rd_task_wait(pool, &g);
    int wrong = 0;
    for (int i = 0; i < LEAVES; i++)
        wrong += atomic_load(&runs[i]) != 1;
    CHECKF(wrong == 0, "%s: %d tasks did not run exactly once", what, wrong);
    CHECK(g.pending == 0);
}

/* A binary tree of tasks: each inner task submits its two children into a group of its own
 * and waits for it, then records the sum of its subtree's leaves (so a child that had not
 * finished when wait returned shows up as a wrong sum). Leaves are also counted. */
typedef struct tree_task {
    rd_task task; /* first member */
    rd_task_pool *pool;
    uint32_t depth;
    uint32_t sum;
    atomic_uint *leaf_runs;
} tree_task;

static void tree_run(rd_task *t)
{
    tree_task *n = (tree_task *)t;
    if (n->depth == 0) {
        atomic_fetch_add(n->leaf_runs, 1);
        n->sum = 1;
        return;
    }
    tree_task kids[2];
    rd_task_group g = {0};
    for (int i = 0; i < 2; i++) {
        kids[i] = (tree_task){
            .pool = n->pool, .depth = n->depth - 1, .sum = 0, .leaf_runs = n->leaf_runs};
        rd_task_submit(n->pool, &g, &kids[i].task, tree_run);
    }
    rd_task_wait(n->pool, &g);
    n->sum = kids[0].sum + kids[1].sum;
}

/* Tasks submitting into the group that is being waited for (the BVH builder's pattern). */
typedef struct chain_task {
    rd_task task; /* first member */
    rd_task_pool *pool;
    rd_task_group *group;
    struct chain_task *all;
    uint32_t index, count;
    atomic_uint *runs;
} chain_task;

static void chain_run(rd_task *t)
{
    chain_task *c = (chain_task *)t;
    atomic_fetch_add(&c->runs[c->index], 1);
    for (uint32_t k = 1; k <= 2; k++) { /* children 2i+1, 2i+2 */
        uint32_t child = 2 * c->index + k;
        if (child < c->count) rd_task_submit(c->pool, c->group, &c->all[child].task, chain_run);
    }
}

static void test_nested(rd_task_pool *pool, const char *what)
{
    atomic_uint leaf_runs;
    atomic_init(&leaf_runs, 0);
    tree_task root = {.pool = pool, .depth = 10, .leaf_runs = &leaf_runs};
    rd_task_group g = {0};
    rd_task_submit(pool, &g, &root.task, tree_run);
    rd_task_wait(pool, &g);
    CHECKF(root.sum == 1024, "%s: tree sum %u", what, root.sum);
    CHECKF(atomic_load(&leaf_runs) == 1024, "%s: %u leaves ran", what, atomic_load(&leaf_runs));

    enum { N = 3000 };
    static chain_task all[N];
    static atomic_uint runs[N];
    rd_task_group cg = {0};
    for (uint32_t i = 0; i < N; i++) {
        atomic_init(&runs[i], 0);
        all[i] = (chain_task){
            .pool = pool, .group = &cg, .all = all, .index = i, .count = N, .runs = runs};
    }
    rd_task_submit(pool, &cg, &all[0].task, chain_run);
    rd_task_wait(pool, &cg);
    int wrong = 0;
    for (uint32_t i = 0; i < N; i++)
        wrong += atomic_load(&runs[i]) != 1;
    CHECKF(wrong == 0, "%s: %d chained tasks did not run exactly once", what, wrong);
}

/* Destroying a pool runs what is still queued. */
static void test_shutdown(uint32_t threads)
{
    static leaf_task tasks[LEAVES];
    static atomic_uint runs[LEAVES];
    rd_task_pool *pool = rd_task_pool_create(threads);
    CHECK(pool != NULL);
    if (!pool) return;
    rd_task_group g = {0};
    for (int i = 0; i < LEAVES; i++) {
        atomic_init(&runs[i], 0);
        tasks[i].runs = &runs[i];
        rd_task_submit(pool, &g, &tasks[i].task, leaf_run);
    }
    rd_task_pool_destroy(pool);
    int wrong = 0;
    for (int i = 0; i < LEAVES; i++)
        wrong += atomic_load(&runs[i]) != 1;
    CHECKF(wrong == 0, "shutdown with %u threads: %d tasks did not run exactly once", threads,
           wrong);
    rd_task_pool_destroy(rd_task_pool_create(threads)); /* idle pool */
}

typedef struct gate_task {
    rd_task task; /* first member */
    atomic_bool open, ran;
} gate_task;

static void gate_run(rd_task *t)
{
    gate_task *g = (gate_task *)t;
    while (!atomic_load(&g->open))
        sched_yield();
    atomic_store(&g->ran, true);
}

/* A task that waits for its gate: its group is not done while it waits (on a worker, or queued
 * where the pool has none), and is done once it has run. */
static void test_done(rd_task_pool *pool, const char *what)
{
    gate_task t;
    atomic_init(&t.open, pool == NULL); /* inline: it runs inside submit */
    atomic_init(&t.ran, false);
    rd_task_group g = {0};
    CHECKF(rd_task_group_done(pool, &g), "%s: an empty group is done", what);
    rd_task_submit(pool, &g, &t.task, gate_run);
    if (pool) {
        for (int i = 0; i < 100; i++) /* polls neither block nor run the task */
            CHECKF(!rd_task_group_done(pool, &g), "%s: done before its task ran", what);
        CHECK(!atomic_load(&t.ran));
        atomic_store(&t.open, true);
    }
    if (rd_task_pool_threads(pool) > 1) { /* a worker runs it: poll until it has */
        while (!rd_task_group_done(pool, &g))
            sched_yield();
        CHECKF(atomic_load(&t.ran), "%s: done before its task ran", what);
    } else {
        rd_task_wait(pool, &g); /* no worker: the waiter runs it */
    }
    CHECKF(atomic_load(&t.ran) && rd_task_group_done(pool, &g), "%s: not done after it ran", what);
}

int main(void)
{
    CHECK(rd_online_cores() >= 1);
    CHECK(rd_task_pool_threads(NULL) == 1);
    test_flat(NULL, "inline");
    test_nested(NULL, "inline");
    test_done(NULL, "inline");
    const uint32_t counts[] = {1, 2, 3, 8};
    for (int i = 0; i < 4; i++) {
        rd_task_pool *pool = rd_task_pool_create(counts[i]);
        CHECK(pool != NULL);
        if (!pool) continue;
        CHECK(rd_task_pool_threads(pool) == counts[i]);
        char what[32];
        snprintf(what, sizeof what, "%u threads", counts[i]);
        for (int rep = 0; rep < 3; rep++) {
            test_flat(pool, what);
            test_nested(pool, what);
            test_done(pool, what);
        }
        rd_task_pool_destroy(pool);
        test_shutdown(counts[i]);
    }
    rd_task_pool *all = rd_task_pool_create(0);
    CHECK(all && rd_task_pool_threads(all) == rd_online_cores());
    if (all) test_flat(all, "online cores");
    rd_task_pool_destroy(all);
    rd_task_pool_destroy(NULL);
    return test_finish();
}
