/* viewer_msg.c: the stream's viewer messages parsed strictly, with api_json.h's field readers.
 * See viewer_msg.h for the contract and protocol/stream.md for the messages. */
#include "server/stream/viewer_msg.h"

#include <math.h>
#include <string.h>

#include "server/api/api_json.h"

#define BAD(...) (srv_api_fail(e, 400, SRV_ERR_INVALID_FIELD, __VA_ARGS__), false)

/* An integer in [lo, hi]. */
static bool get_uint(const cJSON *it, double lo, double hi, unsigned *out, srv_api_error *e)
{
    if (!cJSON_IsNumber(it) || !isfinite(it->valuedouble) ||
        it->valuedouble != floor(it->valuedouble) || it->valuedouble < lo || it->valuedouble > hi)
        return BAD("Field '%s' must be an integer in %.0f..%.0f.", it->string, lo, hi);
    *out = (unsigned)it->valuedouble;
    return true;
}

bool srv_json_viewer_msg(const char *text, size_t len, srv_viewer_msg *out, srv_api_error *e)
{
    memset(out, 0, sizeof *out);
    if (len > SRV_VIEWER_MSG_MAX) {
        srv_api_fail(e, 400, SRV_ERR_TOO_LARGE, "Message of %zu bytes exceeds %d.", len,
                     SRV_VIEWER_MSG_MAX);
        return false;
    }
    cJSON *j = srv_json_parse_object(text, len, e);
    if (!j) return false;
    bool ok = true;
    const cJSON *type = cJSON_GetObjectItemCaseSensitive(j, "type");
    if (!cJSON_IsString(type)) {
        ok = BAD("A message needs a string 'type' (camera, resize, follow, ack or quality).");
    } else if (strcmp(type->valuestring, "camera") == 0) {
        out->type = SRV_VIEWER_CAMERA;
        bool have_seq = false;
        const cJSON *it;
        cJSON_ArrayForEach(it, j)
        {
            bool known;
            if (it == type) continue;
            if (strcmp(it->string, "seq") == 0) {
                if (have_seq)
                    ok = BAD("Field 'seq' appears more than once.");
                else
                    ok = get_uint(it, 0, 4294967295.0, &out->seq, e);
                have_seq = true;
            } else {
                ok = srv_json_camera_member(it, &out->camera, &known, e);
                if (ok && !known) ok = BAD("Unknown camera message field '%s'.", it->string);
            }
            if (!ok) break;
        }
        if (ok && !have_seq) ok = BAD("A camera message needs 'seq'.");
        if (ok) ok = srv_json_camera_consistent(&out->camera, e);
    } else if (strcmp(type->valuestring, "resize") == 0) {
        out->type = SRV_VIEWER_RESIZE;
        out->dpr = 1;
        unsigned has = 0;
        const cJSON *it;
        cJSON_ArrayForEach(it, j)
        {
            if (it == type) continue;
            if (strcmp(it->string, "width") == 0)
                ok = srv_json_once(&has, 1, it, e) && get_uint(it, 1, 16384, &out->width, e);
            else if (strcmp(it->string, "height") == 0)
                ok = srv_json_once(&has, 2, it, e) && get_uint(it, 1, 16384, &out->height, e);
            else if (strcmp(it->string, "dpr") == 0)
                ok = srv_json_once(&has, 4, it, e) && srv_json_get_float(it, 0.25, 8, &out->dpr, e);
            else
                ok = BAD("Unknown resize message field '%s'.", it->string);
            if (!ok) break;
        }
        if (ok && (has & 3) != 3) ok = BAD("A resize message needs 'width' and 'height'.");
    } else if (strcmp(type->valuestring, "follow") == 0) {
        out->type = SRV_VIEWER_FOLLOW;
        bool have = false;
        const cJSON *it;
        cJSON_ArrayForEach(it, j)
        {
            if (it == type) continue;
            if (strcmp(it->string, "view") == 0 && !have) {
                have = true;
                if (cJSON_IsNull(it))
                    out->follow_own = true;
                else
                    ok = get_uint(it, 0, 4294967295.0, &out->view, e);
            } else
                ok = BAD("Unexpected follow message field '%s'.", it->string);
            if (!ok) break;
        }
        if (ok && !have) ok = BAD("A follow message needs 'view' (a view id, or null).");
    } else if (strcmp(type->valuestring, "ack") == 0) {
        out->type = SRV_VIEWER_ACK;
        bool have = false;
        const cJSON *it;
        cJSON_ArrayForEach(it, j)
        {
            if (it == type) continue;
            if (strcmp(it->string, "frame") == 0 && !have) {
                double v = 0;
                ok = srv_json_get_number(it, 0, 9007199254740991.0, &v, e);
                if (ok && v != floor(v)) ok = BAD("Field 'frame' must be an integer.");
                out->frame = (uint64_t)v;
                have = true;
            } else
                ok = BAD("Unexpected ack message field '%s'.", it->string);
            if (!ok) break;
        }
        if (ok && !have) ok = BAD("An ack message needs 'frame'.");
    } else if (strcmp(type->valuestring, "quality") == 0) {
        out->type = SRV_VIEWER_QUALITY;
        unsigned has = 0;
        const cJSON *it;
        cJSON_ArrayForEach(it, j)
        {
            if (it == type) continue;
            bool jpeg = strcmp(it->string, "jpeg") == 0;
            if (jpeg || strcmp(it->string, "max_fps") == 0) {
                ok = srv_json_once(&has, jpeg ? 1 : 2, it, e);
                if (ok && !cJSON_IsNull(it))
                    ok = get_uint(it, 1, jpeg ? SRV_VIEW_JPEG_CAP_MAX : SRV_VIEW_FPS_CAP_MAX,
                                  jpeg ? &out->jpeg_cap : &out->fps_cap, e);
            } else
                ok = BAD("Unknown quality message field '%s'.", it->string);
            if (!ok) break;
        }
        if (ok && has != 3)
            ok = BAD("A quality message needs 'jpeg' and 'max_fps' (a number, or null).");
    } else {
        ok = BAD("Unknown message type '%.40s' (camera, resize, follow, ack or quality).",
                 type->valuestring);
    }
    cJSON_Delete(j);
    return ok;
}
