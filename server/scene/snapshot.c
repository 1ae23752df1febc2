/* snapshot.c: published API documents for readers that must not wait for the renderer. */
#include "server/scene/snapshot.h"

#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "server/api/api_json.h"
#include "server/scene/documents_json.h"
#include "server/base/clock.h"

typedef struct node_doc {
    cJSON *doc;
    uint64_t version; /* of its last event (0: none since the scene was loaded) */
} node_doc;

struct srv_snapshot {
    pthread_mutex_t mu;
    cJSON *docs[SRV_DOC_COUNT];
    uint64_t versions[SRV_DOC_COUNT];
    uint64_t clock; /* versions of all kinds come from one counter */
    node_doc *nodes;
    uint32_t node_count;
    uint64_t node_version;
    srv_view_info *views;
    unsigned view_count, view_cap;
    srv_view_limits limits;
    srv_playback playback;
    bool playback_set;
    srv_snapshot_listener listener;
    void *listener_user;
};

const char *srv_doc_name(srv_doc kind)
{
    static const char *names[SRV_DOC_COUNT] = {"scene", "lights", "settings", "views", "animation"};
    return kind < SRV_DOC_COUNT ? names[kind] : "?";
}

srv_snapshot *srv_snapshot_create(void)
{
    srv_snapshot *s = calloc(1, sizeof *s);
    if (!s) abort();
    pthread_mutex_init(&s->mu, NULL);
    return s;
}

static void free_nodes(srv_snapshot *s)
{
    for (uint32_t i = 0; i < s->node_count; i++)
        cJSON_Delete(s->nodes[i].doc);
    free(s->nodes);
    s->nodes = NULL;
    s->node_count = 0;
}

void srv_snapshot_destroy(srv_snapshot *s)
{
    if (!s) return;
    for (int k = 0; k < SRV_DOC_COUNT; k++)
        cJSON_Delete(s->docs[k]);
    free_nodes(s);
    free(s->views);
    pthread_mutex_destroy(&s->mu);
    free(s);
}

void srv_snapshot_set_listener(srv_snapshot *s, srv_snapshot_listener fn, void *user)
{
    pthread_mutex_lock(&s->mu);
    s->listener = fn;
    s->listener_user = user;
    pthread_mutex_unlock(&s->mu);
}

/* Calls the listener outside the lock. */
static void notify(srv_snapshot *s)
{
    pthread_mutex_lock(&s->mu);
    srv_snapshot_listener fn = s->listener;
    void *user = s->listener_user;
    pthread_mutex_unlock(&s->mu);
    if (fn) fn(user);
}

void srv_snapshot_publish(srv_snapshot *s, srv_doc kind, cJSON *doc, bool quiet)
{
    if (kind >= SRV_DOC_COUNT || kind == SRV_DOC_VIEWS || kind == SRV_DOC_ANIMATION) {
        cJSON_Delete(doc);
        return;
    }
    pthread_mutex_lock(&s->mu);
    cJSON_Delete(s->docs[kind]);
    s->docs[kind] = doc;
    if (!quiet) s->versions[kind] = ++s->clock;
    pthread_mutex_unlock(&s->mu);
    if (!quiet) notify(s);
}

void srv_snapshot_patch_scene(srv_snapshot *s, const char *name, cJSON *value)
{
    pthread_mutex_lock(&s->mu);
    if (s->docs[SRV_DOC_SCENE])
        cJSON_ReplaceItemInObjectCaseSensitive(s->docs[SRV_DOC_SCENE], name, value);
    else
        cJSON_Delete(value);
    pthread_mutex_unlock(&s->mu);
}

