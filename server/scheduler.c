/* scheduler.c: the render thread's policy (see scheduler.h). */
#include "scheduler.h"

#include <math.h>

srv_sched_step srv_sched_next(const srv_sched_state *s)
{
    srv_sched_step step = {.action = SRV_SCHED_SLEEP, .wake_ms = INFINITY};
    bool any_watched = false, any_owed = false, recent_input = false;
    for (unsigned k = 0; k < s->view_count; k++) {
        const srv_sched_view *v = &s->views[k];
        if (!v->watched) continue;
        any_watched = true;
        if (s->now_ms - v->last_input_ms < s->still_delay_ms) recent_input = true;
        if (!v->dirty) continue;
        if (v->behind_world) any_owed = true;
        double due = v->last_render_ms + s->frame_interval_ms;
        if (due > s->now_ms) {
            if (due < step.wake_ms) step.wake_ms = due;
        } else if (!s->readback_free) {
            /* the ring is full: look again as soon as a copy may have finished */
            if (s->now_ms + 1 < step.wake_ms) step.wake_ms = s->now_ms + 1;
        }
    }
    /* 1. dirty, due views in turn */
    if (s->readback_free && s->view_count) {
        for (unsigned n = 0; n < s->view_count; n++) {
            unsigned k = (s->cursor + n) % s->view_count;
            const srv_sched_view *v = &s->views[k];
            if (v->watched && v->dirty && v->last_render_ms + s->frame_interval_ms <= s->now_ms) {
                step.action = SRV_SCHED_RENDER_VIEW;
                step.view = k;
                return step;
            }
        }
    }
    /* 2. the world advances once every watched view has shown the current state */
    if (any_watched && !any_owed && s->world_wants_update) {
        double due = s->last_tick_ms + s->frame_interval_ms;
        if (due <= s->now_ms) {
            step.action = SRV_SCHED_ADVANCE_WORLD;
            unsigned per_tick = recent_input ? 1u : SRV_SCHED_CONVERGE_UPDATES;
            step.world_updates =
                s->world_updates_left < per_tick ? s->world_updates_left : per_tick;
            return step;
        }
        if (due < step.wake_ms) step.wake_ms = due;
    }
    /* 3. still frames once input has stopped (never for a view that owes a frame anyway) */
    for (unsigned n = 0; n < s->view_count; n++) {
        unsigned k = (s->cursor + n) % s->view_count;
        const srv_sched_view *v = &s->views[k];
        if (!v->watched || v->dirty || !v->need_still) continue;
        double due = v->last_input_ms + s->still_delay_ms;
        if (due <= s->now_ms) {
            step.action = SRV_SCHED_EMIT_STILL;
            step.view = k;
            step.wake_ms = INFINITY;
            return step;
        }
        if (due < step.wake_ms) step.wake_ms = due;
    }
    return step;
}
