#include "renderer/scene/camera.h"

#include <math.h>
#include <stdio.h>

#include "renderer/scene/xform.h"

void rd_camera_frame_bounds(const float bmin[3], const float bmax[3], float yfov,
                            rd_view_camera *out)
{
    float center[3], ext[3];
    for (int k = 0; k < 3; k++) {
        center[k] = 0.5f * (bmin[k] + bmax[k]);
        ext[k] = bmax[k] - bmin[k];
    }
    float radius = 0.5f * rd_vec3_length(ext);
    if (!(radius > 0) || !isfinite(radius)) radius = 1.0f;
    const float view_dir[3] = {-0.45f, -0.35f, -1.0f}; /* from front-right-above */
    float fwd[3];
    rd_vec3_normalize(fwd, view_dir, NULL);
    float dist = radius / sinf(0.5f * yfov) * 1.05f;
    for (int k = 0; k < 3; k++) out->eye[k] = center[k] - fwd[k] * dist;
    rd_vec3_set(out->forward, fwd[0], fwd[1], fwd[2]);
    rd_vec3_set(out->up, 0, 1, 0);
    out->yfov = yfov;
}

bool rd_camera_for_scene(const rd_scene *s, int index, rd_view_camera *out, char *err,
                         size_t errlen)
{
    if (index >= 0 && (unsigned)index >= s->camera_count) {
        snprintf(err, errlen, "camera %d does not exist (the scene has %u camera%s)", index,
                 s->camera_count, s->camera_count == 1 ? "" : "s");
        return false;
    }
    if (s->camera_count == 0) {
        rd_camera_frame_bounds(s->bounds_min, s->bounds_max, 50.0f * (float)M_PI / 180.0f, out);
        return true;
    }
    const rd_camera *c = &s->cameras[index < 0 ? 0 : index];
    const float fz[3] = {0, 0, -1}, fy[3] = {0, 1, 0};
    for (int k = 0; k < 3; k++) out->eye[k] = c->position[k];
    rd_vec3_normalize(out->forward, c->forward, fz);
    rd_vec3_normalize(out->up, c->up, fy);
    out->yfov = c->yfov > 0 && c->yfov < (float)M_PI ? c->yfov : 50.0f * (float)M_PI / 180.0f;
    return true;
}

void rd_camera_to_view(const rd_view_camera *c, unsigned width, unsigned height, pc_view *v)
{
    float fwd[3], right[3], up[3];
    const float fz[3] = {0, 0, -1}, fx[3] = {1, 0, 0};
    rd_vec3_normalize(fwd, c->forward, fz);
    rd_vec3_cross(right, fwd, c->up);
    if (!rd_vec3_normalize(right, right, NULL)) { /* up parallel to forward */
        const float alt[3] = {fabsf(fwd[1]) < 0.9f ? 0.0f : 1.0f, fabsf(fwd[1]) < 0.9f ? 1.0f : 0.0f, 0};
        rd_vec3_cross(right, fwd, alt);
        rd_vec3_normalize(right, right, fx);
    }
    rd_vec3_cross(up, right, fwd);
    float ty = tanf(0.5f * c->yfov);
    float tx = ty * (float)width / (float)(height ? height : 1);
    v->eye = (pc_vec4){c->eye[0], c->eye[1], c->eye[2], 0};
    v->forward = (pc_vec4){fwd[0], fwd[1], fwd[2], 0};
    v->right = (pc_vec4){right[0] * tx, right[1] * tx, right[2] * tx, 0};
    v->up = (pc_vec4){up[0] * ty, up[1] * ty, up[2] * ty, 0};
}
