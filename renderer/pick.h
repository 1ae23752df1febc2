/* pick.h: what lies under a point of a view's picture — one camera ray traced on the GPU by the
 * renderer's own trace routine (shaders/pick.comp: the primary pass's ray and culling), for
 * selecting objects by clicking the picture.
 *
 * An rd_pick owns its pipeline and two small buffers; rd_pick_trace records, submits and waits
 * for one dispatch of one invocation. It reads the world only. Render thread only (Vulkan).
 */
#ifndef RD_PICK_H
#define RD_PICK_H

#include <stdbool.h>

#include "renderer/scene/camera.h"
#include "renderer/vk/vk_buffer.h"
#include "renderer/vk/vk_compute.h"
#include "renderer/world.h"

typedef struct rd_pick {
    rd_vk *vk;
    rd_pipeline pipeline;
    rd_buffer globals, result;
} rd_pick;

typedef struct rd_pick_hit {
    bool hit;          /* false: the ray left the scene (nothing below is set) */
    uint32_t instance; /* index into the scene's instances (rd_scene.instances) */
    uint32_t tri;      /* triangle in the GPU scene's leaf order */
    float distance;    /* from the eye along the unit ray */
    float position[3]; /* world coordinates */
    float normal[3];   /* geometric normal, unit, facing the eye */
} rd_pick_hit;

rd_vk_result rd_pick_create(rd_vk *vk, rd_pick *p, char *err, size_t errlen);
void rd_pick_destroy(rd_pick *p); /* idempotent */

/* Traces the camera ray through the picture point (x, y) (normalised: 0..1 across, 0..1 down)
 * of a width x height picture of camera, in w (which needs a scene). Blocking. x and y outside
 * [0, 1] are refused with RD_VK_ERR_UNSUPPORTED. */
rd_vk_result rd_pick_trace(rd_pick *p, const rd_world *w, const rd_view_camera *camera,
                           unsigned width, unsigned height, float x, float y, rd_pick_hit *out,
                           char *err, size_t errlen);

#endif
