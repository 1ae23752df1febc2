/* Input-to-frame stages (server/render/latency_stats.c): stages add up to the total, clock steps never
 * give negative stages, nearest-rank percentiles over the newest SRV_LATENCY_WINDOW samples. */
#include <math.h>

#include "server/render/latency_stats.h"
#include "test_util.h"

static srv_latency_stamps stamps(uint64_t t0, unsigned q, unsigned r, unsigned e, unsigned w,
                                 unsigned x)
{
    srv_latency_stamps s = {.input_us = t0};
    s.capture_us = s.input_us + q;
    s.ready_us = s.capture_us + r;
    s.encode_us = s.ready_us + e;
    s.send_us = s.encode_us + w;
    s.done_us = s.send_us + x;
    return s;
}

int main(void)
{
    static srv_latency_ring ring; /* zeroed */
    srv_latency_summary sum;
    srv_latency_summarise(&ring, &sum);
    CHECK(sum.count == 0 && sum.samples == 0 && sum.p50[SRV_LAT_TOTAL] == 0);

    /* one sample: each stage as given, in ms */
    srv_latency_stamps s = stamps(1000000, 1500, 3000, 800, 0, 250);
    srv_latency_add(&ring, &s);
    srv_latency_summarise(&ring, &sum);
    CHECK(sum.count == 1 && sum.samples == 1);
    CHECK(fabs(sum.p50[SRV_LAT_QUEUE] - 1.5) < 1e-9 && fabs(sum.p50[SRV_LAT_RENDER] - 3.0) < 1e-9);
    CHECK(fabs(sum.p50[SRV_LAT_ENCODE] - 0.8) < 1e-9 && sum.p50[SRV_LAT_WAIT] == 0);
    CHECK(fabs(sum.p50[SRV_LAT_TRANSMIT] - 0.25) < 1e-9);
    CHECK(fabs(sum.p95[SRV_LAT_TOTAL] - 5.55) < 1e-9 && fabs(sum.mean[SRV_LAT_TOTAL] - 5.55) < 1e-9);

    /* a stamp earlier than the one before (another thread's clock read first): clamped to 0 */
    srv_latency_stamps back = s;
    back.ready_us = back.capture_us - 400;
    srv_latency_add(&ring, &back);
    srv_latency_summarise(&ring, &sum);
    CHECK(sum.count == 2);
    for (int i = 0; i < SRV_LAT_STAGES; i++) CHECKF(sum.p50[i] >= 0, "stage %d >= 0", i);

    /* 100 samples with queue 1..100 ms: p50 = 50, p95 = 95 (nearest rank), means add up */
    static srv_latency_ring r2;
    for (unsigned i = 1; i <= 100; i++) {
        srv_latency_stamps t = stamps(5000000ull * i, i * 1000, 2000, 500, 100 * (i % 3), 10);
        srv_latency_add(&r2, &t);
    }
    srv_latency_summarise(&r2, &sum);
    CHECK(sum.count == 100 && sum.samples == 100);
    CHECKF(fabs(sum.p50[SRV_LAT_QUEUE] - 50) < 1e-9, "p50 %g", sum.p50[SRV_LAT_QUEUE]);
    CHECKF(fabs(sum.p95[SRV_LAT_QUEUE] - 95) < 1e-9, "p95 %g", sum.p95[SRV_LAT_QUEUE]);
    double parts = 0;
    for (int i = 0; i < SRV_LAT_TOTAL; i++) parts += sum.mean[i];
    CHECKF(fabs(parts - sum.mean[SRV_LAT_TOTAL]) < 1e-9, "means add up: %g vs %g", parts,
           sum.mean[SRV_LAT_TOTAL]);

    /* the window keeps the newest samples only */
    for (unsigned i = 0; i < SRV_LATENCY_WINDOW; i++) {
        srv_latency_stamps t = stamps(1, 7000, 0, 0, 0, 0);
        srv_latency_add(&r2, &t);
    }
    srv_latency_summarise(&r2, &sum);
    CHECK(sum.count == SRV_LATENCY_WINDOW && sum.samples == 100 + SRV_LATENCY_WINDOW);
    CHECK(fabs(sum.p50[SRV_LAT_QUEUE] - 7) < 1e-9 && fabs(sum.p95[SRV_LAT_TOTAL] - 7) < 1e-9);
    return test_finish();
}
