/* Scheduler policy without a GPU: fairness, pacing (global and per view), one world tick per
 * round, idling. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "server/render/scheduler.h"
#include "test_util.h"

static srv_sched_state base(srv_sched_view *views, unsigned n)
{
    return (srv_sched_state){
        .now_ms = 1000,
        .frame_interval_ms = 10,
        .still_delay_ms = 150,
        .last_tick_ms = -1e9,
        .readback_free = true,
        .views = views,
        .view_count = n,
    };
}

static srv_sched_view view(bool watched, bool dirty)
{
    return (srv_sched_view){
        .watched = watched, .dirty = dirty, .last_render_ms = -1e9, .last_input_ms = -1e9};
}

/* Runs the policy like the render thread does: renders clear dirty, a tick dirties every view. */
static srv_sched_step run(srv_sched_state *s, srv_sched_view *v)
{
    srv_sched_step st = srv_sched_next(s);
    if (st.action == SRV_SCHED_RENDER_VIEW) {
        v[st.view].dirty = v[st.view].behind_world = false;
        v[st.view].renders_since_tick++;
        v[st.view].last_render_ms = s->now_ms;
        s->cursor = (st.view + 1) % s->view_count;
    } else if (st.action == SRV_SCHED_ADVANCE_WORLD) {
        s->last_tick_ms = s->now_ms;
        s->world_updates_left -= st.world_updates;
        if (!s->world_updates_left) s->world_wants_update = false;
        for (unsigned k = 0; k < s->view_count; k++)
            v[k].dirty = v[k].behind_world = true;
    } else if (st.action == SRV_SCHED_EMIT_STILL) {
        v[st.view].need_still = false;
    }
    return st;
}

static void test_idle(void)
{
    srv_sched_view v[2] = {view(true, false), view(false, false)};
    srv_sched_state s = base(v, 2);
    srv_sched_step st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_SLEEP && isinf(st.wake_ms),
           "idle and converged: sleep until woken");
    /* the world wants to converge but nobody watches: still nothing */
    v[0].watched = false;
    s.world_wants_update = true;
    s.world_updates_left = 10;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_SLEEP && isinf(st.wake_ms), "nobody watching: no world work");
    /* an unwatched dirty view is not rendered */
    v[1].dirty = true;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_SLEEP, "unwatched dirty view not rendered");
}

static void test_round_robin(void)
{
    srv_sched_view v[4];
    for (int k = 0; k < 4; k++)
        v[k] = view(true, true);
    srv_sched_state s = base(v, 4);
    s.cursor = 2;
    unsigned order[4], renders[4] = {0};
    for (int i = 0; i < 4; i++) {
        srv_sched_step st = run(&s, v);
        CHECKF(st.action == SRV_SCHED_RENDER_VIEW, "dirty views are rendered (step %d)", i);
        order[i] = st.view;
        renders[st.view]++;
    }
    CHECKF(order[0] == 2 && order[1] == 3 && order[2] == 0 && order[3] == 1,
           "round robin from the cursor: %u %u %u %u", order[0], order[1], order[2], order[3]);
    for (int k = 0; k < 4; k++)
        CHECKF(renders[k] == 1, "view %d rendered once", k);
    /* a view that keeps moving does not starve the others */
    memset(renders, 0, sizeof renders);
    for (int i = 0; i < 40; i++) {
        s.now_ms += 3;
        v[0].dirty = true; /* view 0 gets input all the time */
        if (i % 5 == 0) v[1].dirty = v[2].dirty = v[3].dirty = true;
        srv_sched_step st = run(&s, v);
        if (st.action == SRV_SCHED_RENDER_VIEW) renders[st.view]++;
    }
    for (int k = 1; k < 4; k++)
        CHECKF(renders[k] >= 7, "view %d got %u frames beside a busy view 0", k, renders[k]);
}

static void test_pacing(void)
{
    srv_sched_view v[1] = {view(true, true)};
    srv_sched_state s = base(v, 1);
    v[0].last_render_ms = s.now_ms - 4;
    srv_sched_step st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_SLEEP && fabs(st.wake_ms - (s.now_ms + 6)) < 1e-9,
           "frame cap: sleep until the view is due (wake %.1f)", st.wake_ms);
    s.now_ms += 6;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_RENDER_VIEW, "due view rendered");
    s.readback_free = false;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_SLEEP && st.wake_ms <= s.now_ms + 1,
           "full readback ring: look again soon");
    /* a view whose last frame is still on the GPU is neither rendered nor given a still */
    s.readback_free = true;
    v[0].busy = true;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_SLEEP, "busy view not rendered");
    v[0].dirty = false;
    v[0].need_still = true;
    v[0].last_input_ms = s.now_ms - 1000;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_SLEEP, "busy view gets no still yet");
    v[0].busy = false;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_EMIT_STILL, "its still once the frame is back");
}

