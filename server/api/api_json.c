/* api_json.c: strict JSON parsing of API bodies, the typed field readers it is made of, and the
 * number printing every document shares. See api_json.h for the contract and
 * protocol/openapi.yaml for the documents. */
#include "server/api/api_json.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "shaders/gpu_types.h"

#define BAD(...) (srv_api_fail(e, 400, SRV_ERR_INVALID_FIELD, __VA_ARGS__), false)

cJSON *srv_json_parse_object(const char *text, size_t len, srv_api_error *e)
{
    if (!text || len == 0) {
        srv_api_fail(e, 400, SRV_ERR_MALFORMED_JSON,
                     "The request body is empty; a JSON object is expected.");
        return NULL;
    }
    const char *end = NULL;
    cJSON *j = cJSON_ParseWithLengthOpts(text, len, &end, 0);
    if (!j) {
        size_t at = end && end >= text ? (size_t)(end - text) : 0;
        srv_api_fail(e, 400, SRV_ERR_MALFORMED_JSON,
                     "The body is not valid JSON (error near byte %zu).", at);
        return NULL;
    }
    for (const char *p = end; p && p < text + len; p++) {
        if (!isspace((unsigned char)*p)) {
            cJSON_Delete(j);
            srv_api_fail(e, 400, SRV_ERR_MALFORMED_JSON,
                         "The body has data after its JSON value (at byte %zu).",
                         (size_t)(p - text));
            return NULL;
        }
    }
    if (!cJSON_IsObject(j)) {
        cJSON_Delete(j);
        srv_api_fail(e, 400, SRV_ERR_MALFORMED_JSON, "The body must be a JSON object.");
        return NULL;
    }
    return j;
}

/* ---- typed field readers ------------------------------------------------------------------ */

bool srv_json_get_number(const cJSON *it, double lo, double hi, double *out, srv_api_error *e)
{
    if (!cJSON_IsNumber(it)) return BAD("Field '%s' must be a number.", it->string);
    double v = it->valuedouble;
    if (!isfinite(v) || v < lo || v > hi)
        return BAD("Field '%s' must be a number in [%g, %g].", it->string, lo, hi);
    *out = v;
    return true;
}

bool srv_json_get_float(const cJSON *it, double lo, double hi, float *out, srv_api_error *e)
{
    double v;
    if (!srv_json_get_number(it, lo, hi, &v, e)) return false;
    *out = (float)v;
    return true;
}

/* An array of exactly n finite numbers in [lo, hi]. */
static bool get_vec(const cJSON *it, int n, double lo, double hi, float *out, srv_api_error *e)
{
    if (!cJSON_IsArray(it) || cJSON_GetArraySize(it) != n)
        return BAD("Field '%s' must be an array of %d numbers.", it->string, n);
    int i = 0;
    const cJSON *x;
    cJSON_ArrayForEach(x, it)
    {
        if (!cJSON_IsNumber(x) || !isfinite(x->valuedouble) || x->valuedouble < lo ||
            x->valuedouble > hi)
            return BAD("Field '%s' must hold %d numbers in [%g, %g].", it->string, n, lo, hi);
        out[i++] = (float)x->valuedouble;
    }
    return true;
}

static bool nonzero(const float *v, int n)
{
    double s = 0;
    for (int i = 0; i < n; i++)
        s += (double)v[i] * v[i];
    return s > 1e-12;
}

static bool get_enum(const cJSON *it, const char *const *names, unsigned count, unsigned *out,
                     srv_api_error *e)
{
    if (cJSON_IsString(it)) {
        for (unsigned i = 0; i < count; i++) {
            if (strcmp(it->valuestring, names[i]) == 0) {
                *out = i;
                return true;
            }
        }
    }
    char list[160] = "";
    for (unsigned i = 0; i < count; i++) {
        strncat(list, i ? ", " : "", sizeof list - strlen(list) - 1);
        strncat(list, names[i], sizeof list - strlen(list) - 1);
    }
    return BAD("Field '%s' must be one of: %s.", it->string, list);
}

bool srv_json_once(unsigned *has, unsigned bit, const cJSON *it, srv_api_error *e)
{
    if (*has & bit) return BAD("Field '%s' appears more than once.", it->string);
    *has |= bit;
    return true;
}

#define LIMIT_COORD 1e7 /* metres: anything beyond is surely a client bug */

/* ---- camera -----------------------------------------------------------------------------------
 */

