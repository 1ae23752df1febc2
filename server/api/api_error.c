/* api_error.c: API errors and their JSON bodies (api_error.h). */
#include "server/api/api_error.h"

#include <cjson/cJSON.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

void srv_api_fail(srv_api_error *e, int status, const char *code, const char *fmt, ...)
{
    if (!e) return;
    e->status = status;
    e->code = code;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(e->message, sizeof e->message, fmt, ap);
    va_end(ap);
}

char *srv_json_error_body(const char *code, const char *message)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "error", code);
    cJSON_AddStringToObject(j, "message", message);
    char *s = cJSON_PrintUnformatted(j);
    cJSON_Delete(j);
    if (!s) abort(); /* out of memory */
    return s;
}