/* With N watched views the world advances once per round of N renders. */
static void ticks_per_round(unsigned n)
{
    srv_sched_view v[8];
    for (unsigned k = 0; k < n; k++)
        v[k] = view(true, false);
    srv_sched_state s = base(v, n);
    s.world_wants_update = true;
    s.world_updates_left = 1000;
    unsigned ticks = 0, renders = 0;
    for (int i = 0; i < 200; i++) {
        s.now_ms += 1;
        srv_sched_step st = run(&s, v);
        if (st.action == SRV_SCHED_ADVANCE_WORLD) {
            ticks++;
            CHECKF(st.world_updates == SRV_SCHED_CONVERGE_UPDATES, "no input: %u updates per tick",
                   st.world_updates);
        }
        if (st.action == SRV_SCHED_RENDER_VIEW) renders++;
    }
    CHECKF(ticks > 0, "%u views: the world advanced", n);
    CHECKF(renders >= (ticks - 1) * n && renders <= ticks * n,
           "%u views: the world advances once per round (%u renders, %u ticks)", n, renders, ticks);
}

static void test_world(void)
{
    ticks_per_round(1);
    ticks_per_round(5);
    /* the tick is paced by the frame interval too */
    srv_sched_view v[1] = {view(true, false)};
    srv_sched_state s = base(v, 1);
    s.world_wants_update = true;
    s.world_updates_left = 2;
    s.last_tick_ms = s.now_ms - 3;
    srv_sched_step st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_SLEEP && fabs(st.wake_ms - (s.last_tick_ms + 10)) < 1e-9,
           "tick paced by the frame interval");
    s.now_ms += 7;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_ADVANCE_WORLD && st.world_updates == 2,
           "the last updates: only what is left (%u)", st.world_updates);
    /* slow updates (a CPU device): a tick holds no more than a frame interval of them */
    s.world_updates_left = 100;
    s.update_ms = 4;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_ADVANCE_WORLD && st.world_updates == 2,
           "10 ms frames, 4 ms updates: %u per tick", st.world_updates);
    s.update_ms = 400;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_ADVANCE_WORLD && st.world_updates == 1,
           "updates slower than a frame: %u per tick", st.world_updates);
    s.update_ms = 0;
    /* input keeps a tick to one update */
    s.world_updates_left = 100;
    v[0].last_input_ms = s.now_ms - 20;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_ADVANCE_WORLD && st.world_updates == 1,
           "recent input: one update per tick");
    /* a view dirty from its own camera does not hold the world back */
    v[0].dirty = true;
    v[0].last_render_ms = s.now_ms - 1;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_ADVANCE_WORLD, "camera-dirty view does not block the tick");
    /* ... but, once due, its input is answered before the tick: once per tick */
    v[0].last_render_ms = s.now_ms - 10;
    v[0].renders_since_tick = 1;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_RENDER_VIEW, "input answered before the next tick");
    v[0].renders_since_tick = 2;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_ADVANCE_WORLD, "one input frame per tick, then the tick");
    /* a view that has not shown the last tick does */
    v[0].behind_world = true;
    v[0].last_render_ms = s.now_ms - 1;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_SLEEP, "a view behind the world blocks the next tick");
    /* the world at rest: a dirty view renders as fast as the cap allows */
    s.world_wants_update = false;
    v[0].behind_world = false;
    v[0].renders_since_tick = 50;
    v[0].last_render_ms = s.now_ms - 10;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_RENDER_VIEW, "still world: views follow their input");
}

/* Views kept dirty by their own cameras all the time do not starve the world, and every tick
 * is shown by every view before the next one. */
static void test_world_not_starved(void)
{
    srv_sched_view v[3];
    for (int k = 0; k < 3; k++)
        v[k] = view(true, true);
    srv_sched_state s = base(v, 3);
    s.world_wants_update = true;
    s.world_updates_left = 1000000;
    unsigned ticks = 0, shown[3] = {0};
    bool ok = true;
    for (int i = 0; i < 300; i++) {
        s.now_ms += 2;
        for (int k = 0; k < 3; k++) {
            v[k].dirty = true; /* camera input before every step */
            v[k].last_input_ms = s.now_ms;
        }
        srv_sched_step st = run(&s, v);
        if (st.action == SRV_SCHED_ADVANCE_WORLD) {
            for (int k = 0; k < 3; k++)
                ok &= ticks == 0 || shown[k] == ticks;
            ticks++;
        } else if (st.action == SRV_SCHED_RENDER_VIEW && v[st.view].last_render_ms == s.now_ms &&
                   shown[st.view] < ticks) {
            shown[st.view]++;
        }
    }
    CHECKF(ticks >= 20, "%u world ticks in 600 ms of constant camera input", ticks);
    CHECKF(ok, "every view showed each tick before the next");
}

/* A view with its own frame-rate cap (a viewer's quality message) is rendered at that rate
 * while an uncapped view beside it runs at the global cap, with or without world ticks, and the
 * capped view does not hold the world back. */
