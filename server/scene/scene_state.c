/* scene_state.c: the render thread's scene, camera and settings, and API patches applied to
 * them (validated first, then applied whole). */
#include "server/scene/scene_state.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "server/api/api_json.h"
#include "server/scene/documents_json.h"
#include "renderer/scene/xform.h"

#define BAD(...) (srv_api_fail(e, 400, SRV_ERR_INVALID_FIELD, __VA_ARGS__), false)

void srv_state_init(srv_scene_state *st)
{
    memset(st, 0, sizeof *st);
    rd_scene_init(&st->scene);
    srv_settings_defaults(&st->settings);
}

void srv_state_dispose(srv_scene_state *st)
{
    rd_scene_destroy(&st->scene);
    free(st->light_ids);
    free(st->node_moved);
    st->light_ids = NULL;
    st->node_moved = NULL;
    st->loaded = false;
}

static void *xcalloc(size_t n, size_t size)
{
    void *p = calloc(n ? n : 1, size);
    if (!p) abort(); /* out of memory is the one fatal error */
    return p;
}

/* ---- default lighting ------------------------------------------------------------------- */

/* The environment the settings ask for. */
static void settings_environment(const srv_settings *s, rd_environment *e)
{
    memset(e, 0, sizeof *e);
    e->mode = (rd_env_mode)s->sky_mode;
    memcpy(e->sky, s->sky, sizeof e->sky);
    memcpy(e->ground, s->sky_ground, sizeof e->ground);
    e->intensity = s->sky_intensity;
    e->rotation = s->sky_rotation * 3.14159265358979323846f / 180.0f;
}

void srv_state_environment(const srv_scene_state *st, rd_environment *e)
{
    settings_environment(&st->settings, e);
    if (st->default_lighting && !rd_default_lighting_env_lights(e))
        rd_default_lighting_environment(e);
}

/* The renderer's key light for the default camera, added through the API's path (an id). */
static void add_default_key_light(srv_scene_state *st)
{
    rd_view_camera v;
    srv_camera_to_view(&st->camera, &v);
    rd_light key;
    rd_default_lighting_key(&v, &key);
    srv_light_patch p = {.has = SRV_LIGHT_TYPE | SRV_LIGHT_COLOR | SRV_LIGHT_INTENSITY |
                                SRV_LIGHT_DIRECTION | SRV_LIGHT_NAME,
                         .type = key.type,
                         .intensity = key.intensity};
    memcpy(p.color, key.color, sizeof p.color);
    memcpy(p.direction, key.direction, sizeof p.direction);
    snprintf(p.name, sizeof p.name, "%s", key.name);
    srv_api_error e;
    uint32_t id;
    if (srv_state_light_add(st, &p, &id, &e)) {
        st->default_lighting = true;
        st->default_light_id = id;
    }
}

/* After a scene or a saved state arrived: default lighting on when the renderer's rule asks
 * for it under the settings' environment; off when its key light is gone (a saved state
 * replaced the lights). */
static void settle_default_lighting(srv_scene_state *st)
{
    if (st->default_lighting && srv_state_light_index(st, st->default_light_id) < 0)
        st->default_lighting = false;
    if (st->default_lighting) return;
    rd_environment env;
    settings_environment(&st->settings, &env);
    rd_default_lighting_decide(&st->scene, &env, &st->lighting);
    if (st->lighting.needed) add_default_key_light(st);
}

bool srv_state_drop_default_lighting(srv_scene_state *st)
{
    if (!st->default_lighting) return false;
    srv_api_error e;
    srv_state_light_delete(st, st->default_light_id, &e);
    st->default_lighting = false;
    return true;
}

