/* view_pick.h: POST /v1/views/{id}/pick on the render thread — the node under a point of a
 * view's picture, found by tracing one camera ray on the GPU (renderer/pick.h) and mapping the
 * instance it hits back to the glTF node that places it (the id PATCH /v1/nodes/{id} takes).
 * Render thread only.
 */
#ifndef SRV_VIEW_PICK_H
#define SRV_VIEW_PICK_H

#include "server/api/commands.h"
#include "renderer/pick.h"
#include "server/scene/scene_service.h"
#include "server/render/views.h"

/* Answers c (SRV_CMD_PICK for view v): 200 {"hit": false} or {"hit": true, "node",
 * "node_name", "mesh", "mesh_name", "instance", "distance", "position", "normal"}; 503 when
 * the GPU is lost, 500 when tracing failed. */
void srv_view_pick(rd_pick *pick, const srv_scene_service *svc, const srv_view *v, srv_cmd *c);

#endif
