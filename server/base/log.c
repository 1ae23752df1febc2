/* log.c: levelled log lines on stderr (one fprintf per line, so lines never interleave). */
#include "server/base/log.h"

#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

static atomic_int g_level = SRV_LOG_INFO;

void srv_log_set_level(srv_log_level level)
{
    atomic_store(&g_level, (int)level);
}

srv_log_level srv_log_get_level(void)
{
    return (srv_log_level)atomic_load(&g_level);
}

bool srv_log_parse_level(const char *s, srv_log_level *out)
{
    static const char *names[] = {"error", "warn", "info", "debug"};
    for (int i = 0; s && i < 4; i++) {
        if (strcmp(s, names[i]) == 0) {
            *out = (srv_log_level)i;
            return true;
        }
    }
    return false;
}

void srv_log(srv_log_level level, const char *module, const char *fmt, ...)
{
    if ((int)level > atomic_load(&g_level)) return;
    static const char *tags[] = {"ERROR", "WARN", "INFO", "DEBUG"};
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    struct tm tm;
    gmtime_r(&ts.tv_sec, &tm);
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    fprintf(stderr, "%04d-%02d-%02dT%02d:%02d:%02d.%03ldZ probecast[%s] %s: %s\n",
            tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec,
            ts.tv_nsec / 1000000, tags[level], module, msg);
}