void srv_state_set_scene(srv_scene_state *st, rd_scene *scene, const char *source,
                         uint64_t generation)
{
    rd_scene_destroy(&st->scene);
    free(st->light_ids);
    free(st->node_moved);
    st->scene = *scene;
    memset(scene, 0, sizeof *scene);
    st->light_ids = xcalloc(st->scene.light_count, sizeof *st->light_ids);
    for (uint32_t i = 0; i < st->scene.light_count; i++)
        st->light_ids[i] = st->next_light_id++;
    st->node_moved = xcalloc(st->scene.node_count, sizeof *st->node_moved);
    snprintf(st->source, sizeof st->source, "%s", source ? source : "");
    st->file_name[0] = '\0'; /* the caller names an uploaded file afterwards */
    st->generation = generation;
    st->loaded = true;

    rd_view_camera v;
    char err[256];
    if (!rd_camera_for_scene(&st->scene, -1, &v, err, sizeof err))
        rd_camera_frame_bounds(st->scene.bounds_min, st->scene.bounds_max, 0.7f, &v);
    float c[3], d[3];
    for (int i = 0; i < 3; i++)
        c[i] = 0.5f * (st->scene.bounds_min[i] + st->scene.bounds_max[i]);
    rd_vec3_sub(d, c, v.eye);
    float dist = rd_vec3_dot(d, v.forward);
    srv_camera_from_view(&v, dist > 1e-3f ? dist : 1.0f, &st->camera);
    st->default_lighting = false;
    settle_default_lighting(st);
}

int srv_state_light_index(const srv_scene_state *st, uint32_t id)
{
    for (uint32_t i = 0; i < st->scene.light_count; i++)
        if (st->light_ids[i] == id) return (int)i;
    return -1;
}

/* ---- camera -----------------------------------------------------------------------------------
 */

void srv_camera_from_view(const rd_view_camera *v, float target_distance, srv_camera *c)
{
    memcpy(c->position, v->eye, sizeof c->position);
    memcpy(c->forward, v->forward, sizeof c->forward);
    memcpy(c->up, v->up, sizeof c->up);
    c->fov_deg = v->yfov * 180.0f / (float)M_PI;
    c->target_distance = target_distance;
}

void srv_camera_to_view(const srv_camera *c, rd_view_camera *v)
{
    memcpy(v->eye, c->position, sizeof v->eye);
    memcpy(v->forward, c->forward, sizeof v->forward);
    memcpy(v->up, c->up, sizeof v->up);
    v->yfov = c->fov_deg * (float)M_PI / 180.0f;
}

static void quat_rotate(const float q[4], const float v[3], float out[3])
{
    /* v' = v + 2 w (u x v) + 2 u x (u x v), q = (u, w) normalised */
    float u[3] = {q[0], q[1], q[2]}, t[3], t2[3];
    rd_vec3_cross(t, u, v);
    rd_vec3_scale(t, t, 2);
    rd_vec3_cross(t2, u, t);
    for (int i = 0; i < 3; i++)
        out[i] = v[i] + q[3] * t[i] + t2[i];
}

static void quat_normalize(const float in[4], float out[4])
{
    double n = sqrt((double)in[0] * in[0] + (double)in[1] * in[1] + (double)in[2] * in[2] +
                    (double)in[3] * in[3]);
    for (int i = 0; i < 4; i++)
        out[i] = (float)(in[i] / n);
}