static cJSON *views_doc_locked(const srv_snapshot *s)
{
    cJSON *j = cJSON_CreateObject();
    cJSON *a = cJSON_AddArrayToObject(j, "views");
    for (unsigned i = 0; i < s->view_count; i++) {
        const srv_view_info *v = &s->views[i];
        cJSON *o = cJSON_CreateObject();
        cJSON_AddNumberToObject(o, "id", v->id);
        cJSON_AddStringToObject(o, "owner", v->http ? "http" : "viewer");
        cJSON_AddNumberToObject(o, "width", v->width);
        cJSON_AddNumberToObject(o, "height", v->height);
        cJSON_AddNumberToObject(o, "watchers", v->watchers);
        cJSON_AddItemToObject(o, "camera", srv_json_camera(&v->camera));
        cJSON_AddItemToArray(a, o);
    }
    cJSON *l = cJSON_AddObjectToObject(j, "limits");
    cJSON_AddNumberToObject(l, "max_views", s->limits.max_views);
    cJSON_AddNumberToObject(l, "max_pixels", s->limits.max_pixels);
    cJSON_AddNumberToObject(l, "max_total_pixels", (double)s->limits.max_total_pixels);
    return j;
}

char *srv_snapshot_print(srv_snapshot *s, srv_doc kind, uint64_t *version)
{
    if (kind >= SRV_DOC_COUNT) return NULL;
    pthread_mutex_lock(&s->mu);
    char *text = NULL;
    if (kind == SRV_DOC_VIEWS)
        text = srv_json_print_delete(views_doc_locked(s));
    else if (kind == SRV_DOC_ANIMATION && s->playback_set)
        text = srv_json_print_delete(srv_json_playback(&s->playback, srv_mono_ms()));
    else if (s->docs[kind])
        text = cJSON_PrintUnformatted(s->docs[kind]);
    if (version) *version = s->versions[kind];
    pthread_mutex_unlock(&s->mu);
    return text;
}

uint64_t srv_snapshot_version(srv_snapshot *s, srv_doc kind)
{
    pthread_mutex_lock(&s->mu);
    uint64_t v = kind < SRV_DOC_COUNT ? s->versions[kind] : 0;
    pthread_mutex_unlock(&s->mu);
    return v;
}

char *srv_snapshot_print_light(srv_snapshot *s, uint32_t id)
{
    char *text = NULL;
    pthread_mutex_lock(&s->mu);
    const cJSON *lights = cJSON_GetObjectItemCaseSensitive(s->docs[SRV_DOC_LIGHTS], "lights");
    const cJSON *l;
    cJSON_ArrayForEach(l, lights)
    {
        const cJSON *lid = cJSON_GetObjectItemCaseSensitive(l, "id");
        if (cJSON_IsNumber(lid) && lid->valuedouble == id) {
            text = cJSON_PrintUnformatted(l);
            break;
        }
    }
    pthread_mutex_unlock(&s->mu);
    return text;
}

void srv_snapshot_set_playback(srv_snapshot *s, const srv_playback *p, bool quiet)
{
    pthread_mutex_lock(&s->mu);
    s->playback = *p;
    s->playback_set = true;
    if (!quiet) s->versions[SRV_DOC_ANIMATION] = ++s->clock;
    pthread_mutex_unlock(&s->mu);
    if (!quiet) notify(s);
}

void srv_snapshot_set_nodes(srv_snapshot *s, cJSON **docs, uint32_t count)
{
    node_doc *nodes = calloc(count ? count : 1, sizeof *nodes);
    if (!nodes) abort();
    for (uint32_t i = 0; i < count; i++)
        nodes[i].doc = docs[i];
    pthread_mutex_lock(&s->mu);
    free_nodes(s);
    s->nodes = nodes;
    s->node_count = count;
    pthread_mutex_unlock(&s->mu);
}

void srv_snapshot_set_node(srv_snapshot *s, uint32_t id, cJSON *doc)
{
    pthread_mutex_lock(&s->mu);
    bool ok = id < s->node_count;
    if (ok) {
        /* the scene document lists the nodes too (its first ones): keep its copy current */
        cJSON *list = s->docs[SRV_DOC_SCENE]
                          ? cJSON_GetObjectItemCaseSensitive(s->docs[SRV_DOC_SCENE], "nodes")
                          : NULL;
        if (cJSON_IsArray(list) && id < (uint32_t)cJSON_GetArraySize(list))
            cJSON_ReplaceItemInArray(list, (int)id, cJSON_Duplicate(doc, 1));
        cJSON_Delete(s->nodes[id].doc);
        s->nodes[id].doc = doc;
        s->nodes[id].version = s->node_version = ++s->clock;
    }
    pthread_mutex_unlock(&s->mu);
    if (ok)
        notify(s);
    else
        cJSON_Delete(doc);
}

