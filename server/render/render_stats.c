/* render_stats.c: the render thread's shared statistics. */
#include "server/render/render_stats.h"
#include "server/base/clock.h"

#include <stdio.h>
#include <string.h>

void srv_stats_board_init(srv_stats_board *b)
{
    memset(b, 0, sizeof *b);
    pthread_mutex_init(&b->mu, NULL);
}

void srv_stats_board_dispose(srv_stats_board *b)
{
    pthread_mutex_destroy(&b->mu);
}

static void copy_passes(srv_pass_times *out, const rd_frame_stats *fs)
{
    memset(out, 0, sizeof *out);
    for (unsigned i = 0; i < fs->pass_count && i < RD_TIMER_MAX; i++) {
        snprintf(out->name[i], SRV_PASS_NAME_MAX, "%s", fs->pass_name[i] ? fs->pass_name[i] : "?");
        out->ms[i] = fs->pass_ms[i];
        out->total_ms += fs->pass_ms[i];
    }
    out->count = fs->pass_count < RD_TIMER_MAX ? fs->pass_count : RD_TIMER_MAX;
    out->rays = (uint64_t)fs->rays.primary_rays + fs->rays.shadow_rays + fs->rays.probe_rays +
                fs->rays.path_rays + fs->rays.probe_shadow_rays + fs->rays.reflect_rays +
                fs->rays.shadow_map_rays + fs->rays.probe_path_rays + fs->rays.near_rays;
}

void srv_stats_board_frame(srv_stats_board *b, const rd_frame_stats *fs, unsigned width,
                           unsigned height, double now_ms, double wall_ms)
{
    pthread_mutex_lock(&b->mu);
    srv_render_stats *s = &b->s;
    s->frames_rendered++;
    s->frame_ms_last = wall_ms;
    s->width = width;
    s->height = height;
    copy_passes(&s->view_passes, fs);
    s->rays_per_second =
        s->view_passes.total_ms > 0 ? s->view_passes.rays / (s->view_passes.total_ms * 1e-3) : 0;
    b->frame_times[b->frame_next++ % SRV_FPS_WINDOW] = now_ms;
    pthread_mutex_unlock(&b->mu);
}

void srv_stats_board_tick(srv_stats_board *b, const rd_frame_stats *fs, unsigned updates,
                          double now_ms)
{
    pthread_mutex_lock(&b->mu);
    b->s.world_ticks++;
    b->s.world_updates_total += updates;
    if (updates) copy_passes(&b->s.world_passes, fs);
    b->tick_times[b->tick_next % SRV_FPS_WINDOW] = now_ms;
    b->tick_updates[b->tick_next++ % SRV_FPS_WINDOW] = updates;
    pthread_mutex_unlock(&b->mu);
}

void srv_stats_board_error(srv_stats_board *b, const char *message, bool device_lost)
{
    pthread_mutex_lock(&b->mu);
    snprintf(b->s.last_error, sizeof b->s.last_error, "%s", message);
    b->s.device_lost = device_lost;
    pthread_mutex_unlock(&b->mu);
}

void srv_stats_board_get(srv_stats_board *b, srv_render_stats *out)
{
    double now = srv_mono_ms();
    pthread_mutex_lock(&b->mu);
    *out = b->s;
    unsigned n = 0, u = 0;
    for (unsigned i = 0; i < SRV_FPS_WINDOW && i < b->frame_next; i++)
        if (now - b->frame_times[i] <= 1000.0) n++;
    for (unsigned i = 0; i < SRV_FPS_WINDOW && i < b->tick_next; i++)
        if (now - b->tick_times[i] <= 1000.0) u += b->tick_updates[i];
    pthread_mutex_unlock(&b->mu);
    out->fps = n;
    out->world_updates_per_second = u;
}