bool srv_state_camera_apply(srv_camera *cam, const srv_camera_patch *p, bool replace,
                            srv_api_error *e)
{
    const unsigned dir = SRV_CAM_TARGET | SRV_CAM_FORWARD | SRV_CAM_ORIENTATION;
    if (replace && (!(p->has & SRV_CAM_POSITION) || !(p->has & dir)))
        return BAD("PUT /v1/camera needs 'position' and one of 'target', 'forward' and "
                   "'orientation'.");
    srv_camera c = *cam;
    if (replace && !(p->has & SRV_CAM_UP)) rd_vec3_set(c.up, 0, 1, 0);
    if (p->has & SRV_CAM_POSITION) memcpy(c.position, p->position, sizeof c.position);
    if (p->has & SRV_CAM_TARGET) {
        float d[3];
        rd_vec3_sub(d, p->target, c.position);
        float len = rd_vec3_length(d);
        if (!(len > 1e-6f)) return BAD("The camera target must differ from its position.");
        rd_vec3_scale(c.forward, d, 1.0f / len);
        c.target_distance = len;
    }
    if (p->has & SRV_CAM_FORWARD) rd_vec3_normalize(c.forward, p->forward, NULL);
    if (p->has & SRV_CAM_ORIENTATION) {
        float q[4];
        const float nz[3] = {0, 0, -1}, y[3] = {0, 1, 0};
        quat_normalize(p->orientation, q);
        quat_rotate(q, nz, c.forward);
        quat_rotate(q, y, c.up);
    }
    if (p->has & SRV_CAM_UP) rd_vec3_normalize(c.up, p->up, NULL);
    if (p->has & SRV_CAM_FOV) c.fov_deg = p->fov_deg;
    float right[3];
    rd_vec3_cross(right, c.forward, c.up);
    if (rd_vec3_length(right) < 1e-4f) {
        if (p->has & SRV_CAM_UP)
            return BAD("The camera's 'up' must not be parallel to its view direction.");
        /* the old up happens to be parallel to the new direction: pick another */
        const float alt[3] = {0, 0, 1}, alt2[3] = {1, 0, 0};
        rd_vec3_cross(right, c.forward, fabsf(c.forward[2]) < 0.9f ? alt : alt2);
    }
    rd_vec3_normalize(right, right, NULL);
    rd_vec3_cross(c.up, right, c.forward);
    rd_vec3_normalize(c.up, c.up, NULL);
    if (!rd_vec3_isfinite(c.forward) || !rd_vec3_isfinite(c.up) || !rd_vec3_isfinite(c.position))
        return BAD("The camera would not be finite.");
    *cam = c;
    return true;
}

/* ---- lights -----------------------------------------------------------------------------------
 */

bool srv_state_light_apply(rd_light *l, const srv_light_patch *p, srv_api_error *e)
{
    rd_light n = *l;
    if (p->has & SRV_LIGHT_TYPE) n.type = p->type;
    if (p->has & SRV_LIGHT_COLOR) memcpy(n.color, p->color, sizeof n.color);
    if (p->has & SRV_LIGHT_INTENSITY) n.intensity = p->intensity;
    if (p->has & SRV_LIGHT_POSITION) memcpy(n.position, p->position, sizeof n.position);
    if (p->has & SRV_LIGHT_DIRECTION) rd_vec3_normalize(n.direction, p->direction, NULL);
    if (p->has & SRV_LIGHT_RANGE) n.range = p->range;
    if (p->has & SRV_LIGHT_INNER_CONE) n.inner_cone = p->inner_cone;
    if (p->has & SRV_LIGHT_OUTER_CONE) n.outer_cone = p->outer_cone;
    if (n.type == RD_LIGHT_SPOT && !(n.inner_cone < n.outer_cone))
        return BAD("A spot light needs inner_cone_angle < outer_cone_angle (got %g and %g).",
                   (double)n.inner_cone, (double)n.outer_cone);
    if (p->has & (SRV_LIGHT_POSITION | SRV_LIGHT_DIRECTION))
        n.node = -1; /* now placed in world space */
    if (p->has & SRV_LIGHT_NAME) {
        char *name = strdup(p->name);
        if (!name) abort();
        free(n.name);
        n.name = name;
    }
    *l = n;
    return true;
}

bool srv_state_light_add(srv_scene_state *st, const srv_light_patch *p, uint32_t *id,
                         srv_api_error *e)
{
    if (!(p->has & SRV_LIGHT_TYPE))
        return BAD("A new light needs 'type' (point, spot or directional).");
    rd_light l = {.name = NULL,
                  .type = p->type,
                  .color = {1, 1, 1},
                  .intensity = 1,
                  .outer_cone = (float)M_PI / 4,
                  .node = -1,
                  .direction = {0, -1, 0}};
    if (!srv_state_light_apply(&l, p, e)) return false;
    if (!l.name) {
        char fallback[32];
        snprintf(fallback, sizeof fallback, "light-%u", st->next_light_id);
        l.name = strdup(fallback);
        if (!l.name) abort();
    }
    uint32_t idx = rd_scene_add_light(&st->scene, &l); /* copies the name */
    free(l.name);
    uint32_t *ids = realloc(st->light_ids, st->scene.light_count * sizeof *ids);
    if (!ids) abort();
    st->light_ids = ids;
    st->light_ids[idx] = st->next_light_id++;
    *id = st->light_ids[idx];
    return true;
}

