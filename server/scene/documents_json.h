/* documents_json.h: the API's documents of one camera, light and node (protocol/openapi.yaml):
 * the bodies of GET /v1/camera, /v1/views/{id}/camera, /v1/lights/{id} and /v1/nodes/{id}, and
 * the members of the scene, lights and nodes documents the scene service publishes
 * (scene_documents.c). Numbers print as the floats they are (api_json.h's srv_json_float).
 * Builders return new cJSON trees the caller owns.
 */
#ifndef SRV_DOCUMENTS_JSON_H
#define SRV_DOCUMENTS_JSON_H

#include <cjson/cJSON.h>
#include <stdint.h>

#include "server/api/commands.h"
#include "renderer/scene/scene.h"

/* {"position", "target", "forward", "up", "orientation", "fov"} */
cJSON *srv_json_camera(const srv_camera *c);
cJSON *srv_json_light(uint32_t id, const rd_light *l);
cJSON *srv_json_node(uint32_t id, const rd_node *n);

#endif