static void own_cap(bool world)
{
    srv_sched_view v[2] = {view(true, true), view(true, true)};
    v[0].frame_interval_ms = 100; /* 10 fps; the global cap is 100 fps */
    srv_sched_state s = base(v, 2);
    s.world_wants_update = world;
    s.world_updates_left = world ? 1000000 : 0;
    unsigned renders[2] = {0}, ticks = 0;
    double last0 = -1e9, min_gap0 = 1e9;
    for (int i = 0; i < 1000; i++) { /* one second, a step per millisecond */
        s.now_ms += 1;
        for (int k = 0; k < 2; k++) {
            v[k].dirty = true; /* both cameras move all the time */
            v[k].last_input_ms = s.now_ms;
        }
        srv_sched_step st = run(&s, v);
        if (st.action == SRV_SCHED_ADVANCE_WORLD) ticks++;
        if (st.action != SRV_SCHED_RENDER_VIEW) continue;
        renders[st.view]++;
        if (st.view == 0) {
            if (s.now_ms - last0 < min_gap0) min_gap0 = s.now_ms - last0;
            last0 = s.now_ms;
        }
    }
    CHECKF(renders[0] >= 9 && renders[0] <= 11, "world %d: capped view: %u frames in 1 s (10)",
           world, renders[0]);
    CHECKF(min_gap0 >= 100 - 1e-9, "world %d: capped view frames %.0f ms apart at least", world,
           min_gap0);
    CHECKF(renders[1] >= 90, "world %d: the other view keeps the global rate: %u frames", world,
           renders[1]);
    if (world)
        CHECKF(ticks >= 45, "the capped view does not hold the world back: %u ticks", ticks);
}

static void test_own_cap(void)
{
    own_cap(false);
    own_cap(true);
    /* the sleep deadline is the view's own due time */
    srv_sched_view v[1] = {view(true, true)};
    v[0].frame_interval_ms = 50;
    srv_sched_state s = base(v, 1);
    v[0].last_render_ms = s.now_ms - 20;
    srv_sched_step st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_SLEEP && fabs(st.wake_ms - (s.now_ms + 30)) < 1e-9,
           "own cap: sleep until the view is due (wake %.1f)", st.wake_ms);
    /* an own cap looser than the global one changes nothing */
    v[0].frame_interval_ms = 5;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_RENDER_VIEW, "a 200 fps own cap under a 100 fps global one");
    v[0].last_render_ms = s.now_ms - 7;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_SLEEP && fabs(st.wake_ms - (s.now_ms + 3)) < 1e-9,
           "the global cap still applies (wake %.1f)", st.wake_ms);
    /* a capped view behind the world that is due holds the tick until it has shown it */
    v[0].frame_interval_ms = 50;
    v[0].behind_world = true;
    v[0].busy = true;
    v[0].last_render_ms = s.now_ms - 60;
    s.world_wants_update = true;
    s.world_updates_left = 10;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_SLEEP, "a due capped view still owes the tick");
    v[0].last_render_ms = s.now_ms - 20;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_SLEEP, "no tick while its frame is in flight");
    v[0].busy = false;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_ADVANCE_WORLD, "one held back by its cap does not owe it");
}

/* A tick waits for the frames in flight: they reach the encoders first, and the tick's own
 * GPU work does not queue behind them while the render thread waits. */
static void test_tick_after_frames(void)
{
    srv_sched_view v[2] = {view(true, false), view(true, false)};
    srv_sched_state s = base(v, 2);
    s.world_wants_update = true;
    s.world_updates_left = 10;
    v[1].busy = true; /* its frame (for its own input) is on the GPU */
    srv_sched_step st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_SLEEP && isinf(st.wake_ms),
           "tick due, frame in flight: wait for its completion");
    v[1].busy = false;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_ADVANCE_WORLD, "the tick once the frame is back");
    /* an unwatched view's frame in flight counts too (it is on the same queue) */
    v[0].watched = false;
    v[0].busy = true;
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_SLEEP, "any frame in flight defers the tick");
}

static void test_still(void)
{
    srv_sched_view v[2] = {view(true, false), view(true, false)};
    srv_sched_state s = base(v, 2);
    v[1].need_still = true;
    v[1].last_input_ms = s.now_ms - 100;
    srv_sched_step st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_SLEEP && fabs(st.wake_ms - (s.now_ms + 50)) < 1e-9,
           "still due 150 ms after the last input");
    s.now_ms += 50;
    st = run(&s, v);
    CHECKF(st.action == SRV_SCHED_EMIT_STILL && st.view == 1, "still frame for view 1");
    st = srv_sched_next(&s);
    CHECKF(st.action == SRV_SCHED_SLEEP && isinf(st.wake_ms), "after the still: idle");
}

int main(void)
{
    test_idle();
    test_round_robin();
    test_pacing();
    test_world();
    test_world_not_starved();
    test_own_cap();
    test_still();
    test_tick_after_frames();
    return test_finish();
}
