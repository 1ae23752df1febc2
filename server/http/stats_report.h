/* stats_report.h: /v1/stats (JSON) and /metrics (Prometheus text exposition format 0.0.4)
 * from the render, encoder, stream and HTTP counters. */
#ifndef SRV_STATS_REPORT_H
#define SRV_STATS_REPORT_H

#include <cjson/cJSON.h>
#include <stdint.h>

#include "server/base/process_memory.h"
#include "server/encode/encoder_pool.h"
#include "server/render/render_loop.h"
#include "server/stream/ws_stream.h"

typedef struct srv_http_counters {
    uint64_t requests, status_2xx, status_4xx, status_5xx, uploads_accepted, uploads_rejected;
    /* connections (http_admission.h): open now, refused for their address's limit, the limit
     * per address and the idle timeout */
    uint64_t connections_refused;
    unsigned connections_open, connections_per_ip, idle_timeout_s;
} srv_http_counters;

typedef struct srv_stats_snapshot {
    srv_render_stats render;
    srv_encoder_stats encoder;
    srv_ws_stats stream;
    srv_http_counters http;
    srv_process_memory memory;
    double uptime_s;
} srv_stats_snapshot;

cJSON *srv_stats_json(const srv_stats_snapshot *s);
/* Prometheus text; malloc'd. */
char *srv_stats_prometheus(const srv_stats_snapshot *s);

#endif