bool srv_json_camera_member(const cJSON *it, srv_camera_patch *p, bool *known, srv_api_error *e)
{
    const char *k = it->string;
    *known = true;
    if (strcmp(k, "position") == 0)
        return srv_json_once(&p->has, SRV_CAM_POSITION, it, e) &&
               get_vec(it, 3, -LIMIT_COORD, LIMIT_COORD, p->position, e);
    if (strcmp(k, "target") == 0)
        return srv_json_once(&p->has, SRV_CAM_TARGET, it, e) &&
               get_vec(it, 3, -LIMIT_COORD, LIMIT_COORD, p->target, e);
    if (strcmp(k, "forward") == 0) {
        if (!srv_json_once(&p->has, SRV_CAM_FORWARD, it, e) ||
            !get_vec(it, 3, -1e6, 1e6, p->forward, e))
            return false;
        return nonzero(p->forward, 3) || BAD("Field 'forward' must not be the zero vector.");
    }
    if (strcmp(k, "up") == 0) {
        if (!srv_json_once(&p->has, SRV_CAM_UP, it, e) || !get_vec(it, 3, -1e6, 1e6, p->up, e))
            return false;
        return nonzero(p->up, 3) || BAD("Field 'up' must not be the zero vector.");
    }
    if (strcmp(k, "orientation") == 0) {
        if (!srv_json_once(&p->has, SRV_CAM_ORIENTATION, it, e) ||
            !get_vec(it, 4, -1e6, 1e6, p->orientation, e))
            return false;
        return nonzero(p->orientation, 4) ||
               BAD("Field 'orientation' must be a non-zero quaternion.");
    }
    if (strcmp(k, "fov") == 0)
        return srv_json_once(&p->has, SRV_CAM_FOV, it, e) &&
               srv_json_get_float(it, 1, 170, &p->fov_deg, e);
    *known = false;
    return true;
}

bool srv_json_camera_consistent(const srv_camera_patch *p, srv_api_error *e)
{
    unsigned dirs = p->has & (SRV_CAM_TARGET | SRV_CAM_FORWARD | SRV_CAM_ORIENTATION);
    if (dirs & (dirs - 1)) return BAD("Give at most one of 'target', 'forward' and 'orientation'.");
    if ((p->has & SRV_CAM_ORIENTATION) && (p->has & SRV_CAM_UP))
        return BAD("'orientation' already defines 'up'; give one of them.");
    return true;
}

bool srv_json_camera_patch(const cJSON *obj, srv_camera_patch *out, srv_api_error *e)
{
    memset(out, 0, sizeof *out);
    const cJSON *it;
    cJSON_ArrayForEach(it, obj)
    {
        bool known;
        if (!srv_json_camera_member(it, out, &known, e)) return false;
        if (!known) return BAD("Unknown camera field '%s'.", it->string);
    }
    return srv_json_camera_consistent(out, e);
}

/* ---- lights --------------------------------------------------------------------------------- */

static const char *const light_types[] = {"point", "spot", "directional"};

const char *srv_light_type_name(uint32_t type)
{
    return type < 3 ? light_types[type] : "unknown";
}

bool srv_json_light_patch(const cJSON *obj, srv_light_patch *p, srv_api_error *e)
{
    memset(p, 0, sizeof *p);
    const cJSON *it;
    cJSON_ArrayForEach(it, obj)
    {
        const char *k = it->string;
        bool ok;
        if (strcmp(k, "type") == 0) {
            unsigned t = 0;
            ok = srv_json_once(&p->has, SRV_LIGHT_TYPE, it, e) &&
                 get_enum(it, light_types, 3, &t, e);
            p->type = t;
        } else if (strcmp(k, "name") == 0) {
            ok = srv_json_once(&p->has, SRV_LIGHT_NAME, it, e);
            if (ok && (!cJSON_IsString(it) || strlen(it->valuestring) >= SRV_NAME_MAX))
                ok = BAD("Field 'name' must be a string of at most %d bytes.", SRV_NAME_MAX - 1);
            if (ok) snprintf(p->name, sizeof p->name, "%s", it->valuestring);
        } else if (strcmp(k, "color") == 0) {
            ok = srv_json_once(&p->has, SRV_LIGHT_COLOR, it, e) &&
                 get_vec(it, 3, 0, 1e6, p->color, e);
        } else if (strcmp(k, "intensity") == 0) {
            ok = srv_json_once(&p->has, SRV_LIGHT_INTENSITY, it, e) &&
                 srv_json_get_float(it, 0, 1e9, &p->intensity, e);
        } else if (strcmp(k, "position") == 0) {
            ok = srv_json_once(&p->has, SRV_LIGHT_POSITION, it, e) &&
                 get_vec(it, 3, -LIMIT_COORD, LIMIT_COORD, p->position, e);
        } else if (strcmp(k, "direction") == 0) {
            ok = srv_json_once(&p->has, SRV_LIGHT_DIRECTION, it, e) &&
                 get_vec(it, 3, -1e6, 1e6, p->direction, e);
            if (ok && !nonzero(p->direction, 3))
                ok = BAD("Field 'direction' must not be the zero vector.");
        } else if (strcmp(k, "range") == 0) {
            ok = srv_json_once(&p->has, SRV_LIGHT_RANGE, it, e);
            if (ok && cJSON_IsNull(it))
                p->range = 0; /* unlimited */
            else if (ok)
                ok = srv_json_get_float(it, 0, 1e9, &p->range, e);
        } else if (strcmp(k, "inner_cone_angle") == 0) {
            ok = srv_json_once(&p->has, SRV_LIGHT_INNER_CONE, it, e) &&
                 srv_json_get_float(it, 0, M_PI / 2, &p->inner_cone, e);
        } else if (strcmp(k, "outer_cone_angle") == 0) {
            ok = srv_json_once(&p->has, SRV_LIGHT_OUTER_CONE, it, e) &&
                 srv_json_get_float(it, 0, M_PI / 2, &p->outer_cone, e);
        } else if (strcmp(k, "id") == 0 || strcmp(k, "node") == 0) {
            ok = BAD("Field '%s' is read-only.", k);
        } else {
            ok = BAD("Unknown light field '%s'.", k);
        }
        if (!ok) return false;
    }
    return true;
}

