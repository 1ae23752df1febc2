/* animation.c: the demo's circling light. */
#include "server/scene/animation.h"

#include <math.h>
#include <string.h>

#define ANIM_PERIOD_S 12.0

void srv_animation_reset(srv_animation *a)
{
    a->valid = false;
}

void srv_animation_pause(srv_animation *a)
{
    a->last_ms = 0;
}

bool srv_animation_step(srv_animation *a, srv_scene_state *st, double now_ms)
{
    if (!a->valid || srv_state_light_index(st, a->light) < 0) {
        if (st->scene.light_count == 0) return false;
        a->light = st->light_ids[0];
        memcpy(a->center, st->scene.lights[0].position, sizeof a->center);
        float ex = st->scene.bounds_max[0] - st->scene.bounds_min[0];
        float ez = st->scene.bounds_max[2] - st->scene.bounds_min[2];
        a->radius = 0.25f * (ex < ez ? ex : ez);
        a->phase_s = 0;
        a->valid = true;
    }
    double dt = a->last_ms > 0 ? (now_ms - a->last_ms) / 1000.0 : 0;
    a->last_ms = now_ms;
    a->phase_s += dt < 0.1 ? dt : 0.1;
    rd_light *light = &st->scene.lights[srv_state_light_index(st, a->light)];
    double ang = 2 * M_PI * a->phase_s / ANIM_PERIOD_S;
    light->node = -1;
    light->position[0] = a->center[0] + a->radius * (float)(cos(ang) - 1.0);
    light->position[1] = a->center[1];
    light->position[2] = a->center[2] + a->radius * (float)sin(ang);
    return true;
}
