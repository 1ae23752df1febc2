/* camera.h: the camera a frame is rendered from, and how it is chosen for a scene. */
#ifndef RD_CAMERA_H
#define RD_CAMERA_H

#include <stdbool.h>
#include <stddef.h>

#include "shaders/gpu_types.h"
#include "renderer/scene/scene.h"

typedef struct rd_view_camera {
    float eye[3];
    float forward[3]; /* unit */
    float up[3];      /* unit, roughly orthogonal to forward */
    float yfov;       /* radians */
} rd_view_camera;

/* A camera looking at the centre of the scene bounds from the front-right-above, far enough
 * for the bounding sphere to fit the vertical field of view. */
void rd_camera_frame_bounds(const float bmin[3], const float bmax[3], float yfov,
                            rd_view_camera *out);
/* Camera index of the scene, or (index < 0) its first camera, or a framing camera when the
 * scene has none. Returns false with a message when index names no camera. */
bool rd_camera_for_scene(const rd_scene *s, int index, rd_view_camera *out, char *err,
                         size_t errlen);
/* Fills the camera part of pc_view (eye, basis scaled by the field of view and aspect). */
void rd_camera_to_view(const rd_view_camera *c, unsigned width, unsigned height, pc_view *v);

#endif
