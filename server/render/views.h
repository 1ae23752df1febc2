/* views.h: the daemon's views — one per stream connection, plus view 0 (the default view of
 * HTTP-only clients and version-1 viewers). Render thread only.
 *
 * A view is a camera, a size and its own GPU images (rd_view) over the shared world; it keeps
 * its last frame's info and, on the CPU JPEG path, its RGBA8 image (for still re-encodes:
 * frame_output.h), whether it owes a frame, and how many connections watch it. A view nobody
 * watches is never rendered. Sizes are clamped to the per-view and total pixel limits here, so no
 * caller can exceed them.
 */
#ifndef SRV_VIEWS_H
#define SRV_VIEWS_H

#include <stdbool.h>
#include <stdint.h>

#include "server/api/commands.h"
#include "server/encode/encoder_pool.h"
#include "renderer/view.h"
#include "server/scene/snapshot.h"

typedef struct srv_view {
    uint32_t id;
    srv_camera camera;
    unsigned width, height;
    unsigned watchers;           /* connections showing it */
    unsigned video_watchers;     /* of them, those sent video (the rest JPEG) */
    unsigned requests;           /* GET /v1/frame.jpg waiting for a frame of it */
    bool dirty;                  /* owes a frame */
    bool behind_world;           /* has not shown the world's last tick */
    bool need_still;             /* its last frame was interactive */
    unsigned renders_since_tick; /* frames since the world last advanced (scheduler.h) */
    bool in_flight; /* a frame of it is on the GPU (its images must not be written again) */
    double last_input_ms, last_render_ms;
    uint64_t input_ticket;  /* newest input command applied to it (frames carry it) */
    uint64_t last_frame_id; /* of its newest frame handed to the encoders */
    unsigned pt_samples;    /* progressive path tracing: samples accumulated */
    unsigned jpeg_cap;      /* its owner's JPEG quality cap, 1..100 (0: none; quality message) */
    unsigned fps_cap;       /* its owner's frame-rate cap, frames per second (0: none) */
    srv_image *last_image;  /* CPU JPEG path only (the GPU path re-encodes from gpu.rgba8) */
    srv_frame_info last_info;
    rd_view gpu;
    bool gpu_ok;
} srv_view;

typedef struct srv_views {
    srv_view **items;
    unsigned count, cap;
    unsigned cursor; /* round robin (scheduler.h) */
    unsigned max_views, max_pixels;
    uint64_t max_total_pixels;
} srv_views;

void srv_views_init(srv_views *vs, unsigned max_views, unsigned max_pixels,
                    uint64_t max_total_pixels);
/* Frees every view (GPU images included; the device must be idle). */
void srv_views_dispose(srv_views *vs);
srv_view *srv_views_find(srv_views *vs, uint32_t id);
int srv_views_index(const srv_views *vs, uint32_t id);
/* A new view of the requested size (clamped: srv_views_fit) and camera; NULL when max_views
 * views exist or the id is taken. It starts dirty, watched by nobody. */
srv_view *srv_views_add(srv_views *vs, uint32_t id, unsigned width, unsigned height,
                        const srv_camera *camera);
void srv_views_remove(srv_views *vs, uint32_t id);
/* Clamps a requested size for view id (0 when new): scaled down to max_pixels and to the pixels
 * the other views leave under max_total_pixels, then to SRV_SIDE_MIN..SRV_SIDE_MAX per side. */
void srv_views_fit(const srv_views *vs, uint32_t id, unsigned want_w, unsigned want_h, unsigned *w,
                   unsigned *h);
/* Marks every view dirty (the world changed); world_tick: they now show an older tick. */
void srv_views_mark_all(srv_views *vs, bool world_tick);
/* Sets a view's caps (0: none); true when they changed. A changed JPEG cap asks for a still
 * (the last image re-encoded under the new cap), so an idle view shows it at once. */
bool srv_view_set_caps(srv_view *v, unsigned jpeg_cap, unsigned fps_cap);
/* The JPEG quality to encode a frame of v at: base (a quality setting) under the view's cap. */
unsigned srv_view_quality(const srv_view *v, unsigned base);
/* Path tracing: the fewest samples among watched views (among all when none is watched). */
unsigned srv_views_pt_samples_min(const srv_views *vs);
/* The view as the snapshot shows it. */
void srv_view_info_of(const srv_view *v, srv_view_info *out);

#endif
