/* animation_clip.h: sampling a scene's node animations (rd_scene.animations, from glTF 2.0).
 *
 * (server/scene/animation.h is something else: the daemon's demo light motion.)
 */
#ifndef RD_ANIMATION_CLIP_H
#define RD_ANIMATION_CLIP_H

#include <stdbool.h>

#include "renderer/scene/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Poses every animated node at time t seconds (TRS and morph weights): each animation loops over
 * its own duration (local time = t mod duration, so t = duration shows the pose at 0; negative t
 * counts back from the end; an animation of duration 0 is sampled at 0). Before a sampler's first
 * key it holds the first value, after its last key the last value. Animations apply in order (a
 * later one wins on the same target). Writes the nodes' translation, rotation (unit quaternion),
 * scale and weights (a weights channel whose value count is not the node's weight count is skipped)
 * only, never NaN or infinity (a sample that would not be finite leaves the node's value as it
 * was); a non-finite t counts as 0. Channels with an out-of-range node or sampler are skipped. The
 * caller runs rd_scene_update afterwards. */
void rd_scene_animate(rd_scene *s, double t);

/* Longest animation duration in seconds, 0 when the scene has no animation. */
double rd_scene_animation_duration(const rd_scene *s);

/* out[node_count]: true for every node a TRS channel moves and for all their descendants (the
 * nodes whose world matrix can change over time), false for the rest. */
void rd_scene_animated_nodes(const rd_scene *s, bool *out);

/* One sampler at local time t (seconds, no looping; NaN counts as before the first key):
 * writes sampler->components floats (at most RD_ANIM_MAX_COMPONENTS) to out and returns true, or
 * returns false (out untouched) when the result would not be finite, which only non-finite keys or
 * overflowing tangents cause. With rotation the result is a unit quaternion (identity when
 * degenerate). */
bool rd_anim_sampler_eval(const rd_anim_sampler *sampler, bool rotation, double t, float *out);

#ifdef __cplusplus
}
#endif

#endif
