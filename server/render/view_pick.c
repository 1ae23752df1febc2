/* view_pick.c: the pick route's answer (see view_pick.h). */
#include "server/render/view_pick.h"

#include <stdio.h>

#include "server/api/api_json.h"
#include "server/base/log.h"

void srv_view_pick(rd_pick *pick, const srv_scene_service *svc, const srv_view *v, srv_cmd *c)
{
    if (svc->vk->device_lost) {
        srv_cmd_fail(c, 503, SRV_ERR_GPU, "The GPU device was lost; restart the server.");
        return;
    }
    rd_view_camera cam;
    srv_camera_to_view(&v->camera, &cam);
    rd_pick_hit hit;
    char err[256];
    rd_vk_result vr = rd_pick_trace(pick, &svc->world, &cam, v->width, v->height, c->pick[0],
                                    c->pick[1], &hit, err, sizeof err);
    if (vr != RD_VK_OK) {
        srv_error("render", "pick in view %u failed: %s", v->id, err);
        srv_cmd_fail(c, 500, SRV_ERR_GPU, err);
        return;
    }
    const rd_scene *s = &svc->st.scene;
    cJSON *j = cJSON_CreateObject();
    if (!hit.hit || hit.instance >= s->instance_count) {
        cJSON_AddFalseToObject(j, "hit");
        srv_cmd_complete_json(c, 200, j);
        return;
    }
    const rd_instance *in = &s->instances[hit.instance];
    const rd_node *node = &s->nodes[in->node];
    const rd_mesh *mesh = &s->meshes[in->mesh];
    cJSON_AddTrueToObject(j, "hit");
    cJSON_AddNumberToObject(j, "node", in->node);
    cJSON_AddStringToObject(j, "node_name", node->name ? node->name : "");
    cJSON_AddNumberToObject(j, "mesh", in->mesh);
    cJSON_AddStringToObject(j, "mesh_name", mesh->name ? mesh->name : "");
    cJSON_AddNumberToObject(j, "instance", hit.instance);
    cJSON_AddNumberToObject(j, "distance", srv_json_float(hit.distance));
    srv_json_add_floats(j, "position", hit.position, 3);
    srv_json_add_floats(j, "normal", hit.normal, 3);
    srv_cmd_complete_json(c, 200, j);
}
