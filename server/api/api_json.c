/* api_json.c: strict JSON parsing of API bodies, the typed field readers it is made of, and the
 * number printing every document shares. See api_json.h for the contract and
 * protocol/openapi.yaml for the documents. */
#include "server/api/api_json.h"

#include <ctype.h>
#include <math.h>
#include <stddef.h>
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

/* ---- one shape for every patch: a table of fields --------------------------------------------
 * Each body (camera, light, node, animation playback, pick) is a table of its fields: the name,
 * the bit in the patch's `has`, what the value must be and where it goes (an offset into the
 * patch struct). parse_member reads one member by its table; parse_patch reads a whole object,
 * naming unknown fields with the body's own hint. */

typedef enum field_kind {
    FIELD_VEC,       /* n finite numbers in [lo, hi] (float[n]) */
    FIELD_FLOAT,     /* one number in [lo, hi] (float) */
    FIELD_RANGE,     /* a number in [lo, hi], or null: 0 (float) */
    FIELD_SECONDS,   /* a finite number >= 0 (double) */
    FIELD_BOOL,      /* true or false (bool) */
    FIELD_ENUM,      /* one of names[count] (uint32_t index) */
    FIELD_NAME,      /* a string shorter than SRV_NAME_MAX (char[SRV_NAME_MAX]) */
    FIELD_READ_ONLY, /* reported, never written */
} field_kind;

enum { CHECK_NONZERO = 1, CHECK_NO_ZERO_COMPONENT = 2 };

typedef struct patch_field {
    const char *name;
    unsigned bit;
    field_kind kind;
    size_t offset;
    int n;
    double lo, hi;
    unsigned check;
    const char *const *names; /* FIELD_ENUM */
    unsigned count;
} patch_field;

typedef struct patch_shape {
    const char *what; /* "Unknown <what> field" */
    const char *hint; /* appended to that message, "" or " (...)" */
    const patch_field *fields;
    size_t field_count;
    size_t has_offset; /* of the patch's `unsigned has` */
} patch_shape;

#define SHAPE(what, hint, fields, type)                                                            \
    {                                                                                              \
        what, hint, fields, sizeof fields / sizeof fields[0], offsetof(type, has)                  \
    }

static bool read_field(const patch_field *f, const cJSON *it, char *patch, srv_api_error *e)
{
    void *at = patch + f->offset;
    switch (f->kind) {
    case FIELD_VEC:
        if (!get_vec(it, f->n, f->lo, f->hi, at, e)) return false;
        if ((f->check & CHECK_NONZERO) && !nonzero(at, f->n))
            return f->n == 4 ? BAD("Field '%s' must be a non-zero quaternion.", f->name)
                             : BAD("Field '%s' must not be the zero vector.", f->name);
        for (int i = 0; (f->check & CHECK_NO_ZERO_COMPONENT) && i < f->n; i++)
            if (fabsf(((float *)at)[i]) < 1e-6f)
                return BAD("Field '%s' must not have zero components.", f->name);
        return true;
    case FIELD_RANGE:
        if (cJSON_IsNull(it)) {
            *(float *)at = 0;
            return true;
        }
        /* fall through */
    case FIELD_FLOAT:
        return srv_json_get_float(it, f->lo, f->hi, at, e);
    case FIELD_SECONDS:
        if (!cJSON_IsNumber(it) || !isfinite(it->valuedouble) || it->valuedouble < 0)
            return BAD("Field '%s' must be a finite number of seconds, 0 or more.", f->name);
        *(double *)at = it->valuedouble;
        return true;
    case FIELD_BOOL:
        if (!cJSON_IsBool(it)) return BAD("Field '%s' must be true or false.", f->name);
        *(bool *)at = cJSON_IsTrue(it);
        return true;
    case FIELD_ENUM: {
        unsigned v;
        if (!get_enum(it, f->names, f->count, &v, e)) return false;
        *(uint32_t *)at = v;
        return true;
    }
    case FIELD_NAME:
        if (!cJSON_IsString(it) || strlen(it->valuestring) >= SRV_NAME_MAX)
            return BAD("Field '%s' must be a string of at most %d bytes.", f->name,
                       SRV_NAME_MAX - 1);
        snprintf(at, SRV_NAME_MAX, "%s", it->valuestring);
        return true;
    case FIELD_READ_ONLY:
        return BAD("Field '%s' is read-only.", f->name);
    }
    return BAD("Field '%s' cannot be read.", f->name);
}

