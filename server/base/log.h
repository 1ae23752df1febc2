/* log.h: levelled log lines on stderr, safe from any thread.
 *
 * One line per call: "2024-05-01T12:00:00.123Z probecast[INFO] render: message". The level is
 * set once at start-up (srv_log_set_level) or from $PROBECAST_LOG (error, warn, info, debug).
 */
#ifndef SRV_LOG_H
#define SRV_LOG_H

#include <stdbool.h>

typedef enum srv_log_level {
    SRV_LOG_ERROR = 0,
    SRV_LOG_WARN,
    SRV_LOG_INFO,
    SRV_LOG_DEBUG,
} srv_log_level;

void srv_log_set_level(srv_log_level level);
srv_log_level srv_log_get_level(void);
/* Parses "error", "warn", "info" or "debug"; false when s is none of them. */
bool srv_log_parse_level(const char *s, srv_log_level *out);

#if defined(__GNUC__)
__attribute__((format(printf, 3, 4)))
#endif
void srv_log(srv_log_level level, const char *module, const char *fmt, ...);

#define srv_error(mod, ...) srv_log(SRV_LOG_ERROR, mod, __VA_ARGS__)
#define srv_warn(mod, ...) srv_log(SRV_LOG_WARN, mod, __VA_ARGS__)
#define srv_info(mod, ...) srv_log(SRV_LOG_INFO, mod, __VA_ARGS__)
#define srv_debug(mod, ...) srv_log(SRV_LOG_DEBUG, mod, __VA_ARGS__)

#endif
