/* commands.c: commands as mail of the render loop's mailbox (commands.h): creation, the
 * payloads a command owns, and replies. */
#include "server/api/commands.h"

#include <stdlib.h>

#include "server/api/api_json.h"

/* The mail's destroy callback: frees what the command owns, then the command. */
static void cmd_destroy(srv_mail *m)
{
    srv_cmd *c = srv_cmd_of(m);
    if (c->scene) {
        rd_scene_destroy(c->scene);
        free(c->scene);
    }
    if (c->staged) {
        rd_gpu_scene_staged_destroy(c->staged);
        free(c->staged);
    }
    if (c->env_staged) {
        rd_env_staged_destroy(c->env_staged);
        free(c->env_staged);
    }
    free(c);
}

srv_cmd *srv_cmd_new(srv_cmd_kind kind)
{
    srv_cmd *c = calloc(1, sizeof *c);
    if (!c) abort();
    srv_mail_init(&c->mail, cmd_destroy);
    c->kind = kind;
    return c;
}

void srv_cmd_unref(srv_cmd *c)
{
    if (c) srv_mail_unref(&c->mail);
}

void srv_cmd_complete(srv_cmd *c, int status, char *body)
{
    srv_mail_complete(&c->mail, status, body);
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