/* One member by the shape's table; *known = false (and true returned) for a name it lacks. */
static bool parse_member(const patch_shape *s, const cJSON *it, void *patch, bool *known,
                         srv_api_error *e)
{
    for (size_t i = 0; i < s->field_count; i++) {
        const patch_field *f = &s->fields[i];
        if (strcmp(it->string, f->name) != 0) continue;
        *known = true;
        unsigned *has = (unsigned *)((char *)patch + s->has_offset);
        return (f->kind == FIELD_READ_ONLY || srv_json_once(has, f->bit, it, e)) &&
               read_field(f, it, patch, e);
    }
    *known = false;
    return true;
}

/* A whole object: patch is zeroed, then every member must be one of the shape's fields. */
static bool parse_patch(const patch_shape *s, const cJSON *obj, void *patch, size_t size,
                        srv_api_error *e)
{
    memset(patch, 0, size);
    const cJSON *it;
    cJSON_ArrayForEach(it, obj)
    {
        bool known;
        if (!parse_member(s, it, patch, &known, e)) return false;
        if (!known) return BAD("Unknown %s field '%s'%s.", s->what, it->string, s->hint);
    }
    return true;
}

/* ---- camera -----------------------------------------------------------------------------------
 */

#define CAM(name, bit, kind, member, n, lo, hi, check)                                             \
    {                                                                                              \
        name, bit, kind, offsetof(srv_camera_patch, member), n, lo, hi, check, NULL, 0             \
    }
static const patch_field camera_fields[] = {
    CAM("position", SRV_CAM_POSITION, FIELD_VEC, position, 3, -LIMIT_COORD, LIMIT_COORD, 0),
    CAM("target", SRV_CAM_TARGET, FIELD_VEC, target, 3, -LIMIT_COORD, LIMIT_COORD, 0),
    CAM("forward", SRV_CAM_FORWARD, FIELD_VEC, forward, 3, -1e6, 1e6, CHECK_NONZERO),
    CAM("up", SRV_CAM_UP, FIELD_VEC, up, 3, -1e6, 1e6, CHECK_NONZERO),
    CAM("orientation", SRV_CAM_ORIENTATION, FIELD_VEC, orientation, 4, -1e6, 1e6, CHECK_NONZERO),
    CAM("fov", SRV_CAM_FOV, FIELD_FLOAT, fov_deg, 1, 1, 170, 0),
};
static const patch_shape camera_shape = SHAPE("camera", "", camera_fields, srv_camera_patch);

bool srv_json_camera_member(const cJSON *it, srv_camera_patch *p, bool *known, srv_api_error *e)
{
    return parse_member(&camera_shape, it, p, known, e);
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
    return parse_patch(&camera_shape, obj, out, sizeof *out, e) &&
           srv_json_camera_consistent(out, e);
}

/* ---- lights --------------------------------------------------------------------------------- */

static const char *const light_types[] = {"point", "spot", "directional"};

const char *srv_light_type_name(uint32_t type)
{
    return type < 3 ? light_types[type] : "unknown";
}

#define LIGHT(name, bit, kind, member, n, lo, hi, check)                                           \
    {                                                                                              \
        name, bit, kind, offsetof(srv_light_patch, member), n, lo, hi, check, NULL, 0              \
    }
