/* viewer_msg.c: the stream's viewer messages parsed strictly, with api_json.h's field readers.
 * See viewer_msg.h for the contract and protocol/stream.md for the messages. */
#include "server/stream/viewer_msg.h"

#include <math.h>
#include <string.h>

#include <stdio.h>

#include "protocol/stream.h"
#include "server/api/api_json.h"
#include "server/encode/video_encoder.h"

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
    } else if (strcmp(type->valuestring, "video") == 0) {
        /* only the types are checked here: a codec or cap that cannot be served is answered
         * with an error message (srv_viewer_video_request), not by closing */
        out->type = SRV_VIEWER_VIDEO;
        out->max_kbps = -1;
        unsigned has = 0;
        const cJSON *it;
        cJSON_ArrayForEach(it, j)
        {
            if (it == type) continue;
            if (strcmp(it->string, "codec") == 0) {
                ok = srv_json_once(&has, 1, it, e);
                if (ok && cJSON_IsString(it))
                    snprintf(out->codec, sizeof out->codec, "%s", it->valuestring);
                else if (ok && !cJSON_IsNull(it))
                    ok = BAD("Field 'codec' must be a string or null.");
            } else if (strcmp(it->string, "max_kbps") == 0) {
                ok = srv_json_once(&has, 2, it, e);
                if (ok && cJSON_IsNumber(it) && isfinite(it->valuedouble))
                    out->max_kbps = it->valuedouble;
                else if (ok && !cJSON_IsNull(it))
                    ok = BAD("Field 'max_kbps' must be a number or null.");
            } else
                ok = BAD("Unknown video message field '%s'.", it->string);
            if (!ok) break;
        }
        if (ok && has != 3)
            ok = BAD("A video message needs 'codec' (a string, or null) and 'max_kbps' (a number, "
                     "or null).");
    } else {
        ok = BAD("Unknown message type '%.40s' (camera, resize, follow, ack, quality or video).",
                 type->valuestring);
    }
    cJSON_Delete(j);
    return ok;
}

bool srv_viewer_video_request(const srv_viewer_msg *m, unsigned *format, unsigned *max_kbps,
                              char *why, size_t why_size)
{
    *format = PROTO_FORMAT_JPEG;
    *max_kbps = 0;
    if (m->codec[0]) {
        if (strcmp(m->codec, "vp9") == 0)
            *format = PROTO_FORMAT_VP9;
        else if (strcmp(m->codec, "vp8") == 0)
            *format = PROTO_FORMAT_VP8;
        else {
            /* names only printable characters of what was sent */
            char shown[sizeof m->codec];
            size_t i = 0;
            for (; m->codec[i] && i + 1 < sizeof shown; i++)
                shown[i] = m->codec[i] >= 0x20 && m->codec[i] < 0x7f && m->codec[i] != '"' &&
                                   m->codec[i] != '\\'
                               ? m->codec[i]
                               : '?';
            shown[i] = 0;
            snprintf(why, why_size, "Unknown codec '%s' (vp9, vp8, or null for JPEG).", shown);
            return false;
        }
    }
    if (m->max_kbps >= 0) {
        if (m->max_kbps != floor(m->max_kbps) || m->max_kbps < SRV_VIDEO_MIN_KBPS ||
            m->max_kbps > SRV_VIDEO_MAX_KBPS) {
            snprintf(why, why_size, "Field 'max_kbps' must be an integer in %u..%u, or null.",
                     SRV_VIDEO_MIN_KBPS, SRV_VIDEO_MAX_KBPS);
            return false;
        }
        *max_kbps = (unsigned)m->max_kbps;
    } else if (m->max_kbps != -1) {
        snprintf(why, why_size, "Field 'max_kbps' must be an integer in %u..%u, or null.",
                 SRV_VIDEO_MIN_KBPS, SRV_VIDEO_MAX_KBPS);
        return false;
    }
    return true;
}