bool srv_state_light_delete(srv_scene_state *st, uint32_t id, srv_api_error *e)
{
    int i = srv_state_light_index(st, id);
    if (i < 0) {
        srv_api_fail(e, 404, SRV_ERR_NOT_FOUND, "There is no light with id %u.", id);
        return false;
    }
    uint32_t rest = st->scene.light_count - (uint32_t)i - 1;
    memmove(&st->light_ids[i], &st->light_ids[i + 1], rest * sizeof *st->light_ids);
    rd_scene_remove_light(&st->scene, (uint32_t)i);
    return true;
}

/* ---- nodes ------------------------------------------------------------------------------------
 */

/* TRS of an affine matrix without shear (glTF's rule for animated nodes). */
static void decompose(const float m[16], float t[3], float q[4], float s[3])
{
    t[0] = m[12], t[1] = m[13], t[2] = m[14];
    float cols[3][3];
    for (int c = 0; c < 3; c++) {
        for (int r = 0; r < 3; r++)
            cols[c][r] = m[c * 4 + r];
        s[c] = rd_vec3_length(cols[c]);
    }
    if (rd_mat4_det3(m) < 0) s[0] = -s[0];
    for (int c = 0; c < 3; c++)
        for (int r = 0; r < 3; r++)
            cols[c][r] = s[c] != 0 ? cols[c][r] / s[c] : (c == r);
    rd_mat3_cols_to_quat((const float(*)[3])cols, q);
}

bool srv_state_node_apply(srv_scene_state *st, uint32_t id, const srv_node_patch *p,
                          srv_api_error *e)
{
    if (id >= st->scene.node_count) {
        srv_api_fail(e, 404, SRV_ERR_NOT_FOUND, "There is no node with id %u (the scene has %u).",
                     id, st->scene.node_count);
        return false;
    }
    rd_node *n = &st->scene.nodes[id];
    rd_node old = *n;
    if (n->has_matrix) {
        decompose(n->matrix, n->translation, n->rotation, n->scale);
        n->has_matrix = false;
    }
    if (p->has & SRV_NODE_TRANSLATION)
        memcpy(n->translation, p->translation, sizeof n->translation);
    if (p->has & SRV_NODE_ROTATION) quat_normalize(p->rotation, n->rotation);
    if (p->has & SRV_NODE_SCALE) memcpy(n->scale, p->scale, sizeof n->scale);
    char err[256];
    if (!rd_scene_update(&st->scene, err, sizeof err)) {
        *n = old;
        rd_scene_update(&st->scene, err, sizeof err);
        srv_api_fail(e, 400, SRV_ERR_INVALID_FIELD, "The node cannot be moved: %s", err);
        return false;
    }
    st->node_moved[id] = true;
    return true;
}

/* Length of the UTF-8 sequence at p (1..4), or 0 when it is not one (overlong forms,
 * surrogates and code points past U+10FFFF included). */
static size_t utf8_len(const unsigned char *p)
{
    if (p[0] < 0x80) return 1;
    size_t n = p[0] >= 0xc2 && p[0] < 0xe0   ? 2
               : p[0] >= 0xe0 && p[0] < 0xf0 ? 3
               : p[0] >= 0xf0 && p[0] < 0xf5 ? 4
                                             : 0;
    if (!n) return 0;
    for (size_t i = 1; i < n; i++)
        if ((p[i] & 0xc0) != 0x80) return 0;
    if (n == 3 && ((p[0] == 0xe0 && p[1] < 0xa0) || (p[0] == 0xed && p[1] >= 0xa0))) return 0;
    if (n == 4 && ((p[0] == 0xf0 && p[1] < 0x90) || (p[0] == 0xf4 && p[1] >= 0x90))) return 0;
    return n;
}

