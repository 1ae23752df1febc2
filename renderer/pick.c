/* pick.c: one camera ray through a picture point (see pick.h). */
#include "renderer/pick.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "shaders/pick.spv.h"

rd_vk_result rd_pick_create(rd_vk *vk, rd_pick *p, char *err, size_t errlen)
{
    memset(p, 0, sizeof *p);
    p->vk = vk;
    rd_vk_result res = rd_pipeline_create(vk, &p->pipeline, "pick", pc_spv_pick, sizeof pc_spv_pick,
                                          sizeof(pc_push), err, errlen);
    if (res == RD_VK_OK)
        res = rd_buffer_create(vk, &p->globals, sizeof(pc_globals), RD_MEMORY_UPLOAD, err, errlen);
    if (res == RD_VK_OK)
        res = rd_buffer_create(vk, &p->result, sizeof(pc_pick_result), RD_MEMORY_READBACK, err,
                               errlen);
    if (res != RD_VK_OK) rd_pick_destroy(p);
    return res;
}

void rd_pick_destroy(rd_pick *p)
{
    if (!p->vk) return;
    rd_buffer_destroy(p->vk, &p->result);
    rd_buffer_destroy(p->vk, &p->globals);
    rd_pipeline_destroy(p->vk, &p->pipeline);
}

static uint32_t float_bits(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

rd_vk_result rd_pick_trace(rd_pick *p, const rd_world *w, const rd_view_camera *camera,
                           unsigned width, unsigned height, float x, float y, rd_pick_hit *out,
                           char *err, size_t errlen)
{
    memset(out, 0, sizeof *out);
    if (!w->scene) {
        snprintf(err, errlen, "picking in a world without a scene");
        return RD_VK_ERR_UNSUPPORTED;
    }
    if (!(x >= 0.0f && x <= 1.0f && y >= 0.0f && y <= 1.0f) || !width || !height) {
        snprintf(err, errlen, "pick point (%g, %g) of a %ux%u picture is outside it", (double)x,
                 (double)y, width, height);
        return RD_VK_ERR_UNSUPPORTED;
    }
    /* the globals a frame of this camera and size would have (view.c) */
    pc_globals g;
    memset(&g, 0, sizeof g);
    rd_world_fill_globals(w, &g);
    rd_world_fill_camera(w, camera, width, height, &g);
    memcpy(p->globals.mapped, &g, sizeof g);

    rd_cmd cmd;
    rd_vk_result res = rd_cmd_begin(p->vk, &cmd, err, errlen);
    if (res != RD_VK_OK) return res;
    pc_push push = {.globals = p->globals.address,
                    .buf0 = p->result.address,
                    .params = {float_bits(x), float_bits(y), 0, 0}};
    rd_cmd_dispatch(&cmd, &p->pipeline, &push, 1, 1, 1);
    rd_cmd_barrier(&cmd);
    res = rd_cmd_submit_wait(p->vk, &cmd, err, errlen);
    if (res != RD_VK_OK) return res;
    pc_pick_result r;
    res = rd_buffer_download(p->vk, &p->result, 0, &r, sizeof r, err, errlen);
    if (res != RD_VK_OK || r.info.x == 0) return res;
    out->hit = true;
    out->instance = r.info.y;
    out->tri = r.info.z;
    out->distance = r.position.w;
    const float pos[3] = {r.position.x, r.position.y, r.position.z};
    const float nrm[3] = {r.normal.x, r.normal.y, r.normal.z};
    for (int k = 0; k < 3; k++) {
        out->position[k] = pos[k] + w->scene->origin_shift[k];
        out->normal[k] = nrm[k];
    }
    return RD_VK_OK;
}
