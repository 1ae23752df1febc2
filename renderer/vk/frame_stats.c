/* frame_stats.c: merging per-pass statistics. */
#include "renderer/vk/frame_stats.h"

#include <string.h>

int rd_frame_stats_pass(rd_frame_stats *s, const char *name)
{
    unsigned k = 0;
    while (k < s->pass_count && strcmp(s->pass_name[k], name) != 0)
        k++;
    if (k == s->pass_count) {
        if (k == RD_TIMER_MAX) return -1;
        s->pass_name[k] = name;
        s->pass_ms[k] = 0;
        s->pass_count++;
    }
    return (int)k;
}

static void add_pass(rd_frame_stats *dst, const char *name, double ms)
{
    int k = rd_frame_stats_pass(dst, name);
    if (k >= 0) dst->pass_ms[k] += ms;
}

void rd_frame_stats_add(rd_frame_stats *dst, const rd_frame_stats *src)
{
    for (unsigned i = 0; i < src->pass_count && i < RD_TIMER_MAX; i++)
        add_pass(dst, src->pass_name[i] ? src->pass_name[i] : "?", src->pass_ms[i]);
    dst->timed = dst->timed || src->timed;
    dst->rays.primary_rays += src->rays.primary_rays;
    dst->rays.shadow_rays += src->rays.shadow_rays;
    dst->rays.probe_rays += src->rays.probe_rays;
    dst->rays.path_rays += src->rays.path_rays;
    dst->rays.probe_shadow_rays += src->rays.probe_shadow_rays;
    dst->rays.reflect_rays += src->rays.reflect_rays;
    dst->rays.shadow_map_rays += src->rays.shadow_map_rays;
    dst->rays.probe_path_rays += src->rays.probe_path_rays;
    dst->rays.near_rays += src->rays.near_rays;
}

void rd_frame_stats_add_timer(rd_frame_stats *dst, const rd_timer *t)
{
    dst->timed = dst->timed || t->valid;
    for (uint32_t i = 1; i < t->count && i < RD_TIMER_MAX; i++)
        add_pass(dst, t->names[i] ? t->names[i] : "?", t->ms[i]);
}

double rd_frame_stats_total_ms(const rd_frame_stats *s)
{
    double ms = 0;
    for (unsigned i = 0; i < s->pass_count; i++)
        ms += s->pass_ms[i];
    return ms;
}
