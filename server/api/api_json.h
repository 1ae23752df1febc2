/* api_json.h: the API's JSON documents (protocol/openapi.yaml) to and from commands.h types
 * (the settings document: srv_json_settings_patch and srv_json_settings in settings.h).
 *
 * Parsers are strict: a body must be one JSON object; every member must be known, of the
 * right type, finite and in range; otherwise they fail with a 400 srv_api_error whose message
 * names the field. They only type-check: what depends on the current scene (an unknown light
 * id, a target equal to the position) is checked where the patch is applied (scene_state.h).
 * Builders return new cJSON trees the caller owns.
 */
#ifndef SRV_API_JSON_H
#define SRV_API_JSON_H

#include <cjson/cJSON.h>
#include <stddef.h>

#include "server/api/api_error.h"
#include "server/api/commands.h"

/* Longest JSON body or viewer message accepted. */
#define SRV_JSON_BODY_MAX (64 * 1024)
#define SRV_VIEWER_MSG_MAX 4096

/* Parses len bytes as exactly one JSON object (trailing whitespace only). */
cJSON *srv_json_parse_object(const char *text, size_t len, srv_api_error *e);

bool srv_json_camera_patch(const cJSON *obj, srv_camera_patch *out, srv_api_error *e);
bool srv_json_light_patch(const cJSON *obj, srv_light_patch *out, srv_api_error *e);
bool srv_json_node_patch(const cJSON *obj, srv_node_patch *out, srv_api_error *e);
/* PATCH /v1/animation: {"playing": bool, "time": seconds >= 0}, at least one. */
bool srv_json_playback_patch(const cJSON *obj, srv_playback_patch *out, srv_api_error *e);
/* POST /v1/views/{id}/pick: {"x", "y"}, both required, each in [0, 1] (normalised picture
 * coordinates, y down). */
bool srv_json_pick_request(const cJSON *obj, float point[2], srv_api_error *e);
/* A text message of the stream: {"type":"camera"|"resize"|"ack", ...}. */
bool srv_json_viewer_msg(const char *text, size_t len, srv_viewer_msg *out, srv_api_error *e);

cJSON *srv_json_camera(const srv_camera *c);
cJSON *srv_json_light(uint32_t id, const rd_light *l);
cJSON *srv_json_node(uint32_t id, const rd_node *n);
/* GET /v1/animation: {"count", "duration", "playing", "time"}, the time as of now_ms. */

/* Prints j compactly (malloc'd text) and deletes it. */
char *srv_json_print_delete(cJSON *j);
/* Adds an array of n floats (printed with float precision) to obj. */
void srv_json_add_floats(cJSON *obj, const char *name, const float *v, int n);
/* A float as the double that prints like the float ("0.97", not "0.97000002861022949"). */
double srv_json_float(float f);

/* Names of enumerations as the API spells them (settings: settings.h). */
const char *srv_light_type_name(uint32_t type);

#endif
