/* Per-pass statistics by name (renderer/vk/frame_stats.c): rd_frame_stats_pass finds a pass or
 * appends it with 0 ms and refuses past RD_TIMER_MAX; rd_frame_stats_add sums passes of the same
 * name, appends new ones in order (a distance-map rebuild that runs in some updates only) and
 * adds the ray counts. */
#include <stdio.h>
#include <string.h>

#include "renderer/vk/frame_stats.h"
#include "test_util.h"

int main(void)
{
    rd_frame_stats a = {0};
    CHECK(rd_frame_stats_pass(&a, "probe trace") == 0);
    CHECK(rd_frame_stats_pass(&a, "probe shade") == 1);
    CHECK(rd_frame_stats_pass(&a, "probe trace") == 0 && a.pass_count == 2);
    CHECK(a.pass_ms[0] == 0 && a.pass_ms[1] == 0);
    a.pass_ms[0] = 1.0, a.pass_ms[1] = 2.0;
    a.rays.probe_rays = 10;

    rd_frame_stats b = {0};
    int m = rd_frame_stats_pass(&b, "shadow maps"), t = rd_frame_stats_pass(&b, "probe trace");
    b.pass_ms[m] = 0.5, b.pass_ms[t] = 3.0;
    b.rays.probe_rays = 5, b.rays.shadow_map_rays = 7;
    b.timed = true;
    rd_frame_stats_add(&a, &b);
    CHECKF(a.pass_count == 3 && strcmp(a.pass_name[2], "shadow maps") == 0,
           "%u passes, the last %s", a.pass_count,
           a.pass_count ? a.pass_name[a.pass_count - 1] : "-");
    CHECK(a.pass_ms[0] == 4.0 && a.pass_ms[1] == 2.0 && a.pass_ms[2] == 0.5);
    CHECK(a.rays.probe_rays == 15 && a.rays.shadow_map_rays == 7 && a.timed);
    CHECK(rd_frame_stats_total_ms(&a) == 6.5);

    static const char *names[RD_TIMER_MAX + 1];
    static char buf[RD_TIMER_MAX + 1][16];
    rd_frame_stats full = {0};
    for (int i = 0; i <= RD_TIMER_MAX; i++) {
        snprintf(buf[i], sizeof buf[i], "pass %d", i);
        names[i] = buf[i];
    }
    for (int i = 0; i < RD_TIMER_MAX; i++)
        CHECK(rd_frame_stats_pass(&full, names[i]) == i);
    CHECK(rd_frame_stats_pass(&full, names[RD_TIMER_MAX]) == -1 && full.pass_count == RD_TIMER_MAX);
    CHECK(rd_frame_stats_pass(&full, names[3]) == 3);
    return test_finish();
}
