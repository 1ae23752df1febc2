/* scheduler.h: what the render thread does next — plain policy, no GPU, unit-tested.
 *
 * A tick advances the shared world once (probe updates, the demo animation) and then every
 * watched view shows it once. Views nobody watches are never rendered, and nobody watching means
 * no world work either. In order:
 *   1. A watched view that owes a frame of the world's last tick and is due under the
 *      frame-rate cap is rendered; among several, in turn (round robin from the one after the
 *      last rendered), so no view starves.
 *   2. A watched view dirty from its own input (its camera moved) gets one frame of its own
 *      between two ticks, so input is answered without waiting for the next world update.
 *   3. When no watched view owes the last tick, the world wants to change (probes converging,
 *      animation) and a tick period has passed, the world advances — once per tick whatever the
 *      number of views; with one probe update while someone interacts, else a few.
 *   4. When the world is still, dirty views are rendered in turn as fast as the cap allows.
 *   5. A watched view whose input stopped still_delay_ms ago gets its still frame (the last image
 *      re-encoded at full quality), once a readback slot is free (the GPU JPEG path copies it).
 *   6. Otherwise sleep until the earliest deadline among those rules, or until woken.
 *
 * Each view is paced by the global frame-rate cap and by its own (a viewer's quality message),
 * whichever is slower. A view that its own cap holds back does not hold back the world: the
 * world ticks for the others and the slow view shows the newest tick when its turn comes.
 */
#ifndef SRV_SCHEDULER_H
#define SRV_SCHEDULER_H

#include <stdbool.h>

typedef struct srv_sched_view {
    bool watched;                /* a connection shows it, or a frame request waits for it */
    bool dirty;                  /* it owes a frame */
    bool behind_world;           /* it has not shown the world's last tick yet (implies dirty) */
    bool need_still;             /* its last frame was interactive */
    unsigned renders_since_tick; /* frames of it since the world last advanced */
    bool busy;                   /* its last frame is still on the GPU: not renderable yet */
    double last_render_ms;
    double last_input_ms;
    double frame_interval_ms; /* its own cap (its viewer's max_fps), 0: only the global one */
} srv_sched_view;

typedef struct srv_sched_state {
    double now_ms;
    double frame_interval_ms; /* 1000 / max_fps */
    double still_delay_ms;
    bool world_wants_update;     /* probes converging or animation running */
    unsigned world_updates_left; /* probe updates still wanted (0: only the animation moves) */
    double update_ms;            /* measured wall time of one probe update (0: not known yet) */
    double last_tick_ms;         /* when the world last advanced */
    bool readback_free;          /* a frame can be handed to the readback ring now */
    const srv_sched_view *views;
    unsigned view_count;
    unsigned cursor; /* round robin: the index to look at first */
} srv_sched_state;

typedef enum srv_sched_action {
    SRV_SCHED_SLEEP = 0,
    SRV_SCHED_ADVANCE_WORLD,
    SRV_SCHED_RENDER_VIEW,
    SRV_SCHED_EMIT_STILL,
} srv_sched_action;

/* A busy view's frame is in flight; the caller polls for its completion, which makes the view
 * renderable again (no wake-up deadline is given for it). The world does not tick while any
 * frame is in flight. */

/* Probe updates per tick while the probes converge and no input arrives: the field settles in a
 * quarter of the ticks. Fewer when the updates would hold a tick longer than a frame interval (a
 * CPU device), and one only while someone interacts, so their next frame is not delayed. */
#define SRV_SCHED_CONVERGE_UPDATES 4u

typedef struct srv_sched_step {
    srv_sched_action action;
    unsigned view;          /* RENDER_VIEW, EMIT_STILL: index into views */
    unsigned world_updates; /* ADVANCE_WORLD: probe updates to run (0: move only) */
    double wake_ms;         /* SLEEP: when to look again (INFINITY: only when woken) */
} srv_sched_step;

srv_sched_step srv_sched_next(const srv_sched_state *s);

#endif
