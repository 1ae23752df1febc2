/* latency_stats.h: where input-to-frame time goes, for /v1/stats (issue "pipelined frames").
 *
 * For each viewer input (a camera message) the first frame that reflects it yields one sample,
 * split into stages along the frame's path through the daemon:
 *   queue     the message's arrival until its view's render began (mailbox, scheduler pacing)
 *   render    render began until its pixels reached the encoders (GPU frame and readback)
 *   encode    until its JPEG was published
 *   wait      until the sender started it (flow control, a frame still being sent)
 *   transmit  until its last byte was handed to the socket
 * Times are Unix microseconds taken on the threads that own each step; stages of one sample
 * add up to its total. The network to the browser and decoding there are the client's part
 * (protocol/stream.md: the frame header carries the same stamps). */
#ifndef SRV_LATENCY_STATS_H
#define SRV_LATENCY_STATS_H

#include <stdint.h>

#define SRV_LATENCY_WINDOW 256 /* newest samples summarised */

typedef enum srv_latency_stage {
    SRV_LAT_QUEUE,
    SRV_LAT_RENDER,
    SRV_LAT_ENCODE,
    SRV_LAT_WAIT,
    SRV_LAT_TRANSMIT,
    SRV_LAT_TOTAL,
    SRV_LAT_STAGES
} srv_latency_stage;

extern const char *const srv_latency_stage_names[SRV_LAT_STAGES];

/* The stamps of one input's first frame (Unix microseconds, in this order). */
typedef struct srv_latency_stamps {
    uint64_t input_us, capture_us, ready_us, encode_us, send_us, done_us;
} srv_latency_stamps;

typedef struct srv_latency_ring {
    double ms[SRV_LATENCY_WINDOW][SRV_LAT_STAGES];
    unsigned head, count;
    uint64_t total; /* samples ever recorded */
} srv_latency_ring;

typedef struct srv_latency_summary {
    unsigned count;   /* samples summarised (at most SRV_LATENCY_WINDOW) */
    uint64_t samples; /* samples ever recorded */
    double p50[SRV_LAT_STAGES], p95[SRV_LAT_STAGES], mean[SRV_LAT_STAGES];
} srv_latency_summary;

/* Adds one sample. Stamps out of order (clock steps) are clamped so no stage is negative. */
void srv_latency_add(srv_latency_ring *r, const srv_latency_stamps *s);
/* Percentiles (nearest rank) and means per stage over the window; zeros when empty. */
void srv_latency_summarise(const srv_latency_ring *r, srv_latency_summary *out);

#endif
