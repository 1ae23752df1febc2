/* snapshot.h: the published state that network threads read without waiting for the renderer.
 *
 * The render thread owns the scene; after every change it publishes the API documents here
 * (the bodies of GET /v1/scene, /v1/lights, /v1/settings, each node, each view's camera). GET
 * routes answer from these copies, so they never wait behind a frame, and the stream thread
 * sends them as events: each kind has a version that grows with every published change, and a
 * listener is told (from the publishing thread) so it can push the news to viewers.
 * Thread-safe: one mutex guards everything; documents are printed while it is held.
 */
#ifndef SRV_SNAPSHOT_H
#define SRV_SNAPSHOT_H

#include <cjson/cJSON.h>
#include <stdbool.h>
#include <stdint.h>

#include "server/api/commands.h"
#include "server/scene/playback.h"

typedef enum srv_doc {
    SRV_DOC_SCENE,     /* GET /v1/scene */
    SRV_DOC_LIGHTS,    /* GET /v1/lights */
    SRV_DOC_SETTINGS,  /* GET /v1/settings */
    SRV_DOC_VIEWS,     /* GET /v1/views (built from the view table below) */
    SRV_DOC_ANIMATION, /* GET /v1/animation (built from the playback clock below) */
    SRV_DOC_COUNT
} srv_doc;

/* The event name of a kind ("scene", "lights", "settings", "views", "animation"). */
const char *srv_doc_name(srv_doc kind);

/* One view as GET /v1/views shows it. */
typedef struct srv_view_info {
    uint32_t id;
    bool http; /* the default view (0), not owned by a stream connection */
    unsigned width, height;
    unsigned watchers;
    srv_camera camera;
} srv_view_info;

typedef struct srv_view_limits {
    unsigned max_views, max_pixels;
    uint64_t max_total_pixels;
} srv_view_limits;

typedef void (*srv_snapshot_listener)(void *user);
typedef struct srv_snapshot srv_snapshot;

srv_snapshot *srv_snapshot_create(void);
void srv_snapshot_destroy(srv_snapshot *s); /* NULL is fine */
void srv_snapshot_set_listener(srv_snapshot *s, srv_snapshot_listener fn, void *user);

/* Replaces a document (doc is taken; not SRV_DOC_VIEWS or SRV_DOC_ANIMATION). quiet: the GET answer
 * changes but no event is sent (e.g. the demo animation moving a light every frame). */
void srv_snapshot_publish(srv_snapshot *s, srv_doc kind, cJSON *doc, bool quiet);
/* Replaces member name of the scene document without an event (the probe field's progress). */
void srv_snapshot_patch_scene(srv_snapshot *s, const char *name, cJSON *value);
/* The document as malloc'd text and its version (NULL before the first publication). */
char *srv_snapshot_print(srv_snapshot *s, srv_doc kind, uint64_t *version);
uint64_t srv_snapshot_version(srv_snapshot *s, srv_doc kind);
/* One light of the lights document by id (malloc'd text), or NULL. */
char *srv_snapshot_print_light(srv_snapshot *s, uint32_t id);

/* The animation document: a copy of the render thread's playback clock, printed with the time
 * as of the moment it is read, so the time moves while playing without a publication per frame.
 * quiet: no event (the clock started or stopped because viewers came or went). */
void srv_snapshot_set_playback(srv_snapshot *s, const srv_playback *p, bool quiet);

/* Nodes: docs[i] is node i (taken). set_nodes replaces all (a new scene, no events per node);
 * set_node replaces one and makes it an event; pose_nodes replaces the n nodes ids[] (docs[k] is
 * node ids[k]) without events (an animation posed them). */
void srv_snapshot_set_nodes(srv_snapshot *s, cJSON **docs, uint32_t count);
void srv_snapshot_set_node(srv_snapshot *s, uint32_t id, cJSON *doc);
void srv_snapshot_pose_nodes(srv_snapshot *s, const uint32_t *ids, cJSON **docs, uint32_t n);
char *srv_snapshot_print_node(srv_snapshot *s, uint32_t id); /* NULL: no such node */
/* The version of the newest node event. */
uint64_t srv_snapshot_node_version(srv_snapshot *s);
/* The oldest node changed after version `after` (malloc'd text), with its version; NULL when
 * none. Walk with after = the returned version. */
char *srv_snapshot_next_node(srv_snapshot *s, uint64_t after, uint64_t *version);

/* Views. structural: the set of views, a size or the watchers changed (an event); a camera move
 * alone changes the GET answers only. */
void srv_snapshot_set_view(srv_snapshot *s, const srv_view_info *v, bool structural);
void srv_snapshot_remove_view(srv_snapshot *s, uint32_t id);
void srv_snapshot_set_view_limits(srv_snapshot *s, const srv_view_limits *l);
bool srv_snapshot_view(srv_snapshot *s, uint32_t id, srv_view_info *out);

#endif
