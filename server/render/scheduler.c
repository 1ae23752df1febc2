/* scheduler.c: the render thread's policy (see scheduler.h). */
#include "server/render/scheduler.h"

#include <math.h>

/* When view v may be rendered next: after the global frame interval, or its own if longer. */
static double due_at(const srv_sched_state *s, const srv_sched_view *v)
{
    double gap =
        v->frame_interval_ms > s->frame_interval_ms ? v->frame_interval_ms : s->frame_interval_ms;
    return v->last_render_ms + gap;
}

/* The first watched, dirty view, in turn from the cursor, that pred accepts and that is due
 * under the frame-rate caps; -1 when none. */
static int pick(const srv_sched_state *s, bool (*pred)(const srv_sched_view *))
{
    for (unsigned n = 0; n < s->view_count; n++) {
        unsigned k = (s->cursor + n) % s->view_count;
        const srv_sched_view *v = &s->views[k];
        if (v->watched && v->dirty && !v->busy && pred(v) && due_at(s, v) <= s->now_ms)
            return (int)k;
    }
    return -1;
}

static bool owes_tick(const srv_sched_view *v)
{
    return v->behind_world;
}

static bool input_first(const srv_sched_view *v)
{
    return v->renders_since_tick < 2; /* the tick's frame, and one for its own input */
}

static bool any(const srv_sched_view *v)
{
    (void)v;
    return true;
}

srv_sched_step srv_sched_next(const srv_sched_state *s)
{
    srv_sched_step step = {.action = SRV_SCHED_SLEEP, .wake_ms = INFINITY};
    bool any_watched = false, any_owed = false, interacting = false, any_busy = false;
    for (unsigned k = 0; k < s->view_count; k++) {
        const srv_sched_view *v = &s->views[k];
        any_busy |= v->busy;
        if (!v->watched) continue;
        any_watched = true;
        if (v->last_input_ms > s->last_tick_ms || s->now_ms - v->last_input_ms < s->still_delay_ms)
            interacting = true;
        if (!v->dirty) continue;
        double due = due_at(s, v);
        /* a view its own cap holds back lets the world tick without it */
        bool held_back = v->frame_interval_ms > s->frame_interval_ms && due > s->now_ms;
        if (v->behind_world && !held_back) any_owed = true;
        if (v->busy) continue; /* woken by its completion */
        if (due > s->now_ms) {
            if (due < step.wake_ms) step.wake_ms = due;
        } else if (!s->readback_free) {
            /* the ring is full: look again as soon as a copy may have finished */
            if (s->now_ms + 1 < step.wake_ms) step.wake_ms = s->now_ms + 1;
        }
    }
    int k = -1;
    if (s->readback_free && s->view_count) {
        /* 1. views that owe the world's last tick */
        k = pick(s, owes_tick);
        /* 2. a frame for a view's own input before the next tick (once per tick) */
        if (k < 0) k = pick(s, input_first);
    }
    if (k >= 0) {
        step.action = SRV_SCHED_RENDER_VIEW;
        step.view = (unsigned)k;
        return step;
    }
    /* 3. the world advances once every watched view has shown its last tick, and once no frame
     * is in flight: a tick waits for its GPU work, which queues behind those frames, and the
     * frames would reach the encoders only after it (measured on an H200 at 1080p: 5.7 ms of a
     * 7.5 ms render-to-encoder time was the tick waiting behind the view's frame) */
    if (any_watched && !any_owed && s->world_wants_update) {
        double due = s->last_tick_ms + s->frame_interval_ms;
        if (due <= s->now_ms && !any_busy) {
            step.action = SRV_SCHED_ADVANCE_WORLD;
            unsigned per_tick = SRV_SCHED_CONVERGE_UPDATES;
            if (s->update_ms > 0) {
                double fit = floor(s->frame_interval_ms / s->update_ms);
                if (fit < per_tick) per_tick = fit < 1 ? 1u : (unsigned)fit;
            }
            if (interacting) per_tick = 1;
            step.world_updates =
                s->world_updates_left < per_tick ? s->world_updates_left : per_tick;
            return step;
        }
        /* due but frames in flight: woken by their completion (the caller polls for it) */
        if (due > s->now_ms && due < step.wake_ms) step.wake_ms = due;
    } else if (s->readback_free && s->view_count) {
        /* 4. the world is still: views follow their input as fast as the cap allows */
        k = pick(s, any);
        if (k >= 0) {
            step.action = SRV_SCHED_RENDER_VIEW;
            step.view = (unsigned)k;
            return step;
        }
    }
    /* 5. still frames once input has stopped (never for a view that owes a frame anyway) */
    for (unsigned n = 0; n < s->view_count; n++) {
        unsigned i = (s->cursor + n) % s->view_count;
        const srv_sched_view *v = &s->views[i];
        if (!v->watched || v->dirty || v->busy || !v->need_still) continue;
        double due = v->last_input_ms + s->still_delay_ms;
        if (due <= s->now_ms && !s->readback_free) {
            /* the GPU JPEG path copies a still too: try again once a slot is free (leases end as
             * the encoders finish) */
            if (s->now_ms + 1 < step.wake_ms) step.wake_ms = s->now_ms + 1;
        } else if (due <= s->now_ms) {
            step.action = SRV_SCHED_EMIT_STILL;
            step.view = i;
            step.wake_ms = INFINITY;
            return step;
        }
        if (due < step.wake_ms) step.wake_ms = due;
    }
    return step;
}
