/* api_json.h: the API's JSON bodies (protocol/openapi.yaml) parsed into commands.h types, the
 * typed field readers they are made of, and the number printing every document shares (the
 * settings document: srv_json_settings_patch and srv_json_settings in settings.h; documents of
 * the scene's camera, lights and nodes: server/scene/documents_json.h; the stream's viewer
 * messages: server/stream/viewer_msg.h, built on the readers here).
 *
 * Parsers are strict: a body must be one JSON object; every member must be known, of the
 * right type, finite and in range; otherwise they fail with a 400 srv_api_error whose message
 * names the field. They only type-check: what depends on the current scene (an unknown light
 * id, a target equal to the position) is checked where the patch is applied (scene_state.h).
 */
#ifndef SRV_API_JSON_H
#define SRV_API_JSON_H

#include <cjson/cJSON.h>
#include <stddef.h>

#include "server/api/api_error.h"
#include "server/api/commands.h"

/* Longest JSON body accepted. */
#define SRV_JSON_BODY_MAX (64 * 1024)

/* Parses len bytes as exactly one JSON object (trailing whitespace only). */
cJSON *srv_json_parse_object(const char *text, size_t len, srv_api_error *e);

/* Typed field readers: it is a member of an object (it->string names it in the message of the
 * 400 they fail with). A number must be finite and in [lo, hi]. */
bool srv_json_get_number(const cJSON *it, double lo, double hi, double *out, srv_api_error *e);
bool srv_json_get_float(const cJSON *it, double lo, double hi, float *out, srv_api_error *e);
/* Each field may appear once: cJSON keeps duplicate keys, so they are caught here (bit is the
 * field's bit in *has, which collects the fields seen). */
bool srv_json_once(unsigned *has, unsigned bit, const cJSON *it, srv_api_error *e);
/* Reads one camera member into p; *known = false when the name is not a camera field (a camera
 * message of the stream carries other members beside them). */
bool srv_json_camera_member(const cJSON *it, srv_camera_patch *p, bool *known, srv_api_error *e);
/* After the members: at most one of target, forward and orientation; not orientation and up. */
bool srv_json_camera_consistent(const srv_camera_patch *p, srv_api_error *e);

bool srv_json_camera_patch(const cJSON *obj, srv_camera_patch *out, srv_api_error *e);
bool srv_json_light_patch(const cJSON *obj, srv_light_patch *out, srv_api_error *e);
bool srv_json_node_patch(const cJSON *obj, srv_node_patch *out, srv_api_error *e);
/* PATCH /v1/animation: {"playing": bool, "time": seconds >= 0}, at least one. */
bool srv_json_playback_patch(const cJSON *obj, srv_playback_patch *out, srv_api_error *e);
/* POST /v1/views/{id}/pick: {"x", "y"}, both required, each in [0, 1] (normalised picture
 * coordinates, y down). */
bool srv_json_pick_request(const cJSON *obj, float point[2], srv_api_error *e);

/* Prints j compactly (malloc'd text) and deletes it. */
char *srv_json_print_delete(cJSON *j);
/* Adds an array of n floats (printed with float precision) to obj. */
void srv_json_add_floats(cJSON *obj, const char *name, const float *v, int n);
/* A float as the double that prints like the float ("0.97", not "0.97000002861022949"). */
double srv_json_float(float f);

/* Names of enumerations as the API spells them (settings: settings.h). */
const char *srv_light_type_name(uint32_t type);

#endif
