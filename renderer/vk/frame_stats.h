/* frame_stats.h: GPU time per named pass and rays traced, for one frame or one world update.
 * Pass names point at string literals (the rd_timer_mark names), so stats can be copied and
 * merged freely. */
#ifndef RD_FRAME_STATS_H
#define RD_FRAME_STATS_H

#include <stdbool.h>

#include "shaders/gpu_types.h"
#include "renderer/vk/vk_compute.h"

typedef struct rd_frame_stats {
    unsigned pass_count;
    const char *pass_name[RD_TIMER_MAX];
    double pass_ms[RD_TIMER_MAX]; /* GPU time per pass (0 when timestamps are unavailable) */
    bool timed;
    pc_counters rays; /* rays traced per kind */
} rd_frame_stats;

/* Adds src to dst: the times of passes with the same name are summed, new passes are appended
 * in src's order (those past RD_TIMER_MAX are dropped), and ray counts are added. dst is timed
 * when either is. */
void rd_frame_stats_add(rd_frame_stats *dst, const rd_frame_stats *src);
/* The index of the pass called name in s, appended with 0 ms when s has none yet; -1 when s is
 * full (RD_TIMER_MAX passes). */
int rd_frame_stats_pass(rd_frame_stats *s, const char *name);
/* GPU time of all passes together (0 when timestamps are unavailable). */
double rd_frame_stats_total_ms(const rd_frame_stats *s);
/* Adds the sections of a resolved timer (rd_timer_resolve) to dst, by name as above. */
void rd_frame_stats_add_timer(rd_frame_stats *dst, const rd_timer *t);

#endif
