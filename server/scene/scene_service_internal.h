/* scene_service_internal.h: what the parts of the scene service share (scene_service.c applies
 * changes, scene_documents.c builds and publishes the API documents, scene_pose.c poses the
 * scene at its animation clock). Not for other modules: render thread only, like
 * scene_service.h. */
#ifndef SRV_SCENE_SERVICE_INTERNAL_H
#define SRV_SCENE_SERVICE_INTERNAL_H

#include "server/scene/documents_json.h"
#include "server/scene/scene_service.h"

/* ---- documents (scene_documents.c) ---------------------------------------------------------- */

/* The "nodes" member of the scene document (the first NODE_DOC_LIMIT nodes). */
cJSON *srv_scene_nodes_json(const rd_scene *s);
/* The scene document (GET /v1/scene). */
cJSON *srv_scene_json(const srv_scene_service *svc);
void srv_scene_publish_lights(srv_scene_service *svc, bool quiet);
/* Everything, after a new scene (or at start). */
void srv_scene_publish_scene(srv_scene_service *svc);
/* The probe part of the scene document, when the field's state changed (no event). */
void srv_scene_publish_probes(srv_scene_service *svc);

/* ---- changes (scene_service.c) -------------------------------------------------------------- */

/* The lighting changed: every probe wakes with its hysteresis lowered by age. */
void srv_scene_lighting_changed(srv_scene_service *svc, float age);
/* Grows lo..hi by the world box of mesh placed with world matrix m. */
void srv_scene_grow_by_mesh(const srv_scene_service *svc, uint32_t mesh, const float m[16],
                            float lo[3], float hi[3]);
void srv_scene_empty_box(float lo[3], float hi[3]);

/* ---- the scene's animations (scene_pose.c) -------------------------------------------------- */

/* Poses the scene at the clock's time; with wake, probes around what moved wake. *moved: some
 * instance or light moved. */
rd_vk_result srv_scene_pose(srv_scene_service *svc, bool wake, bool *moved, char *err,
                            size_t errlen);
/* A new scene: its animated nodes, the clock at 0 and the scene posed there. Before
 * srv_scene_publish_scene. */
void srv_scene_load_playback(srv_scene_service *svc);
/* PATCH /v1/animation; returns SRV_CHANGE_* bits. */
unsigned srv_scene_patch_playback(srv_scene_service *svc, srv_cmd *c);

#endif
