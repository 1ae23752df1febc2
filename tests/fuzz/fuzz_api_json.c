/* libFuzzer harness: arbitrary bytes as an HTTP JSON body (every patch parser) and as a
 * viewer's WebSocket text message. Build with -DPROBECAST_FUZZ=ON using clang. */
#include <stddef.h>
#include <stdint.h>

#include "server/api/api_json.h"
#include "server/stream/viewer_msg.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    srv_api_error e;
    srv_viewer_msg msg;
    srv_json_viewer_msg((const char *)data, size, &msg, &e);
    cJSON *obj = srv_json_parse_object((const char *)data, size, &e);
    if (!obj) return 0;
    srv_camera_patch cam;
    srv_light_patch light;
    srv_node_patch node;
    srv_settings_patch settings;
    srv_playback_patch playback;
    srv_json_camera_patch(obj, &cam, &e);
    srv_json_light_patch(obj, &light, &e);
    srv_json_node_patch(obj, &node, &e);
    srv_json_settings_patch(obj, &settings, &e);
    srv_json_playback_patch(obj, &playback, &e);
    float point[2];
    srv_json_pick_request(obj, point, &e);
    cJSON_Delete(obj);
    return 0;
}