bool srv_state_clean_file_name(const char *raw, char out[SRV_FILE_NAME_MAX])
{
    out[0] = '\0';
    if (!raw) return false;
    const char *base = raw;
    for (const char *p = raw; *p; p++)
        if (*p == '/' || *p == '\\') base = p + 1;
    size_t o = 0;
    const unsigned char *p = (const unsigned char *)base;
    while (*p) {
        size_t n = utf8_len(p);
        bool bad = n == 0 || (n == 1 && (*p < 0x20 || *p == 0x7f));
        if (bad) n = 1;
        if (o + (bad ? 1 : n) >= SRV_FILE_NAME_MAX) break;
        if (bad) {
            out[o++] = '_';
        } else {
            memcpy(out + o, p, n);
            o += n;
        }
        p += n;
    }
    out[o] = '\0';
    return o > 0;
}

/* ---- persistence document --------------------------------------------------------------- */

cJSON *srv_state_to_json(const srv_scene_state *st)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddItemToObject(j, "camera", srv_json_camera(&st->camera));
    cJSON_AddItemToObject(j, "settings", srv_json_settings(&st->settings));
    cJSON_AddStringToObject(j, "file_name", st->file_name);
    cJSON *lights = cJSON_AddArrayToObject(j, "lights");
    for (uint32_t i = 0; i < st->scene.light_count; i++)
        cJSON_AddItemToArray(lights, srv_json_light(st->light_ids[i], &st->scene.lights[i]));
    if (st->default_lighting)
        cJSON_AddNumberToObject(j, "default_lighting", st->default_light_id);
    else
        cJSON_AddFalseToObject(j, "default_lighting");
    cJSON *nodes = cJSON_AddArrayToObject(j, "nodes");
    for (uint32_t i = 0; i < st->scene.node_count; i++) {
        if (!st->node_moved[i]) continue;
        const rd_node *n = &st->scene.nodes[i];
        cJSON *o = cJSON_CreateObject();
        cJSON_AddNumberToObject(o, "id", i);
        srv_json_add_floats(o, "translation", n->translation, 3);
        srv_json_add_floats(o, "rotation", n->rotation, 4);
        srv_json_add_floats(o, "scale", n->scale, 3);
        cJSON_AddItemToArray(nodes, o);
    }
    return j;
}

/* A copy of obj without the named read-only members, for the patch parsers. */
static cJSON *without(const cJSON *obj, const char *a, const char *b)
{
    cJSON *c = cJSON_Duplicate(obj, 1);
    if (c && a) cJSON_DeleteItemFromObjectCaseSensitive(c, a);
    if (c && b) cJSON_DeleteItemFromObjectCaseSensitive(c, b);
    return c;
}

static bool vec_member(const cJSON *o, const char *name, int n, float *out)
{
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(o, name);
    if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) != n) return false;
    int i = 0;
    const cJSON *x;
    cJSON_ArrayForEach(x, a)
    {
        if (!cJSON_IsNumber(x) || !isfinite(x->valuedouble)) return false;
        out[i++] = (float)x->valuedouble;
    }
    return true;
}

