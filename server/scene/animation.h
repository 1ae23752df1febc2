/* animation.h: the demo animation — the first light circles its starting point, one turn per
 * 12 s, while someone watches (settings.animate). Plain CPU code on the scene state. */
#ifndef SRV_ANIMATION_H
#define SRV_ANIMATION_H

#include <stdbool.h>
#include <stdint.h>

#include "server/scene/scene_state.h"

typedef struct srv_animation {
    bool valid; /* the light and its circle are chosen */
    uint32_t light;
    float center[3], radius;
    double phase_s, last_ms;
} srv_animation;

/* Forgets the chosen light (a new scene, or the user edited or removed that light). */
void srv_animation_reset(srv_animation *a);
/* The clock stops (nobody watches, or animation off): no jump when it resumes. */
void srv_animation_pause(srv_animation *a);
/* Moves the animated light to its place at now_ms; false when the scene has no light. */
bool srv_animation_step(srv_animation *a, srv_scene_state *st, double now_ms);

#endif