void srv_snapshot_pose_nodes(srv_snapshot *s, const uint32_t *ids, cJSON **docs, uint32_t n)
{
    pthread_mutex_lock(&s->mu);
    for (uint32_t k = 0; k < n; k++) {
        if (ids[k] < s->node_count) {
            cJSON_Delete(s->nodes[ids[k]].doc);
            s->nodes[ids[k]].doc = docs[k];
        } else {
            cJSON_Delete(docs[k]);
        }
    }
    pthread_mutex_unlock(&s->mu);
}

char *srv_snapshot_print_node(srv_snapshot *s, uint32_t id)
{
    pthread_mutex_lock(&s->mu);
    char *text = id < s->node_count ? cJSON_PrintUnformatted(s->nodes[id].doc) : NULL;
    pthread_mutex_unlock(&s->mu);
    return text;
}

uint64_t srv_snapshot_node_version(srv_snapshot *s)
{
    pthread_mutex_lock(&s->mu);
    uint64_t v = s->node_version;
    pthread_mutex_unlock(&s->mu);
    return v;
}

char *srv_snapshot_next_node(srv_snapshot *s, uint64_t after, uint64_t *version)
{
    pthread_mutex_lock(&s->mu);
    uint32_t best = UINT32_MAX;
    for (uint32_t i = 0; i < s->node_count; i++)
        if (s->nodes[i].version > after &&
            (best == UINT32_MAX || s->nodes[i].version < s->nodes[best].version))
            best = i;
    char *text = NULL;
    if (best != UINT32_MAX) {
        text = cJSON_PrintUnformatted(s->nodes[best].doc);
        *version = s->nodes[best].version;
    }
    pthread_mutex_unlock(&s->mu);
    return text;
}

void srv_snapshot_set_view(srv_snapshot *s, const srv_view_info *v, bool structural)
{
    pthread_mutex_lock(&s->mu);
    unsigned i = 0;
    while (i < s->view_count && s->views[i].id != v->id)
        i++;
    if (i == s->view_count) {
        if (s->view_count == s->view_cap) {
            s->view_cap = s->view_cap ? 2 * s->view_cap : 8;
            s->views = realloc(s->views, s->view_cap * sizeof *s->views);
            if (!s->views) abort();
        }
        s->view_count++;
        structural = true;
    }
    s->views[i] = *v;
    if (structural) s->versions[SRV_DOC_VIEWS] = ++s->clock;
    pthread_mutex_unlock(&s->mu);
    if (structural) notify(s);
}

void srv_snapshot_remove_view(srv_snapshot *s, uint32_t id)
{
    pthread_mutex_lock(&s->mu);
    bool found = false;
    for (unsigned i = 0; i < s->view_count; i++) {
        if (s->views[i].id != id) continue;
        memmove(&s->views[i], &s->views[i + 1], (s->view_count - i - 1) * sizeof *s->views);
        s->view_count--;
        s->versions[SRV_DOC_VIEWS] = ++s->clock;
        found = true;
        break;
    }
    pthread_mutex_unlock(&s->mu);
    if (found) notify(s);
}

void srv_snapshot_set_view_limits(srv_snapshot *s, const srv_view_limits *l)
{
    pthread_mutex_lock(&s->mu);
    s->limits = *l;
    pthread_mutex_unlock(&s->mu);
}

bool srv_snapshot_view(srv_snapshot *s, uint32_t id, srv_view_info *out)
{
    pthread_mutex_lock(&s->mu);
    bool found = false;
    for (unsigned i = 0; i < s->view_count && !found; i++)
        if (s->views[i].id == id) *out = s->views[i], found = true;
    pthread_mutex_unlock(&s->mu);
    return found;
}