bool srv_state_restore(srv_scene_state *st, const cJSON *doc, srv_api_error *e)
{
    e->message[0] = '\0';
    if (!cJSON_IsObject(doc)) return BAD("The saved state is not a JSON object.");
    const cJSON *cam = cJSON_GetObjectItemCaseSensitive(doc, "camera");
    const cJSON *settings = cJSON_GetObjectItemCaseSensitive(doc, "settings");
    const cJSON *lights = cJSON_GetObjectItemCaseSensitive(doc, "lights");
    const cJSON *nodes = cJSON_GetObjectItemCaseSensitive(doc, "nodes");
    srv_api_error ignored;
    if (cJSON_IsObject(settings)) {
        srv_settings_patch sp;
        if (srv_json_settings_patch(settings, &sp, e))
            srv_state_settings_apply(&st->settings, &sp, &ignored);
        else
            return false;
    }
    if (cJSON_IsObject(cam)) {
        srv_camera_patch cp = {.has =
                                   SRV_CAM_POSITION | SRV_CAM_FORWARD | SRV_CAM_UP | SRV_CAM_FOV};
        float target[3];
        const cJSON *fov = cJSON_GetObjectItemCaseSensitive(cam, "fov");
        if (!vec_member(cam, "position", 3, cp.position) ||
            !vec_member(cam, "forward", 3, cp.forward) || !vec_member(cam, "up", 3, cp.up) ||
            !cJSON_IsNumber(fov) || !(fov->valuedouble >= 1) || !(fov->valuedouble <= 170))
            return BAD("The saved camera is incomplete.");
        cp.fov_deg = (float)fov->valuedouble;
        if (!srv_state_camera_apply(&st->camera, &cp, true, e)) return false;
        if (vec_member(cam, "target", 3, target)) {
            float d[3];
            rd_vec3_sub(d, target, st->camera.position);
            float len = rd_vec3_length(d);
            if (len > 1e-6f) st->camera.target_distance = len;
        }
    }
    if (cJSON_IsArray(lights)) {
        /* the saved lights replace the scene's */
        for (uint32_t i = 0; i < st->scene.light_count; i++)
            free(st->scene.lights[i].name);
        st->scene.light_count = 0;
        const cJSON *l;
        uint32_t max_id = 0;
        bool any = false;
        cJSON_ArrayForEach(l, lights)
        {
            const cJSON *idj = cJSON_GetObjectItemCaseSensitive(l, "id");
            const cJSON *nodej = cJSON_GetObjectItemCaseSensitive(l, "node");
            cJSON *c = without(l, "id", "node");
            srv_light_patch lp;
            uint32_t id;
            bool ok = c && cJSON_IsNumber(idj) && srv_json_light_patch(c, &lp, e) &&
                      srv_state_light_add(st, &lp, &id, e);
            cJSON_Delete(c);
            if (!ok) {
                snprintf(e->message, sizeof e->message, "a saved light was skipped");
                continue;
            }
            uint32_t idx = st->scene.light_count - 1;
            st->light_ids[idx] = (uint32_t)idj->valuedouble;
            if (cJSON_IsNumber(nodej) && nodej->valuedouble >= 0 &&
                nodej->valuedouble < st->scene.node_count)
                st->scene.lights[idx].node = (int32_t)nodej->valuedouble;
            if (!any || st->light_ids[idx] > max_id) max_id = st->light_ids[idx];
            any = true;
        }
        if (any && max_id + 1 > st->next_light_id) st->next_light_id = max_id + 1;
    }
    if (cJSON_IsArray(nodes)) {
        const cJSON *n;
        cJSON_ArrayForEach(n, nodes)
        {
            const cJSON *idj = cJSON_GetObjectItemCaseSensitive(n, "id");
            cJSON *c = without(n, "id", NULL);
            srv_node_patch np;
            srv_api_error ne;
            bool ok = c && cJSON_IsNumber(idj) && idj->valuedouble >= 0 &&
                      srv_json_node_patch(c, &np, &ne) &&
                      srv_state_node_apply(st, (uint32_t)idj->valuedouble, &np, &ne);
            cJSON_Delete(c);
            if (!ok) snprintf(e->message, sizeof e->message, "a saved node was skipped");
        }
    }
    char err[256];
    rd_scene_update(&st->scene, err, sizeof err); /* places node-attached lights */
    /* the saved lights replaced the scene's: which of them is the default key light, if any */
    const cJSON *dl = cJSON_GetObjectItemCaseSensitive(doc, "default_lighting");
    if (cJSON_IsArray(lights)) {
        st->default_lighting = cJSON_IsNumber(dl) && dl->valuedouble >= 0;
        if (st->default_lighting) st->default_light_id = (uint32_t)dl->valuedouble;
    }
    settle_default_lighting(st);
    const cJSON *fn = cJSON_GetObjectItemCaseSensitive(doc, "file_name");
    if (cJSON_IsString(fn)) srv_state_clean_file_name(fn->valuestring, st->file_name);
    return true;
}
