/* documents_json.c: one camera, light or node as the API's JSON document. See
 * documents_json.h. */
#include "server/scene/documents_json.h"

#include "server/api/api_json.h"
#include "renderer/scene/xform.h"

/* Quaternion (x, y, z, w) of the rotation whose columns are the camera axes. */
static void basis_to_quat(const float fwd[3], const float up[3], float q[4])
{
    float z[3] = {-fwd[0], -fwd[1], -fwd[2]};
    float x[3] = {up[1] * z[2] - up[2] * z[1], up[2] * z[0] - up[0] * z[2],
                  up[0] * z[1] - up[1] * z[0]};
    const float cols[3][3] = {{x[0], x[1], x[2]}, {up[0], up[1], up[2]}, {z[0], z[1], z[2]}};
    rd_mat3_cols_to_quat(cols, q);
}

cJSON *srv_json_camera(const srv_camera *c)
{
    cJSON *j = cJSON_CreateObject();
    float target[3], q[4];
    for (int i = 0; i < 3; i++)
        target[i] = c->position[i] + c->forward[i] * c->target_distance;
    basis_to_quat(c->forward, c->up, q);
    srv_json_add_floats(j, "position", c->position, 3);
    srv_json_add_floats(j, "target", target, 3);
    srv_json_add_floats(j, "forward", c->forward, 3);
    srv_json_add_floats(j, "up", c->up, 3);
    srv_json_add_floats(j, "orientation", q, 4);
    cJSON_AddNumberToObject(j, "fov", srv_json_float(c->fov_deg));
    return j;
}

cJSON *srv_json_light(uint32_t id, const rd_light *l)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddNumberToObject(j, "id", id);
    cJSON_AddStringToObject(j, "name", l->name ? l->name : "");
    cJSON_AddStringToObject(j, "type", srv_light_type_name(l->type));
    srv_json_add_floats(j, "color", l->color, 3);
    cJSON_AddNumberToObject(j, "intensity", srv_json_float(l->intensity));
    srv_json_add_floats(j, "position", l->position, 3);
    srv_json_add_floats(j, "direction", l->direction, 3);
    cJSON_AddNumberToObject(j, "range", srv_json_float(l->range));
    cJSON_AddNumberToObject(j, "inner_cone_angle", srv_json_float(l->inner_cone));
    cJSON_AddNumberToObject(j, "outer_cone_angle", srv_json_float(l->outer_cone));
    cJSON_AddNumberToObject(j, "node", l->node);
    return j;
}

cJSON *srv_json_node(uint32_t id, const rd_node *n)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddNumberToObject(j, "id", id);
    cJSON_AddStringToObject(j, "name", n->name ? n->name : "");
    cJSON_AddNumberToObject(j, "parent", n->parent);
    cJSON_AddNumberToObject(j, "mesh", n->mesh);
    cJSON_AddNumberToObject(j, "skin", n->skin ? (double)n->skin - 1 : -1.0);
    srv_json_add_floats(j, "translation", n->translation, 3);
    srv_json_add_floats(j, "rotation", n->rotation, 4);
    srv_json_add_floats(j, "scale", n->scale, 3);
    float wt[3] = {n->world[12], n->world[13], n->world[14]};
    srv_json_add_floats(j, "world_translation", wt, 3);
    return j;
}