static const patch_field light_fields[] = {
    {"type", SRV_LIGHT_TYPE, FIELD_ENUM, offsetof(srv_light_patch, type), 1, 0, 0, 0, light_types,
     3},
    LIGHT("name", SRV_LIGHT_NAME, FIELD_NAME, name, 1, 0, 0, 0),
    LIGHT("color", SRV_LIGHT_COLOR, FIELD_VEC, color, 3, 0, 1e6, 0),
    LIGHT("intensity", SRV_LIGHT_INTENSITY, FIELD_FLOAT, intensity, 1, 0, 1e9, 0),
    LIGHT("position", SRV_LIGHT_POSITION, FIELD_VEC, position, 3, -LIMIT_COORD, LIMIT_COORD, 0),
    LIGHT("direction", SRV_LIGHT_DIRECTION, FIELD_VEC, direction, 3, -1e6, 1e6, CHECK_NONZERO),
    LIGHT("range", SRV_LIGHT_RANGE, FIELD_RANGE, range, 1, 0, 1e9, 0), /* null: unlimited */
    LIGHT("inner_cone_angle", SRV_LIGHT_INNER_CONE, FIELD_FLOAT, inner_cone, 1, 0, M_PI / 2, 0),
    LIGHT("outer_cone_angle", SRV_LIGHT_OUTER_CONE, FIELD_FLOAT, outer_cone, 1, 0, M_PI / 2, 0),
    {"id", 0, FIELD_READ_ONLY, 0, 0, 0, 0, 0, NULL, 0},
    {"node", 0, FIELD_READ_ONLY, 0, 0, 0, 0, 0, NULL, 0},
};
static const patch_shape light_shape = SHAPE("light", "", light_fields, srv_light_patch);

bool srv_json_light_patch(const cJSON *obj, srv_light_patch *p, srv_api_error *e)
{
    return parse_patch(&light_shape, obj, p, sizeof *p, e);
}

/* ---- nodes ---------------------------------------------------------------------------------- */

#define NODE(name, bit, member, n, lo, hi, check)                                                  \
    {                                                                                              \
        name, bit, FIELD_VEC, offsetof(srv_node_patch, member), n, lo, hi, check, NULL, 0          \
    }
static const patch_field node_fields[] = {
    NODE("translation", SRV_NODE_TRANSLATION, translation, 3, -LIMIT_COORD, LIMIT_COORD, 0),
    NODE("rotation", SRV_NODE_ROTATION, rotation, 4, -1e6, 1e6, CHECK_NONZERO),
    NODE("scale", SRV_NODE_SCALE, scale, 3, -1e6, 1e6, CHECK_NO_ZERO_COMPONENT),
};
static const patch_shape node_shape =
    SHAPE("node", " (translation, rotation and scale can be changed)", node_fields, srv_node_patch);

bool srv_json_node_patch(const cJSON *obj, srv_node_patch *p, srv_api_error *e)
{
    if (!parse_patch(&node_shape, obj, p, sizeof *p, e)) return false;
    if (!p->has) return BAD("Give at least one of 'translation', 'rotation' and 'scale'.");
    return true;
}

/* ---- animation playback ----------------------------------------------------------------- */

static const patch_field playback_fields[] = {
    {"playing", SRV_PLAY_PLAYING, FIELD_BOOL, offsetof(srv_playback_patch, playing), 1, 0, 0, 0,
     NULL, 0},
    {"time", SRV_PLAY_TIME, FIELD_SECONDS, offsetof(srv_playback_patch, time_s), 1, 0, 0, 0, NULL,
     0},
};
static const patch_shape playback_shape =
    SHAPE("animation", " (playing and time can be changed)", playback_fields, srv_playback_patch);

bool srv_json_playback_patch(const cJSON *obj, srv_playback_patch *p, srv_api_error *e)
{
    if (!parse_patch(&playback_shape, obj, p, sizeof *p, e)) return false;
    if (!p->has) return BAD("Give at least one of 'playing' and 'time'.");
    return true;
}

/* ---- picking -------------------------------------------------------------------------------- */

typedef struct pick_patch {
    unsigned has;
    float point[2];
} pick_patch;

static const patch_field pick_fields[] = {
    {"x", 1u, FIELD_FLOAT, offsetof(pick_patch, point[0]), 1, 0, 1, 0, NULL, 0},
    {"y", 2u, FIELD_FLOAT, offsetof(pick_patch, point[1]), 1, 0, 1, 0, NULL, 0},
};
static const patch_shape pick_shape =
    SHAPE("pick", " (x and y, 0..1 across and down the picture)", pick_fields, pick_patch);

bool srv_json_pick_request(const cJSON *obj, float point[2], srv_api_error *e)
{
    pick_patch p;
    if (!parse_patch(&pick_shape, obj, &p, sizeof p, e)) return false;
    if (p.has != 3u)
        return BAD("Give both 'x' and 'y': the point in the picture, 0..1 across and down.");
    point[0] = p.point[0], point[1] = p.point[1];
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