/* ---- nodes ---------------------------------------------------------------------------------- */

bool srv_json_node_patch(const cJSON *obj, srv_node_patch *p, srv_api_error *e)
{
    memset(p, 0, sizeof *p);
    const cJSON *it;
    cJSON_ArrayForEach(it, obj)
    {
        const char *k = it->string;
        bool ok;
        if (strcmp(k, "translation") == 0) {
            ok = srv_json_once(&p->has, SRV_NODE_TRANSLATION, it, e) &&
                 get_vec(it, 3, -LIMIT_COORD, LIMIT_COORD, p->translation, e);
        } else if (strcmp(k, "rotation") == 0) {
            ok = srv_json_once(&p->has, SRV_NODE_ROTATION, it, e) &&
                 get_vec(it, 4, -1e6, 1e6, p->rotation, e);
            if (ok && !nonzero(p->rotation, 4))
                ok = BAD("Field 'rotation' must be a non-zero quaternion.");
        } else if (strcmp(k, "scale") == 0) {
            ok = srv_json_once(&p->has, SRV_NODE_SCALE, it, e) &&
                 get_vec(it, 3, -1e6, 1e6, p->scale, e);
            for (int i = 0; ok && i < 3; i++)
                if (fabsf(p->scale[i]) < 1e-6f)
                    ok = BAD("Field 'scale' must not have zero components.");
        } else {
            ok =
                BAD("Unknown node field '%s' (translation, rotation and scale can be changed).", k);
        }
        if (!ok) return false;
    }
    if (!p->has) return BAD("Give at least one of 'translation', 'rotation' and 'scale'.");
    return true;
}

/* ---- animation playback ----------------------------------------------------------------- */

bool srv_json_playback_patch(const cJSON *obj, srv_playback_patch *p, srv_api_error *e)
{
    memset(p, 0, sizeof *p);
    const cJSON *it;
    cJSON_ArrayForEach(it, obj)
    {
        const char *k = it->string;
        bool ok;
        if (strcmp(k, "playing") == 0) {
            ok = srv_json_once(&p->has, SRV_PLAY_PLAYING, it, e) &&
                 (cJSON_IsBool(it) || BAD("Field 'playing' must be true or false."));
            p->playing = cJSON_IsTrue(it);
        } else if (strcmp(k, "time") == 0) {
            ok = srv_json_once(&p->has, SRV_PLAY_TIME, it, e) &&
                 ((cJSON_IsNumber(it) && isfinite(it->valuedouble) && it->valuedouble >= 0) ||
                  BAD("Field 'time' must be a finite number of seconds, 0 or more."));
            p->time_s = ok ? it->valuedouble : 0;
        } else {
            ok = BAD("Unknown animation field '%s' (playing and time can be changed).", k);
        }
        if (!ok) return false;
    }
    if (!p->has) return BAD("Give at least one of 'playing' and 'time'.");
    return true;
}

/* ---- picking -------------------------------------------------------------------------------- */

bool srv_json_pick_request(const cJSON *obj, float point[2], srv_api_error *e)
{
    unsigned has = 0;
    const cJSON *it;
    cJSON_ArrayForEach(it, obj)
    {
        const char *k = it->string;
        bool ok;
        if (strcmp(k, "x") == 0)
            ok = srv_json_once(&has, 1u, it, e) && srv_json_get_float(it, 0, 1, &point[0], e);
        else if (strcmp(k, "y") == 0)
            ok = srv_json_once(&has, 2u, it, e) && srv_json_get_float(it, 0, 1, &point[1], e);
        else
            ok = BAD("Unknown pick field '%s' (x and y, 0..1 across and down the picture).", k);
        if (!ok) return false;
    }
    if (has != 3u)
        return BAD("Give both 'x' and 'y': the point in the picture, 0..1 across and down.");
    return true;
}

/* ---- printing ------------------------------------------------------------------------------- */

double srv_json_float(float f)
{
    char buf[32];
    snprintf(buf, sizeof buf, "%.7g", (double)f);
    return strtod(buf, NULL) + 0.0; /* + 0.0 turns -0 into 0 */
}

void srv_json_add_floats(cJSON *obj, const char *name, const float *v, int n)
{
    cJSON *a = cJSON_AddArrayToObject(obj, name);
    for (int i = 0; i < n; i++)
        cJSON_AddItemToArray(a, cJSON_CreateNumber(srv_json_float(v[i])));
}

char *srv_json_print_delete(cJSON *j)
{
    char *s = cJSON_PrintUnformatted(j);
    cJSON_Delete(j);
    if (!s) abort(); /* out of memory */
    return s;
}
