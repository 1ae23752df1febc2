#include "server/render/latency_stats.h"

#include <stdlib.h>
#include <string.h>

const char *const srv_latency_stage_names[SRV_LAT_STAGES] = {
    "queue_ms", "render_ms", "encode_ms", "wait_ms", "transmit_ms", "total_ms",
};

void srv_latency_add(srv_latency_ring *r, const srv_latency_stamps *s)
{
    uint64_t t[6] = {s->input_us, s->capture_us, s->ready_us,
                     s->encode_us, s->send_us,    s->done_us};
    for (int i = 1; i < 6; i++)
        if (t[i] < t[i - 1]) t[i] = t[i - 1];
    double *ms = r->ms[r->head];
    for (int i = 0; i < SRV_LAT_TOTAL; i++) ms[i] = (double)(t[i + 1] - t[i]) / 1000.0;
    ms[SRV_LAT_TOTAL] = (double)(t[5] - t[0]) / 1000.0;
    r->head = (r->head + 1) % SRV_LATENCY_WINDOW;
    if (r->count < SRV_LATENCY_WINDOW) r->count++;
    r->total++;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

void srv_latency_summarise(const srv_latency_ring *r, srv_latency_summary *out)
{
    memset(out, 0, sizeof *out);
    out->count = r->count;
    out->samples = r->total;
    if (!r->count) return;
    double v[SRV_LATENCY_WINDOW];
    for (int st = 0; st < SRV_LAT_STAGES; st++) {
        double sum = 0;
        for (unsigned i = 0; i < r->count; i++) sum += v[i] = r->ms[i][st];
        qsort(v, r->count, sizeof v[0], cmp_double);
        /* nearest rank: the smallest value with at least p of the samples at or below it */
        out->p50[st] = v[(r->count * 50 + 99) / 100 - 1];
        out->p95[st] = v[(r->count * 95 + 99) / 100 - 1];
        out->mean[st] = sum / r->count;
    }
}
