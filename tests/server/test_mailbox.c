/* The mailbox as a generic queue: mail of a payload type it does not know, freed through the
 * owner's destroy callback exactly once; tickets in posting order; calls answered, timed out
 * and refused; what is queued at shutdown answered with a 503. */
#include <math.h>
#include <pthread.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "server/api/mailbox.h"
#include "test_util.h"

/* A payload the mailbox has never heard of. */
typedef struct note {
    srv_mail mail;
    int value;
    int *freed; /* counts destroy callbacks */
} note;

static void note_destroy(srv_mail *m)
{
    note *n = (note *)((char *)m - offsetof(note, mail));
    (*n->freed)++;
    free(n);
}

static note *note_new(int value, int *freed)
{
    note *n = calloc(1, sizeof *n);
    if (!n) abort();
    srv_mail_init(&n->mail, note_destroy);
    n->value = value;
    n->freed = freed;
    return n;
}

static char *text(const char *s)
{
    char *t = malloc(strlen(s) + 1);
    if (!t) abort();
    strcpy(t, s);
    return t;
}

static void test_post_take(void)
{
    srv_mailbox mb;
    srv_mailbox_init(&mb);
    int freed = 0;
    uint64_t tickets[3];
    for (int i = 0; i < 3; i++)
        tickets[i] = srv_mailbox_post(&mb, &note_new(10 + i, &freed)->mail);
    CHECK(tickets[0] == 1 && tickets[1] == 2 && tickets[2] == 3);
    bool closed = true;
    srv_mail *batch = srv_mailbox_take(&mb, &closed);
    CHECK(!closed);
    int i = 0;
    while (batch) {
        srv_mail *m = batch;
        batch = m->next;
        note *n = (note *)((char *)m - offsetof(note, mail));
        CHECKF(n->value == 10 + i && m->ticket == tickets[i], "mail %d in posting order", i);
        i++;
        srv_mail_complete(m, 204, NULL); /* nobody waits: the reply goes with the mail */
        srv_mail_unref(m);
    }
    CHECK(i == 3);
    CHECKF(freed == 3, "each posted note destroyed once (%d)", freed);
    CHECK(srv_mailbox_take(&mb, &closed) == NULL);
    srv_mailbox_dispose(&mb);
}

typedef struct caller {
    srv_mailbox *mb;
    note *n;
    unsigned timeout_ms;
    bool answered;
} caller;

static void *call_main(void *arg)
{
    caller *c = arg;
    c->answered = srv_mailbox_call(c->mb, &c->n->mail, c->timeout_ms);
    return NULL;
}

/* Render-thread side: waits for one piece of mail and takes it. */
static srv_mail *take_one(srv_mailbox *mb)
{
    for (;;) {
        bool closed;
        srv_mail *m = srv_mailbox_take(mb, &closed);
        if (m || closed) return m;
        srv_mailbox_wait(mb, INFINITY);
    }
}

static void test_call_answered(void)
{
    srv_mailbox mb;
    srv_mailbox_init(&mb);
    int freed = 0;
    caller c = {.mb = &mb, .n = note_new(7, &freed), .timeout_ms = 60000};
    pthread_t t;
    pthread_create(&t, NULL, call_main, &c);
    srv_mail *m = take_one(&mb);
    CHECK(m == &c.n->mail && m->next == NULL);
    srv_mail_complete(m, 200, text("{\"ok\":true}"));
    srv_mail_unref(m); /* the queue's reference */
    pthread_join(t, NULL);
    CHECK(c.answered);
    CHECK(c.n->mail.reply.status == 200);
    CHECK(c.n->mail.reply.body && strcmp(c.n->mail.reply.body, "{\"ok\":true}") == 0);
    CHECKF(freed == 0, "the caller still holds the mail");
    srv_mail_unref(&c.n->mail);
    CHECK(freed == 1);
    srv_mailbox_dispose(&mb);
}

static void test_call_timeout(void)
{
    srv_mailbox mb;
    srv_mailbox_init(&mb);
    int freed = 0;
    note *n = note_new(1, &freed);
    CHECK(!srv_mailbox_call(&mb, &n->mail, 20));
    CHECK(n->mail.reply.status == 503);
    CHECK(n->mail.reply.body && strstr(n->mail.reply.body, "\"unavailable\""));
    /* the render thread answers late: the reply it gives is dropped */
    bool closed;
    srv_mail *m = srv_mailbox_take(&mb, &closed);
    CHECK(m == &n->mail);
    srv_mail_complete(m, 200, text("late"));
    srv_mail_unref(m);
    CHECK(n->mail.reply.status == 503 && strcmp(n->mail.reply.body, "late") != 0);
    CHECK(freed == 0);
    srv_mail_unref(&n->mail);
    CHECK(freed == 1);
    srv_mailbox_dispose(&mb);
}

static void test_closed(void)
{
    srv_mailbox mb;
    srv_mailbox_init(&mb);
    int freed = 0;
    srv_mailbox_close(&mb);
    CHECKF(srv_mailbox_post(&mb, &note_new(1, &freed)->mail) == 0, "a closed mailbox refuses");
    CHECKF(freed == 1, "refused posted mail is destroyed");
    note *n = note_new(2, &freed);
    CHECK(!srv_mailbox_call(&mb, &n->mail, 60000));
    CHECK(n->mail.reply.status == 503);
    CHECK(n->mail.reply.body && strstr(n->mail.reply.body, "shutting down"));
    srv_mail_unref(&n->mail);
    CHECK(freed == 2);
    bool closed = false;
    CHECK(srv_mailbox_take(&mb, &closed) == NULL && closed);
    srv_mailbox_dispose(&mb);
}

static void test_dispose_answers(void)
{
    srv_mailbox mb;
    srv_mailbox_init(&mb);
    int freed = 0;
    srv_mailbox_post(&mb, &note_new(1, &freed)->mail);
    caller c = {.mb = &mb, .n = note_new(2, &freed), .timeout_ms = 60000};
    pthread_t t;
    pthread_create(&t, NULL, call_main, &c);
    for (;;) { /* until the call is queued behind the post */
        pthread_mutex_lock(&mb.mu);
        unsigned queued = mb.queued;
        pthread_mutex_unlock(&mb.mu);
        if (queued == 2) break;
        nanosleep(&(struct timespec){.tv_nsec = 1000000}, NULL);
    }
    srv_mailbox_dispose(&mb);
    pthread_join(t, NULL);
    CHECKF(c.answered, "the waiting caller is answered");
    CHECK(c.n->mail.reply.status == 503);
    CHECK(c.n->mail.reply.body && strstr(c.n->mail.reply.body, "shutting down"));
    CHECKF(freed == 1, "the posted mail is destroyed, the called one is still the caller's");
    srv_mail_unref(&c.n->mail);
    CHECK(freed == 2);
}

int main(void)
{
    test_post_take();
    test_call_answered();
    test_call_timeout();
    test_closed();
    test_dispose_answers();
    return test_finish();
}
